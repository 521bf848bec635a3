"""Which holes of a shape's outline stay open in the stacked layout.

Part of stage 6 (:mod:`depixel.svg.outlines`). A stacked shape fills every hole of its union of
faces (the shapes drawn later cover it) unless the hole holds a transparent or translucent
pixel, which filling would hide. Each such face is represented by one pixel, its *probe*;
a hole is kept open when it holds a probe by the even-odd rule. The test goes row by row
(:func:`holds_a_probe`), linear in the image, where testing every (hole edge, probe) pair
would be quadratic.
"""
from __future__ import annotations

import numpy as np

from ..arrays import ranges
from .loops import Loops


def probe_keys(pixels: np.ndarray, width: int) -> np.ndarray:
    """Sorted keys of the centres of some pixels (flat indices), as :func:`holds_a_probe`
    searches them: row * (4W + 8) + the centre's x in quarter pixels."""
    row, col = np.divmod(pixels, width)
    return np.sort(row * (4 * width + 8) + 4 * col + 2)


def loops_to_keep(loops: Loops, halfedge_from: np.ndarray, nodes: np.ndarray, probe_key: np.ndarray | None,
                   width: int, fill_holes: bool) -> np.ndarray:
    """Indices of the loops drawn: all of them, less (``fill_holes``, the stacked layout) the
    holes that hold no transparent or translucent pixel (``probe_key``: :func:`probe_keys` of
    one pixel of each such face, None if none; the others are covered by shapes drawn later).
    ``nodes``: quarter-pixel node positions."""
    everything = np.arange(len(loops))
    if not fill_holes or len(loops) == 0:
        return everything
    start = halfedge_from.take(loops.halfedges)
    nxt_pos = np.arange(start.size) + 1
    nxt_pos[loops.ptr[1:] - 1] = loops.ptr[:-1]
    p, q = nodes.take(start, axis=0).astype(np.int64), nodes.take(start.take(nxt_pos), axis=0).astype(np.int64)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    loop_of = everything.repeat(loops.ptr[1:] - loops.ptr[:-1])
    area2 = np.bincount(loop_of, weights=cross, minlength=len(loops))  # clockwise on screen > 0
    holes = (area2 < 0).nonzero()[0]
    if holes.size == 0:
        return everything
    if probe_key is None:
        return (area2 >= 0).nonzero()[0]
    is_hole = area2 < 0
    hole_edges = is_hole.take(loop_of).nonzero()[0]
    blocked = holds_a_probe(p.take(hole_edges, axis=0), q.take(hole_edges, axis=0), loop_of.take(hole_edges), probe_key,
                            len(loops), width)
    keep = (area2 >= 0) | blocked
    return keep.nonzero()[0]


def holds_a_probe(a: np.ndarray, b: np.ndarray, loop: np.ndarray, probe_key: np.ndarray, n_loops: int,
                   width: int) -> np.ndarray:
    """(n_loops,) bool: the loops (edges a→b (E, 2) of loop ``loop``, quarter-pixel units)
    that hold a probe (pixel centres (4c + 2, 4r + 2), sorted keys r(4W + 8) + 4c + 2) by the
    even-odd rule, a ray towards +x counting the edges that straddle the probe's row
    (half-open in y) and cross it strictly right.

    Row by row instead of every (edge, probe) pair: a probe row y = 4r + 2 meets each loop
    at crossings x_c; a probe at integer x has odd parity exactly when it lies in
    [C1, C2), [C3, C4), … of that loop's crossings rounded up, C = ceil(x_c), sorted (x_c > x
    if and only if C > x). So the cost is the edges' crossings and a binary search per
    span, linear in the image, where the pairs cost edges × probes."""
    ay, by = a[:, 1], b[:, 1]
    lo, hi = np.minimum(ay, by), np.maximum(ay, by)
    # the probe rows each edge straddles: lo <= 4r + 2 < hi
    r0, r1 = -((2 - lo) // 4), -((2 - hi) // 4)  # ceil((lo - 2) / 4), ceil((hi - 2) / 4)
    count = np.maximum(r1 - r0, 0)
    edge = np.arange(a.shape[0]).repeat(count)
    row = ranges(r0, count)
    ax, ay, bx, by = a[:, 0].take(edge), a[:, 1].take(edge), b[:, 0].take(edge), b[:, 1].take(edge)
    py, dy = 4 * row + 2, by - ay
    # x_c = ax + (py - ay)(bx - ax) / dy, rounded up exactly in integers (dy made positive)
    num = ax * dy + (py - ay) * (bx - ax)
    num, den = np.where(dy < 0, -num, num), np.abs(dy)
    ceil = -((-num) // den)
    span = 4 * width + 8  # x keys per row: every crossing and probe x lies in [0, 4W + 4]
    ceil = np.clip(ceil, 0, span - 1)
    order = np.lexsort((ceil, row, loop[edge]))
    group = loop[edge][order] * (row.max(initial=0) + 1) + row[order]
    rank = np.arange(order.size) - group.searchsorted(group)  # position within (loop, row)
    first = order[rank % 2 == 0]
    second = order[rank % 2 == 1]  # each (loop, row) has an even number of crossings
    start = probe_key.searchsorted(row[first] * span + ceil[first])
    stop = probe_key.searchsorted(row[second] * span + ceil[second])
    held = np.zeros(n_loops, bool)
    held[loop[edge][first][stop > start]] = True
    return held
