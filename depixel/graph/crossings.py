"""Stage 2 — paper §3.2 — similarity graph → planar similarity graph (crossings resolved).

A 2×2 block whose two diagonals are both linked is a crossing. If the block is fully
connected (all four sides too) it lies inside a flat region and both diagonals go. Every
other crossing — including the non-transitive ones with some but not all sides — is decided
by three votes, each signed towards the diagonal it supports:

* curves: the diagonal on the longer curve (chain of valence-2 pixels) wins the difference
  of the lengths;
* sparse pixels: in an 8×8 window around the block, the diagonal whose connected component
  is smaller wins the difference of the component sizes;
* islands: a diagonal with a valence-1 end (cutting it would strand a pixel) gets 5.

The diagonal with the larger total stays. A tie is broken (not in paper, ``tie_break``)
towards the diagonal whose colour is rarer in the window; only if that ties too are both
removed, as the paper does for every tie. All votes are computed on the
graph after the flat blocks are cleared and before any ambiguous crossing is decided, so the
result does not depend on the order of the blocks.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import batch_slices
from ..frozen import compact_repr
from ..params import Params
from .components import component_roots
from .similarity import SimilarityGraph

#: crossings whose 8×8 windows are evaluated together: bounds the temporary memory of the
#: window batches (~20 MB at 64 nodes a window) whatever the number of crossings (a
#: checkerboard has one per pixel)
WINDOW_BATCH = 2048


@dataclass(frozen=True, eq=False)
class CrossingResolution:
    """The planar graph plus what was decided where (for tests and stage pictures)."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    graph: SimilarityGraph  # resolved: at most one diagonal per 2×2 block
    flat: np.ndarray  # (H-1, W-1) bool: fully connected block, both diagonals removed
    ambiguous: np.ndarray  # (H-1, W-1) bool: crossing decided by the heuristics
    curve_vote: np.ndarray  # (H-1, W-1) float: + favours diag_main, - favours diag_anti
    sparse_vote: np.ndarray  # (H-1, W-1) float, same sign convention
    island_vote: np.ndarray  # (H-1, W-1) float, same sign convention
    tie_break_vote: np.ndarray  # (H-1, W-1) float: ±1 where the votes tied (not in paper)

    @property
    def total_vote(self) -> np.ndarray:
        return self.curve_vote + self.sparse_vote + self.island_vote + self.tie_break_vote


def resolve_crossings(graph: SimilarityGraph, params: Params = Params()) -> CrossingResolution:
    """Remove crossing diagonals so that the similarity graph becomes planar."""
    h, w = graph.shape
    crossing = graph.diag_main & graph.diag_anti
    sides = graph.right[:-1, :] & graph.right[1:, :] & graph.down[:, :-1] & graph.down[:, 1:]
    flat = crossing & sides
    ambiguous = crossing & ~sides
    cleared = graph.with_diagonals(graph.diag_main & ~flat, graph.diag_anti & ~flat)

    # three fresh zero arrays (np.zeros: pages that only a vote written touches; a copy of
    # one writes every page of a frame-sized array)
    shape = (max(h - 1, 0), max(w - 1, 0))
    curve_vote, sparse_vote, island_vote = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    rows, cols = ambiguous.nonzero()
    if rows.size:
        degree = cleared.degree().ravel()
        main_a, main_b = rows * w + cols, (rows + 1) * w + cols + 1
        anti_a, anti_b = rows * w + cols + 1, (rows + 1) * w + cols

        lengths = _curve_lengths(cleared, degree)
        main_len = _curve_length_of_edge(main_a, main_b, degree, lengths)
        anti_len = _curve_length_of_edge(anti_a, anti_b, degree, lengths)
        curve_vote[rows, cols] = params.curve_weight * (main_len - anti_len)

        main_size, anti_size = _window_component_sizes(cleared, rows, cols, params.sparse_window)
        sparse_vote[rows, cols] = params.sparse_weight * (anti_size - main_size)

        main_island = (degree[main_a] == 1) | (degree[main_b] == 1)
        anti_island = (degree[anti_a] == 1) | (degree[anti_b] == 1)
        island_vote[rows, cols] = params.island_weight * (
            main_island.astype(np.float64) - anti_island.astype(np.float64)
        )

    total = curve_vote + sparse_vote + island_vote
    tie_break = np.zeros_like(total)
    if params.tie_break:
        tied = ambiguous & (total == 0)
        tied_rows, tied_cols = tied.nonzero()
        tie_break[tied] = _colour_frequency_vote(graph, graph.yuv(), tied_rows, tied_cols, params)
    total = total + tie_break
    keep_main = cleared.diag_main & ~(ambiguous & (total <= 0))
    keep_anti = cleared.diag_anti & ~(ambiguous & (total >= 0))
    return CrossingResolution(
        graph=graph.with_diagonals(keep_main, keep_anti),
        flat=flat,
        ambiguous=ambiguous,
        curve_vote=curve_vote,
        sparse_vote=sparse_vote,
        island_vote=island_vote,
        tie_break_vote=tie_break,
    )


