"""The boundaries between faces, cut at junctions into pieces of line and quadratic segments.

Every face boundary of a :class:`~depixel.vector.VectorImage` runs along the B-spline curves
of the spline stages (or along straight cell edges at the cells stage). Where three or more
face boundaries meet (a *junction*), or where a curve ends, a shape's outline may turn from
one curve onto another; between two such places every shape that follows the curve follows
all of it. So the curves are cut at those places into *pieces*, and each piece is written
once, as segments; an outline is then a sequence of whole pieces, each traversed forwards
or backwards. Two shapes that share a boundary use the same piece, so they draw exactly the
same geometry (and, on a grid, the same numbers).

A piece from slot a to slot b (:class:`~depixel.vector.CurveTable`) is: the second half of
span a (from the curve point S_a, where the curve passes through a's node), the full spans
of the slots in between, and the first half of span b (to S_b) — one quadratic Bézier per
span, with TrueType's implied on-curve points between them; at an open end the clamped end
point itself. A closed curve without any junction is one piece of full spans.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import set_rows
from ..curves.bspline import joint as leg_joint
from ..vector import CurveTable, VectorImage

#: segment kinds: a line, a quadratic Bézier (the spline's spans), a cubic Bézier (simplified)
LINE, QUAD, CUBIC = 0, 1, 2


@dataclass(frozen=True, eq=False)
class BoundaryPieces:
    """Pieces of curve between junctions, each a run of segments in the curve's direction.

    Piece p starts at ``start[p]`` and has the segments ``ptr[p]:ptr[p+1]``. The curved cell
    edges map to pieces: ``edge_piece[e]`` (-1 for a straight edge), and whether the edge is
    the first (``edge_first``) or last (``edge_last``) edge of its piece in the curve's
    direction (``edge_forward`` of the curve table says how the edge is stored).
    """

    start: np.ndarray  # (N, 2) float64 start point of each piece
    ptr: np.ndarray  # (N+1,) int64
    kind: np.ndarray  # (K,) uint8 LINE, QUAD or CUBIC
    ctrl: np.ndarray  # (K, 2) float64 control point (the first of a CUBIC; NaN for a LINE)
    end: np.ndarray  # (K, 2) float64 end point
    edge_piece: np.ndarray  # (E,) int32
    edge_first: np.ndarray  # (E,) bool
    edge_last: np.ndarray  # (E,) bool
    span_slot: np.ndarray  # (K,) int32 slot whose span the segment is (part of); -1 once simplified
    curve_ctrl: np.ndarray  # (P, 2) float64 the curve table's control points (the image's own array)
    grid: float | None  # the grid of the coordinates (None: exact)
    ctrl2: np.ndarray  # (K, 2) float64 second control point of a CUBIC (NaN otherwise; read-only)
    closed: np.ndarray  # (N,) bool a whole closed curve without junction: it starts at an arbitrary joint

    def __len__(self) -> int:
        return int(self.ptr.size - 1)

    def span_ctrl(self, slot: np.ndarray) -> np.ndarray:
        """(n, 2) the control point of each slot's span, on the grid like the segments' (computed
        when asked: the few spans an outline joins back from two halves need it)."""
        return _ctrl_on_grid(self.curve_ctrl[slot], self.grid)

    def replace_segments(self, start: np.ndarray, ptr: np.ndarray, kind: np.ndarray, ctrl: np.ndarray,
                         end: np.ndarray, ctrl2: np.ndarray) -> BoundaryPieces:
        """The same pieces with other segments (e.g. simplified)."""
        return BoundaryPieces(start, ptr, kind, ctrl, end, self.edge_piece, self.edge_first, self.edge_last,
                              np.full(kind.size, -1, np.int32), self.curve_ctrl, self.grid, ctrl2, self.closed)


def build_pieces(image: VectorImage, junction: np.ndarray, grid: float | None = None) -> BoundaryPieces:
    """Cut the curves of ``image`` at the ``junction`` nodes and at their ends into pieces.

    With ``grid``, every node point and joint is a multiple of ``grid`` and every control
    point a multiple of twice it (so each implied on-curve point, a midpoint of two control
    points, is exact); each value comes from one computation, whichever shapes use it.
    """
    n_edges = len(image.cells.edges)
    curves = image.curves
    empty = np.zeros(0, np.int64)
    if curves is None or not image.curved.any():
        return BoundaryPieces(np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.uint8), np.zeros((0, 2)),
                              np.zeros((0, 2)), np.full(n_edges, -1, np.int64), np.zeros(n_edges, bool),
                              np.zeros(n_edges, bool), empty, np.zeros((0, 2)), grid, np.zeros((0, 2)),
                              np.zeros(0, bool))
    point = _on_grid(image.points, grid)
    node, nxt = curves.node, curves.next
    end = curves.is_end()

    # slots that bound pieces; a closed curve with none gets its first slot, where its
    # piece starts and ends at a joint instead of a curve point
    anchor = end | junction[node]
    closed_free = _seeds(curves.curve, curves.closed, anchor)
    anchor_or_seed = anchor | closed_free
    # the pieces: one from every anchor with a next slot to the next anchor along its curve.
    # A curve's slots are consecutive in order (SplineSet's flat arrays; next wraps round a
    # closed curve), so a slot's piece is the last start at or before it, or on a closed
    # curve before its first start, the curve's last one (the piece that wraps round)
    starts = (anchor_or_seed & (nxt >= 0)).nonzero()[0]
    curve = curves.curve
    start_curve = curve[starts]
    label = (anchor_or_seed & (nxt >= 0)).cumsum() - 1
    wraps = label < start_curve.searchsorted(curve, side="left")
    label[wraps] = start_curve.searchsorted(curve[wraps], side="right") - 1
    edge_slot_ok = nxt >= 0  # slots that start an edge
    piece_of_slot = np.where(edge_slot_ok, label, -1).astype(np.int32)  # piece of the edge slot → next
    length = np.bincount(piece_of_slot[edge_slot_ok], minlength=starts.size).astype(np.int64)  # edges per piece
    curve_first = curve.searchsorted(start_curve, side="left")
    curve_size = curve.searchsorted(start_curve, side="right") - curve_first
    last_slot = curve_first + (starts - curve_first + length) % curve_size  # the anchor each piece ends at
    first_slot = starts
    del label, wraps, edge_slot_ok

    edge_piece = np.full(n_edges, -1, np.int32)
    edge_first = np.zeros(n_edges, bool)
    edge_last = np.zeros(n_edges, bool)
    edge_slot = curves.edge_slot
    curved_edges = (edge_slot >= 0).nonzero()[0]
    slot_of_edge = edge_slot[curved_edges]
    edge_piece[curved_edges] = piece_of_slot[slot_of_edge]
    edge_first[curved_edges] = anchor_or_seed[slot_of_edge]
    edge_last[curved_edges] = anchor_or_seed[nxt[slot_of_edge]]
    del curved_edges, slot_of_edge, piece_of_slot, anchor, anchor_or_seed

    # segments: [head half of span a] + full spans in between + [tail half of span b]; at a
    # seeded closed curve, full spans all round from the joint before its seed
    seed = closed_free[first_slot]
    head = ~end[first_slot] & ~seed
    tail = ~end[last_slot] & ~seed
    n_full = length - 1 + seed  # a seeded piece: every slot's span, seed included
    count = head + n_full + tail
    ptr = np.concatenate(([0], count.cumsum()), dtype=np.int64)
    total = int(ptr[-1])
    piece = np.arange(starts.size).repeat(count)
    offset = np.arange(total) - ptr.take(piece)
    # which slot's span each segment is, walking from the first slot
    head_of = head.take(piece)
    is_head = head_of & (offset == 0)
    is_tail = tail.take(piece) & (offset == count.take(piece) - 1)
    steps = offset - head_of + 1 - seed.take(piece)  # full span k is the slot k steps after the first
    steps[is_tail] = length.take(piece.compress(is_tail))
    steps[is_head] = 0
    del offset, head_of
    # the slot k steps after the piece's first, on its curve's run of consecutive slots (a
    # closed curve's wraps round; an open curve's is never walked past its end)
    steps += (first_slot - curve_first).take(piece)
    steps %= curve_size.take(piece)
    slot = curve_first.take(piece)
    slot += steps
    del piece, steps

    kind = np.full(total, QUAD, np.uint8)
    seg_ctrl = _ctrl_on_grid(curves.ctrl.take(slot, axis=0), grid)
    seg_end = _joints(curves, point, end, slot, seg_ctrl, grid)
    # the halves of a span (de Casteljau at t = ½) have the controls (S0 + C) / 2 and (C + S1) / 2,
    # S0 the joint before the span, where the segment before ends (the rows are per slot, so
    # no joint is computed twice): a head's own control and joint, a tail's control and the
    # end of the segment before it, or of its piece's start (an open curve's end) if none
    heads, tails = is_head.nonzero()[0], is_tail.nonzero()[0]
    set_rows(seg_ctrl, heads, _on_grid((seg_ctrl.take(heads, axis=0) + seg_end.take(heads, axis=0)) / 2.0, grid))
    start = point.take(node.take(first_slot), axis=0)
    tail_piece = tail.nonzero()[0]  # (a piece has at most one tail: its last segment)
    before = seg_end.take(tails - 1, axis=0)
    alone = (ptr.take(tail_piece) == tails).nonzero()[0]
    set_rows(before, alone, start.take(tail_piece.take(alone), axis=0))
    set_rows(seg_ctrl, tails, _on_grid((before + seg_ctrl.take(tails, axis=0)) / 2.0, grid))
    set_rows(seg_end, tails, point.take(node.take(slot.take(tails)), axis=0))
    # a seeded closed curve starts at the joint before its seed, where its last span ends
    seeded = seed.nonzero()[0]
    set_rows(start, seeded, seg_end.take(ptr.take(seeded + 1) - 1, axis=0))
    del point, before, is_head, is_tail
    span_slot = slot.astype(np.int32)
    del slot
    _straighten(start, ptr, kind, seg_ctrl, seg_end, grid)
    return BoundaryPieces(start, ptr, kind, seg_ctrl, seg_end, edge_piece, edge_first, edge_last,
                          span_slot, curves.ctrl, grid, _no_cubics(seg_ctrl.shape), seed)


def _no_cubics(shape: tuple[int, ...]) -> np.ndarray:
    """``ctrl2`` of segments without cubics: all NaN, a read-only view that takes no memory."""
    return np.broadcast_to(np.nan, shape)


def _joints(curves: CurveTable, point: np.ndarray, end: np.ndarray, slot: np.ndarray, ctrl: np.ndarray,
            grid: float | None) -> np.ndarray:
    """(n, 2) the joint after each slot's span (between it and the next slot's span; at an
    end, the end point; NaN past an open end), ``ctrl`` the slots' control points on the grid:
    computed for the slots asked (every segment's once), so no (P, 2) table is built."""
    nxt = curves.next.take(slot)
    b = np.maximum(nxt, 0)
    joint = leg_joint(ctrl, _ctrl_on_grid(curves.ctrl.take(b, axis=0), grid))
    # at a curve's end the end point, else before one the next slot's end point: one gather
    at_end = end.take(slot)
    rows = (at_end | end.take(b)).nonzero()[0]
    ending = np.where(at_end, slot, b).take(rows)
    set_rows(joint, rows, point.take(curves.node.take(ending), axis=0))
    joint[nxt < 0] = np.nan
    return joint


def _on_grid(xy: np.ndarray, grid: float | None) -> np.ndarray:
    return xy.copy() if grid is None else (xy / grid).round() * grid


def _ctrl_on_grid(ctrl: np.ndarray, grid: float | None) -> np.ndarray:
    """Control points on twice the grid, so every implied on-curve point (a midpoint) is on it."""
    return ctrl if grid is None else (ctrl / (2 * grid)).round() * (2 * grid)


def _seeds(curve: np.ndarray, closed: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """(P,) bool: the first slot of every closed curve that has no anchor."""
    n_curves = closed.size
    anchored = np.bincount(curve, weights=anchor, minlength=n_curves) > 0
    first = np.full(n_curves, curve.size, np.int64)
    np.minimum.at(first, curve, np.arange(curve.size))
    seed = np.zeros(curve.size, bool)
    free = (closed & ~anchored & (first < curve.size)).nonzero()[0]
    seed[first[free]] = True
    return seed


def _straighten(start: np.ndarray, ptr: np.ndarray, kind: np.ndarray, ctrl: np.ndarray, end: np.ndarray,
                grid: float | None) -> None:
    """Quadratics whose control point lies on the segment between their ends are lines
    (``kind`` and ``ctrl`` changed in place)."""
    n = kind.size
    if n == 0:
        return
    seg_start = np.empty_like(end)
    seg_start[1:] = end[:-1]
    first = ptr[:-1][np.diff(ptr) > 0]  # the first segment of every piece starts at its start
    set_rows(seg_start, first, start.compress(np.diff(ptr) > 0, axis=0))
    d0 = ctrl - seg_start
    del seg_start
    d1 = end - ctrl
    cross = d0[:, 0] * d1[:, 1] - d0[:, 1] * d1[:, 0]
    tol = 1e-12 if grid is None else 0.25 * grid * grid
    flat = (kind == QUAD) & (np.abs(cross) <= tol) & (d0[:, 0] * d1[:, 0] + d0[:, 1] * d1[:, 1] >= 0)
    kind[flat] = LINE
    ctrl[flat] = np.nan
