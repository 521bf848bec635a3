"""Stage 4, the pairing — paper §3.3 — reshaped cell graph → which cell edges carry curves,
how their ends continue each other at the nodes, and the chains of edges that are the curves.

The rules (the module docstring of :mod:`depixel.curves.splines` has them in full): visible
edges separate dissimilar pixels; at a node where two curve edges meet they continue each
other, at a T-junction the contour edges continue over a shading edge (else the
straightest pair), and at one or four and more every curve ends. Not in the paper: the
boundaries between the colour bands of a region (:func:`band_edges`) are paired too. Its
own module because the pairing is pure graph work on integer arrays, separate from the
curves' geometry (:class:`depixel.curves.splines.SplineSet`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import both, ranges
from ..graph.cells import INDEX, CellGraph
from ..graph.components import cycle_leaders
from ..params import Params
from ..vector import linked_edges


class HalfEnds(NamedTuple):
    """The ends of the curve edges and how they continue each other at their nodes.

    Half-end ``2k`` is the ``u`` end of edge ``edges[k]``, ``2k + 1`` its ``v`` end."""

    edges: np.ndarray  # (K,) int32 the cell edges that carry curves
    node: np.ndarray  # (2K,) int32 node of each half-end
    partner: np.ndarray  # (2K,) int32 the half-end continuing it at its node, -1 where a curve ends


class Chains(NamedTuple):
    """Curves as flat slot arrays (see :class:`SplineSet`), indices int32."""

    curve_ptr: np.ndarray
    curve_nodes: np.ndarray
    curve_closed: np.ndarray
    slot_edges: np.ndarray
    slot_forward: np.ndarray



def visible_edges(cells: CellGraph, linked: np.ndarray | None = None) -> np.ndarray:
    """(E,) bool: edges between two pixels that are not linked (dissimilar colours);
    ``linked`` is :func:`linked_edges` if the caller has it."""
    linked = linked_edges(cells) if linked is None else linked
    return _both_inside(cells) & ~linked


def shading_edges(cells: CellGraph, visible: np.ndarray, params: Params) -> np.ndarray:
    """(E,) bool: visible edges whose two colours are within ``shading_distance`` in YUV."""
    g = cells.graph
    at = visible.nonzero()[0]  # only they can be shading edges
    # both inside; rows gathered (a strided column's take copies the whole column first)
    left, right = cells.edge_pixels.take(at, axis=0).T
    yuv = g.yuv().reshape(-1, 3)
    # the norm of the YUV difference a channel at a time (numpy's row gathers of an (N, 3)
    # array copy row by row), the squares summed in the order ``np.linalg.norm`` sums them
    square = np.zeros(at.size)
    for channel in range(3):
        column = yuv[:, channel]
        delta = column.take(left)
        delta -= column.take(right)
        delta *= delta
        square += delta
    alpha = g.rgba.reshape(-1, 4)[:, 3]
    clear_mismatch = (alpha.take(left) == 0) != (alpha.take(right) == 0)
    shading = np.zeros(visible.shape, bool)
    shading[at] = (np.sqrt(square) <= params.shading_distance) & ~clear_mismatch
    return shading


def band_edges(cells: CellGraph, linked: np.ndarray | None = None) -> np.ndarray:
    """(E,) bool: invisible edges (between linked, similar pixels) whose colours differ;
    ``linked`` is :func:`linked_edges` if the caller has it.

    Not in the paper, whose regions are shaded smoothly by its renderer (§3.5): in an SVG
    with one flat fill per face, the boundaries between the colour bands of one region
    become curves too, so the bands read as steps of a gradient rather than a mosaic of
    cells."""
    linked = linked_edges(cells) if linked is None else linked
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    colour = np.ascontiguousarray(cells.graph.rgba).view(np.uint32).ravel()  # one number per RGBA
    differ = colour.take(np.maximum(left, 0)) != colour.take(np.maximum(right, 0))
    return _both_inside(cells) & linked & differ


def _both_inside(cells: CellGraph) -> np.ndarray:
    """(E,) bool: both pixels of each edge are inside the image (neither is -1)."""
    return both(cells.edge_pixels >= 0)


def pair_ends(cells: CellGraph, edges: np.ndarray, shading: np.ndarray) -> HalfEnds:
    """Pair the ends of the curve edges ``edges`` (K,) at every node, by the number of
    curve edges meeting there: two continue each other; at three (a T-junction) one pair
    is joined by :func:`_t_junction_pairs`; at one or four and more every curve ends."""
    n_half = 2 * edges.size
    node = cells.edges.take(edges, axis=0).reshape(-1)  # the ends of each edge in turn: its row, flattened
    partner = np.full(n_half, -1, dtype=INDEX)
    order = node.argsort(kind="stable")
    sorted_nodes = node.take(order)
    new_node = np.empty(n_half + 1, dtype=bool)  # where each node's run starts, and the end
    new_node[0] = new_node[-1] = True
    np.not_equal(sorted_nodes[1:], sorted_nodes[:-1], out=new_node[1:-1])
    bounds = new_node.nonzero()[0]
    starts, counts = bounds[:-1], bounds[1:] - bounds[:-1]

    two = starts[counts == 2]
    partner[order[two]] = order[two + 1]
    partner[order[two + 1]] = order[two]

    three = starts[counts == 3]
    if three.size:
        h = order.take(three[:, None] + np.arange(3))  # (T, 3)
        a, b = _t_junction_pairs(cells, node, h, shading[edges[h >> 1]])
        partner[a] = b
        partner[b] = a
    return HalfEnds(edges.astype(INDEX), node, partner)


#: the three pairs of a T-junction's ends: first and second members
_PAIRS = np.array([(0, 0, 1), (1, 2, 2)])


def _t_junction_pairs(cells: CellGraph, node: np.ndarray, h: np.ndarray,
                      is_shading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two half-ends of each T-junction ``h`` (T, 3) that continue each other: the
    contour edges when exactly one of the three is a shading edge (``is_shading`` (T, 3)),
    else the pair closest to a straight line (the first such pair on a tie).

    The unit directions as x and y planes (T, 3): the same numbers as ``np.linalg.norm``
    over an (T, 3, 2) array and the sums of ``np.einsum`` over its last axis (two products
    added), without their Python wrappers and inner loops of two."""
    t = h.shape[0]
    here = cells.nodes.take(node.take(h[:, 0]), axis=0)  # rows gathered: a column's take copies it whole
    other = cells.nodes.take(node.take(h ^ 1).reshape(-1), axis=0)  # the far node of each edge
    dx = other[:, 0].reshape(t, 3) - here[:, :1].astype(np.float64)
    dy = other[:, 1].reshape(t, 3) - here[:, 1:].astype(np.float64)
    norm = np.sqrt(dx * dx + dy * dy)
    dx /= norm
    dy /= norm
    first, second = _PAIRS  # the pairs (0, 1), (0, 2), (1, 2)
    cosine = dx.take(first, axis=1) * dx.take(second, axis=1)
    cosine += dy.take(first, axis=1) * dy.take(second, axis=1)
    # contour-over-shading rule: exactly one shading edge → join the other two
    one_shading = np.add.reduce(is_shading, axis=1) == 1
    lone = is_shading.argmax(axis=1)  # index of the shading edge
    by_rule = 2 - lone  # the pair not containing `lone`: (1,2)→idx 2, (0,2)→1, (0,1)→0
    straightest = cosine.argmin(axis=1)  # closest to 180° (first on ties)
    choice = np.where(one_shading, by_rule, straightest)
    row = np.arange(0, 3 * t, 3)
    flat = h.reshape(-1)
    return flat.take(row + first.take(choice)), flat.take(row + second.take(choice))


