"""Stage 4, the pairing — paper §3.3 — reshaped cell graph → which cell edges carry curves,
how their ends continue each other at the nodes, and the chains of edges that are the curves.

The rules (the module docstring of :mod:`depixel.splines` has them in full): visible
edges separate dissimilar pixels; at a node where two curve edges meet they continue each
other, at a T-junction the contour edges continue over a shading edge (else the
straightest pair), and at one or four and more every curve ends. Not in the paper: the
boundaries between the colour bands of a region (:func:`band_edges`) are paired too. Its
own module because the pairing is pure graph work on integer arrays, separate from the
curves' geometry (:class:`depixel.splines.SplineSet`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .cells import CellGraph
from .params import Params
from .vector import linked_edges


class HalfEnds(NamedTuple):
    """The ends of the curve edges and how they continue each other at their nodes.

    Half-end ``2k`` is the ``u`` end of edge ``edges[k]``, ``2k + 1`` its ``v`` end."""

    edges: np.ndarray  # (K,) int64 the cell edges that carry curves
    node: np.ndarray  # (2K,) int64 node of each half-end
    partner: np.ndarray  # (2K,) int64 the half-end continuing it at its node, -1 where a curve ends


class Chains(NamedTuple):
    """Curves as flat slot arrays (see :class:`SplineSet`)."""

    curve_ptr: np.ndarray
    curve_nodes: np.ndarray
    curve_closed: np.ndarray
    slot_edges: np.ndarray
    slot_forward: np.ndarray



def visible_edges(cells: CellGraph) -> np.ndarray:
    """(E,) bool: edges between two pixels that are not linked (dissimilar colours)."""
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    return (left >= 0) & (right >= 0) & ~linked_edges(cells)


def shading_edges(cells: CellGraph, visible: np.ndarray, params: Params) -> np.ndarray:
    """(E,) bool: visible edges whose two colours are within ``shading_distance`` in YUV."""
    g = cells.graph
    yuv = g.yuv.reshape(-1, 3)
    alpha = g.rgba.reshape(-1, 4)[:, 3]
    left, right = np.maximum(cells.edge_pixels[:, 0], 0), np.maximum(cells.edge_pixels[:, 1], 0)
    dist = np.linalg.norm(yuv[left] - yuv[right], axis=1)
    clear_mismatch = (alpha[left] == 0) != (alpha[right] == 0)
    return visible & (dist <= params.shading_distance) & ~clear_mismatch


def band_edges(cells: CellGraph) -> np.ndarray:
    """(E,) bool: invisible edges (between linked, similar pixels) whose colours differ.

    Not in the paper, whose regions are shaded smoothly by its renderer (§3.5): in an SVG
    with one flat fill per face, the boundaries between the colour bands of one region
    become curves too, so the bands read as steps of a gradient rather than a mosaic of
    cells."""
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    rgba = cells.graph.rgba.reshape(-1, 4)
    differ = (rgba[np.maximum(left, 0)] != rgba[np.maximum(right, 0)]).any(axis=1)
    return (left >= 0) & (right >= 0) & linked_edges(cells) & differ


def pair_ends(cells: CellGraph, edges: np.ndarray, shading: np.ndarray) -> HalfEnds:
    """Pair the ends of the curve edges ``edges`` (K,) at every node, by the number of
    curve edges meeting there: two continue each other; at three (a T-junction) one pair
    is joined by :func:`_t_junction_pairs`; at one or four and more every curve ends."""
    node = cells.edges[edges].ravel()
    n_half = node.size
    partner = np.full(n_half, -1, dtype=np.int64)
    order = np.argsort(node, kind="stable")
    sorted_nodes = node[order]
    starts = np.flatnonzero(np.r_[True, sorted_nodes[1:] != sorted_nodes[:-1]])
    counts = np.diff(np.r_[starts, n_half])

    two = starts[counts == 2]
    partner[order[two]] = order[two + 1]
    partner[order[two + 1]] = order[two]

    three = starts[counts == 3]
    if three.size:
        h = np.stack([order[three], order[three + 1], order[three + 2]], axis=1)  # (T, 3)
        a, b = _t_junction_pairs(cells, node, h, shading[edges[h >> 1]])
        partner[a] = b
        partner[b] = a
    return HalfEnds(edges, node, partner)


def _t_junction_pairs(cells: CellGraph, node: np.ndarray, h: np.ndarray,
                      is_shading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two half-ends of each T-junction ``h`` (T, 3) that continue each other: the
    contour edges when exactly one of the three is a shading edge (``is_shading`` (T, 3)),
    else the pair closest to a straight line (the first such pair on a tie)."""
    here = node[h[:, 0]]
    other = node[h ^ 1]  # the far node of each edge
    direction = cells.nodes[other].astype(np.float64) - cells.nodes[here][:, None, :]
    direction /= np.linalg.norm(direction, axis=2, keepdims=True)
    pairs = np.array([(0, 1), (0, 2), (1, 2)])
    cosine = np.einsum("tpk,tpk->tp", direction[:, pairs[:, 0]], direction[:, pairs[:, 1]])
    # contour-over-shading rule: exactly one shading edge → join the other two
    one_shading = is_shading.sum(axis=1) == 1
    lone = np.argmax(is_shading, axis=1)  # index of the shading edge
    by_rule = 2 - lone  # the pair not containing `lone`: (1,2)→idx 2, (0,2)→1, (0,1)→0
    straightest = np.argmin(cosine, axis=1)  # closest to 180° (first on ties)
    choice = np.where(one_shading, by_rule, straightest)
    rows = np.arange(h.shape[0])
    return h[rows, pairs[choice, 0]], h[rows, pairs[choice, 1]]


def chain_curves(half_ends: HalfEnds) -> Chains:
    """Walk paired half-ends into curves (open ones first from their free ends, then loops)."""
    vis, end_node, partner = half_ends
    n_vis = vis.size
    used = np.zeros(n_vis, dtype=bool)
    ptr = [0]
    nodes: list[int] = []
    edges: list[int] = []
    forward: list[bool] = []
    closed: list[bool] = []
    partner_l = partner.tolist()
    end_l = end_node.tolist()
    vis_l = vis.tolist()

    def walk(h: int) -> bool:
        """Follow from half-end h (the start of an edge); return True if the walk closed."""
        start_edge = h >> 1
        while True:
            k = h >> 1
            used[k] = True
            nodes.append(end_l[h])
            edges.append(vis_l[k])
            forward.append(h & 1 == 0)
            far = h ^ 1
            nxt = partner_l[far]
            if nxt < 0:
                nodes.append(end_l[far])
                edges.append(-1)
                forward.append(True)
                return False
            if nxt >> 1 == start_edge:
                return True
            h = nxt

    free = [h for h in range(2 * n_vis) if partner_l[h] < 0]
    for h in free:
        if not used[h >> 1]:
            closed.append(walk(h))
            ptr.append(len(nodes))
    for k in range(n_vis):
        if not used[k]:
            closed.append(walk(2 * k))
            ptr.append(len(nodes))
    return Chains(
        np.array(ptr, dtype=np.int64),
        np.array(nodes, dtype=np.int64),
        np.array(closed, dtype=bool),
        np.array(edges, dtype=np.int64),
        np.array(forward, dtype=bool),
    )