def _colour_frequency_vote(graph: SimilarityGraph, yuv: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                           params: Params) -> np.ndarray:
    """Not in paper: break a tie towards the diagonal whose colour is rarer in the window.

    Counts the pixels of the sparse-pixels window similar to each diagonal's first pixel; a
    rarer colour is the foreground of a dotted or dithered line (the perception the sparse
    heuristic models, measured by colour rather than by connected component). +1 keeps
    the "\\" diagonal, -1 the "/" one, 0 (equal counts) still removes both.
    """
    if rows.size > WINDOW_BATCH:
        return np.concatenate([_colour_frequency_vote(graph, yuv, rows[part], cols[part], params)
                               for part in batch_slices(rows.size, WINDOW_BATCH)])
    from .similarity import similar

    if rows.size == 0:
        return np.zeros(0)
    h, w = graph.shape
    window = params.sparse_window
    offs = np.arange(window) - (window // 2 - 1)
    wr = (rows[:, None] + offs[None, :]).clip(0, h - 1)[:, :, None]
    wc = (cols[:, None] + offs[None, :]).clip(0, w - 1)[:, None, :]
    inside = ((rows[:, None] + offs >= 0) & (rows[:, None] + offs < h))[:, :, None] & \
             ((cols[:, None] + offs >= 0) & (cols[:, None] + offs < w))[:, None, :]
    window_yuv, alpha = yuv[wr, wc], graph.rgba[..., 3][wr, wc]
    counts = []
    for pr, pc in ((rows, cols), (rows, cols + 1)):
        ref_yuv = yuv[pr, pc][:, None, None, :]
        ref_alpha = graph.rgba[pr, pc, 3][:, None, None]
        counts.append((similar(window_yuv, alpha, ref_yuv, ref_alpha, params) & inside).sum(axis=(1, 2)))
    return np.sign(counts[1] - counts[0]).astype(np.float64)


def _curve_lengths(graph: SimilarityGraph, degree: np.ndarray) -> np.ndarray:
    """Per pixel of valence 2: the number of edges of the curve through it (else 0).

    A curve is a maximal chain of valence-2 pixels plus the edges that leave it. For a
    component of k valence-2 pixels with e_in edges among them, the curve has 2k - e_in
    edges: k + 1 for an open chain, k for a closed loop.
    """
    n = degree.size
    a, b = graph.edge_ends()
    two = degree == 2
    inner = two.take(a) & two.take(b)
    a, b = a.compress(inner), b.compress(inner)
    label = component_roots(n, a, b)
    k = np.bincount(label, weights=two.astype(np.float64), minlength=n)
    e_in = np.bincount(label.take(a), minlength=n).astype(np.float64)
    return np.where(two, (2 * k - e_in)[label], 0.0)


def _curve_length_of_edge(a: np.ndarray, b: np.ndarray, degree: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Length of the curve the edge a—b lies on: 1 when neither end has valence 2."""
    return np.maximum(np.maximum(lengths[a], lengths[b]), 1.0)


def _window_component_sizes(graph: SimilarityGraph, rows: np.ndarray, cols: np.ndarray,
                            window: int) -> tuple[np.ndarray, np.ndarray]:
    """Sizes of the components holding each diagonal, within a window around each block.

    The K windows are the disjoint parts of one graph of ``K * window²`` nodes (only links
    with both ends in a window count), labelled in one pass per :data:`WINDOW_BATCH` windows.
    """
    pad = window
    # Pad every link array so that window offsets never fall outside: each to the image's
    # (H, W) plus ``pad`` on every side (np.pad costs ~30 µs a call in Python)
    h, w = graph.shape
    padded = []
    for link in (graph.right, graph.down, graph.diag_main, graph.diag_anti):
        frame = np.zeros((h + 2 * pad, w + 2 * pad), dtype=bool)
        frame[pad : pad + link.shape[0], pad : pad + link.shape[1]] = link
        padded.append(frame)
    right, down, main, anti = padded
    sizes = [_batch_component_sizes((right, down, main, anti), rows[part], cols[part], window, pad)
             for part in batch_slices(rows.size, WINDOW_BATCH)]
    return np.concatenate([s[0] for s in sizes]), np.concatenate([s[1] for s in sizes])


def _batch_component_sizes(links: tuple[np.ndarray, ...], rows: np.ndarray, cols: np.ndarray, window: int,
                           pad: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_window_component_sizes` of one batch of windows, on link arrays padded by ``pad``."""
    right, down, main, anti = links
    before = window // 2 - 1  # window rows/cols before the block's top-left pixel (3 for 8)
    offs = np.arange(window) - before
    wr = (rows[:, None] + offs[None, :] + pad)[:, :, None]  # (K, window, 1)
    wc = (cols[:, None] + offs[None, :] + pad)[:, None, :]  # (K, 1, window)

    # links inside the window only (both ends within the window); none reach outside the image
    link_right = right[wr, wc][:, :, :-1]
    link_down = down[wr, wc][:, :-1, :]
    link_main = main[wr, wc][:, :-1, :-1]
    link_anti = anti[wr, wc][:, :-1, :-1]

    node = np.arange(rows.size * window * window).reshape(rows.size, window, window)
    pairs = ((link_right, node[:, :, :-1], node[:, :, 1:]), (link_down, node[:, :-1, :], node[:, 1:, :]),
             (link_main, node[:, :-1, :-1], node[:, 1:, 1:]), (link_anti, node[:, :-1, 1:], node[:, 1:, :-1]))
    label = component_roots(node.size, np.concatenate([a[link] for link, a, _ in pairs]),
                            np.concatenate([b[link] for link, _, b in pairs]))
    size = np.bincount(label, minlength=node.size).astype(np.float64)
    return size[label[node[:, before, before]]], size[label[node[:, before, before + 1]]]