def chain_curves(half_ends: HalfEnds) -> Chains:
    """Walk paired half-ends into curves: the open ones first, each from the first of its
    two free ends, in the order of those ends; then the closed ones, each from the ``u`` end
    of its first edge, in the order of those edges.

    Vectorized as the cycles of a permutation of walk states: state ``s`` runs along edge
    ``s >> 1`` from its end ``s``; it continues with the partner of the far end ``s ^ 1``,
    or, where the curve ends, turns back along the same edge (state ``s ^ 1``). An open
    curve is then one cycle, there and back from either free end; a closed curve two
    cycles, one each way, the one through state ``2k`` of its first edge ``k`` led by it."""
    vis, end_node, partner = half_ends
    n = end_node.size
    state = np.arange(n, dtype=INDEX)
    far = state ^ 1
    after = partner.take(far)
    nxt = np.where(after >= 0, after, far)
    del after, far
    leader, position = cycle_leaders(nxt)
    del nxt
    length = np.bincount(leader, minlength=n).astype(INDEX)  # of the cycle each state leads
    free = (partner < 0).nonzero()[0]  # ascending
    # each open curve's first free end, in the order of those ends: the free ends whose
    # leader no earlier free end has (a stable sort by leader; no np.unique, a Python
    # function of ~10 calls, and no sort by start)
    free_lead = leader.take(free)
    by_lead = free_lead.argsort(kind="stable")
    led = free_lead.take(by_lead)
    run_start = np.empty(free.size, dtype=bool)
    run_start[:1] = True
    np.not_equal(led[1:], led[:-1], out=run_start[1:])
    first = np.empty(free.size, dtype=bool)
    first.put(by_lead, run_start)  # from the sorted order back to the order of the free ends
    open_lead, open_start = free_lead.compress(first), free.compress(first)
    is_open = np.zeros(n, dtype=bool)
    is_open[open_lead] = True
    closed_lead = ((leader == state) & (state % 2 == 0) & ~is_open).nonzero()[0]
    del is_open
    n_open = open_lead.size
    counts = np.concatenate([length.take(open_lead) // 2 + 1, length.take(closed_lead)])  # slots per curve
    ptr = np.zeros(counts.size + 1, dtype=INDEX)
    counts.cumsum(out=ptr[1:])
    # each state's curve (-1: the way back of an open curve, the other way of a closed one)
    # and its place on the curve, counted from the curve's first state
    rank = np.full(n, -1, dtype=INDEX)
    rank[open_lead] = np.arange(n_open)
    rank[closed_lead] = n_open + np.arange(closed_lead.size)
    origin = np.zeros(n, dtype=INDEX)
    origin[open_lead] = position.take(open_start)
    curve = rank.take(leader)
    del rank
    offset = position.astype(INDEX)
    del position
    offset -= origin.take(leader)
    del origin
    offset %= np.maximum(length.take(leader), 1)
    del leader, length
    kept = (curve >= 0).nonzero()[0]  # the states on a curve (state s is index s)
    curve, offset = curve.take(kept), offset.take(kept)
    there = offset < counts.take(curve)  # an open curve's way there, and its far end
    kept, curve, offset = kept.compress(there), curve.compress(there), offset.compress(there)
    slot = ptr.take(curve) + offset
    del state, curve, offset, there
    nodes = np.empty(ptr[-1], dtype=INDEX)
    edges = np.empty(ptr[-1], dtype=INDEX)
    forward = np.empty(ptr[-1], dtype=bool)
    nodes.put(slot, end_node.take(kept))
    edges.put(slot, vis.take(kept >> 1))
    forward.put(slot, (kept & 1) == 0)
    last = ptr[1 : n_open + 1] - 1  # an open curve's far end: no edge leaves it
    edges[last] = -1
    forward[last] = True
    closed = np.zeros(counts.size, dtype=bool)
    closed[n_open:] = True
    return Chains(ptr, nodes, closed, edges, forward)


def cut_chains(chains: Chains, curve_edges: np.ndarray, n_edges: int, breaks: np.ndarray) -> Chains:
    """:func:`chain_curves` of the same pairing with every pair at a node of ``breaks`` (N,)
    bool undone, read off ``chains`` (the chains of the whole pairing, whose curve edges are
    ``curve_edges``, the :class:`HalfEnds` ``edges``, of ``n_edges`` cell edges) instead of
    walked again.

    Every curve through a break is cut there into pieces: an open curve between its ends and
    its slots at a break, a closed one between its slots at a break, around (one break: one
    piece from that slot all the way round to it). A piece is an open curve; as
    :func:`chain_curves` orders them, it runs from the lower of its two end half-ends (half-end
    ``2k`` is the ``u`` end of ``curve_edges[k]``, ``2k + 1`` its ``v`` end: reversed where the
    far end's is the lower) and the pieces, the open curves no break touches among them, come
    in the order of those half-ends; the closed curves no break touches follow, in their order.
    """
    ptr, nodes, closed, edges, forward = chains
    n_curves = closed.size
    size = ptr[1:] - ptr[:-1]
    first_slot, last_slot = ptr[:-1], ptr[1:] - 1
    curve = np.arange(n_curves, dtype=INDEX).repeat(size)  # of each slot
    cut = breaks.take(nodes)
    cut_closed = closed & (np.bincount(curve.compress(cut), minlength=n_curves) > 0)
    # the slots that bound the pieces: a break, and an open curve's two ends
    is_open = ~closed
    bound = cut.copy()
    bound[first_slot.compress(is_open)] = True
    bound[last_slot.compress(is_open)] = True
    at = bound.nonzero()[0]  # by curve, then along it
    owner = curve.take(at)
    curve_last = np.empty(at.size, dtype=bool)  # the last bound of its curve
    curve_last[-1:] = True
    np.not_equal(owner[1:], owner[:-1], out=curve_last[:-1])
    # each bound starts a piece reaching the next bound of its curve, except an open curve's
    # far end; the last bound of a closed curve reaches round to its first (its place + size)
    curve_first = np.empty(at.size, dtype=bool)
    curve_first[:1] = True
    curve_first[1:] = curve_last[:-1]
    first_bound = at.take(np.maximum.accumulate(np.where(curve_first, np.arange(at.size), 0)))
    end = np.empty(at.size, dtype=np.int64)
    end[:-1] = at[1:]
    end = np.where(curve_last, first_bound + size.take(owner), end)  # only closed curves' are used
    starts = ~(curve_last & is_open.take(owner))
    start, end, owner = at.compress(starts), end.compress(starts), owner.compress(starts)
    # the half-end leaving each slot along its edge; a piece's far end is the other end of
    # the edge arriving there (a place past its curve's last slot is a closed curve's, round)
    half = np.zeros(n_edges, dtype=np.int64)
    half[curve_edges] = np.arange(0, 2 * curve_edges.size, 2)

    def round_(place: np.ndarray, of: np.ndarray) -> np.ndarray:
        return place - size.take(of) * (place > last_slot.take(of))

    def leaving(slot: np.ndarray) -> np.ndarray:
        return half.take(edges.take(slot)) + ~forward.take(slot)

    near, far = leaving(start), leaving(round_(end - 1, owner)) ^ 1
    reverse = far < near
    order = np.minimum(near, far).argsort()
    start, end, owner, reverse = start.take(order), end.take(order), owner.take(order), reverse.take(order)
    kept = (closed & ~cut_closed).nonzero()[0]  # the closed curves no break touches
    counts = np.concatenate([end - start + 1, size.take(kept)])
    new_ptr = np.zeros(counts.size + 1, dtype=INDEX)
    counts.cumsum(out=new_ptr[1:])
    # the pieces' slots: from their start forwards, or from their end backwards, where an
    # edge leaving a slot backwards is the one arriving there, the other way round
    n_pieces = start.size
    step = ranges(0, counts[:n_pieces])
    piece = np.arange(n_pieces).repeat(counts[:n_pieces])
    backwards = reverse.take(piece)
    place = np.where(backwards, end.take(piece) - step, start.take(piece) + step)
    of = owner.take(piece)
    slot = round_(place, of)
    edge_slot = round_(place - backwards, of)  # the last slot's is overwritten below
    whole = ranges(first_slot.take(kept), size.take(kept))
    slot = np.concatenate([slot, whole])
    edge_slot = np.concatenate([edge_slot, whole])
    new_edges = edges.take(edge_slot)
    new_forward = forward.take(edge_slot)
    new_forward[:backwards.size] ^= backwards
    last = new_ptr[1:n_pieces + 1] - 1  # a piece's far end: no edge leaves it
    new_edges[last] = -1
    new_forward[last] = True
    new_closed = np.zeros(counts.size, dtype=bool)
    new_closed[n_pieces:] = True
    return Chains(new_ptr, nodes.take(slot), new_closed, new_edges.astype(INDEX, copy=False), new_forward)
