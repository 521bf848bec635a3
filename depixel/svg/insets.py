"""Stacked outlines pulled back from the edges that shapes above them draw (no threads).

Part of stage 6 (:mod:`depixel.svg.outlines`). In the stacked layout a shape S covers faces
drawn above it. Where such a face Q borders a face X that no shape above S covers (X drawn
below S, or not opaque), S's outline would run along the Q–X boundary, which Q draws too:
every renderer anti-aliases both, so S's colour shows through Q's edge as a thin thread
(in exact coverage Q hides it). Only the lower of two touching faces need lie under their
boundary, and it does (X's shape covers Q), so S stops short of it: such a *run* of S's
outline is replaced by its *inset*, the same curve moved a margin into Q along its normal.
S still lies under Q wherever Q borders S or a face above S, so hiding Q shows S there.

* **Margin.** :data:`MARGIN` (0.25 px), less in a face too small for it: at most an eighth
  of the face's width measured as 4 × area / perimeter of its cells (a one-pixel square:
  0.125 px), so the insets of a small face's sides do not cross.
* **Ends.** Where a run starts or ends at a node, Q's boundary turns there from the Q–X
  edge onto another edge f of Q, inside S's shape. The inset is joined to the node by a line
  along the bisector of Q's corner between the two, which leaves both edges at the same
  angle (a line along the normal would run along f wherever Q's corner is a right angle, and
  there S's edge would coincide with Q's again); at a sharp corner it meets the bisector
  nearer the node, never more than a third of the curve's leg along it. Where the outline
  next to the run is hidden itself (it bounds a face drawn above S against another), that
  segment ends (or starts) where the inset does instead: no line.
* **Curves.** The inset of a segment moves its ends along their normals and its control
  points with them (a quadratic's control to where its two moved legs meet, a cubic's to
  where its moved middle leg meets the moved first and last, as Tiller and Hanson): not the
  exact offset curve, which no Bézier is, but close to it on the gentle segments of a
  depixelized boundary. A segment shortened at a run's end or at a convex corner is cut
  there first (de Casteljau), so the part kept is the same curve.
* **Corners.** Consecutive insets meet on the bisector of their corner, at the mean of
  their margins; at a convex corner (where the insets cross) at most half of either
  curve's leg from the corner (the most for which the joints at the two ends of a line
  never cross: the nearer the bisector's own point, the less of the corner's colour shows
  under the face above), nearer to it if need be; at a reflex turn of more than 120°
  round the corner by two lines through the bisector's point at the margin. Where the two
  move into different faces with the shape's own face touching the node between them, each
  run ends at the node as above instead: a joint would cut that corner of the shape's own
  face, and the colour below would show there.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import set_rows
from ..vector import VectorImage
from .boundaries import CUBIC, LINE
from .stacking import FaceBoundaries

#: how far a lower shape's outline stays inside an upper face from that face's visible edge,
#: in pixels: more than a render pixel's diagonal at 8x (0.18), so no render pixel at 8x
#: or finer is touched by both edges, and less than half the width of a one-pixel line
MARGIN = 0.25
#: a reflex turn between two inset segments is joined by a mitre while the cosine of the
#: angle between their normals exceeds this (turns up to 120 degrees), else by two lines
SHARP = -0.5


class Segments(NamedTuple):
    """Closed loops of segments: loop l is ``loop_ptr[l]:loop_ptr[l+1]`` (as in
    :class:`~depixel.svg.outlines.Outlines`)."""

    kind: np.ndarray  # (K,) uint8 LINE, QUAD or CUBIC
    ctrl: np.ndarray  # (K, 2) first control point (NaN for a line)
    ctrl2: np.ndarray  # (K, 2) second control point of a cubic (NaN otherwise)
    end: np.ndarray  # (K, 2) end point
    loop_ptr: np.ndarray  # (L+1,)


class RunMarks(NamedTuple):
    """Per segment, what the insets need (:func:`segment_insets`)."""

    margin: np.ndarray  # (K,) how far it is pulled back; 0: not, the owner's own edge; -1: not, hidden
    f_in: np.ndarray  # (K, 2) at a run's first segment, the pulled face's other edge at its start node (NaN)
    f_out: np.ndarray  # (K, 2) at a run's last segment, that edge at its end node (NaN elsewhere)


class InsetGuide:
    """What the insets need of an image: each face's margin, and where each face's boundary
    leaves or enters a node."""

    def __init__(self, image: VectorImage, faces: FaceBoundaries) -> None:
        self.image, self.faces = image, faces
        n = faces.n_faces
        entry_face = np.arange(n).repeat(faces.entry_ptr[1:] - faces.entry_ptr[:-1])
        a = faces.nodes.take(faces.entry_from, axis=0).astype(np.float64) / 4.0
        b = faces.nodes.take(faces.entry_to, axis=0).astype(np.float64) / 4.0
        # each face's area (its boundary's shoelace: the face lies right of its half-edges,
        # y down) and perimeter, in pixels
        area = np.bincount(entry_face, weights=a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1], minlength=n) / 2.0
        perimeter = np.bincount(entry_face, weights=np.hypot(*(b - a).T), minlength=n)
        self.margin = np.minimum(MARGIN, area / np.maximum(2.0 * perimeter, 1e-9))
        n_nodes = len(faces.nodes)
        self.n_nodes = n_nodes
        self.arrive_key = entry_face.astype(np.int64) * n_nodes + faces.entry_to
        self.arrive = self.arrive_key.argsort(kind="stable")
        self.arrive_key = self.arrive_key.take(self.arrive)
        self.leave_key = entry_face.astype(np.int64) * n_nodes + faces.entry_from
        self.leave = self.leave_key.argsort(kind="stable")
        self.leave_key = self.leave_key.take(self.leave)

    def touches(self, face: np.ndarray, node: np.ndarray) -> np.ndarray:
        """(n,) whether ``face``'s boundary passes through ``node``."""
        key = face.astype(np.int64) * self.n_nodes + node
        return self.arrive_key.take(np.minimum(self.arrive_key.searchsorted(key), self.arrive_key.size - 1)) == key

    def turn(self, face: np.ndarray, node: np.ndarray, arriving: bool) -> np.ndarray:
        """(n, 2) unit direction in which ``face``'s boundary leaves ``node`` along the edge
        by which it arrives there (``arriving``), or by which it leaves."""
        keys, order = (self.arrive_key, self.arrive) if arriving else (self.leave_key, self.leave)
        entry = order.take(np.minimum(keys.searchsorted(face.astype(np.int64) * self.n_nodes + node), keys.size - 1))
        edge = self.faces.entry_edge.take(entry)
        image = self.image
        u, v = image.cells.edges.take(edge, axis=0).T
        at_u = u == node
        here, there = np.where(at_u, u, v), np.where(at_u, v, u)
        p, q = image.points.take(here, axis=0), image.points.take(there, axis=0)
        c = image.controls.take(edge, axis=0)
        towards = np.where(image.curved.take(edge)[:, None], np.where(at_u[:, None], c[:, 0], c[:, 2]), q)
        d = towards - p
        short = np.hypot(d[:, 0], d[:, 1]) < 1e-9
        d[short] = (q - p)[short]
        return unit(d)


def segment_insets(guide: InsetGuide | None, q: np.ndarray, owner: np.ndarray, x: np.ndarray,
                   loop_of: np.ndarray, n_seg: np.ndarray) -> RunMarks:
    """The :class:`RunMarks` of the segments of the loops' steps (half-edges in loop order,
    each from node ``x``, loop ``loop_of``, ``n_seg`` segments each, laid out in order).
    ``q``: per step, the face an inset moves into, or -1 (the owner's own edge) or -2
    (another face's, hidden under the shapes above); ``owner``: the face of the step's shape."""
    total = int(n_seg.sum())
    f_in, f_out = np.full((total, 2), np.nan), np.full((total, 2), np.nan)
    if guide is None or not np.logical_or.reduce(q >= 0, initial=False):
        return RunMarks(np.zeros(total), f_in, f_out)
    k = np.arange(q.size)
    starts = np.concatenate(([True], loop_of[1:] != loop_of[:-1])).nonzero()[0]
    first = starts.take(np.searchsorted(starts, k, side="right") - 1)
    last = np.concatenate((starts[1:], [q.size])).take(np.searchsorted(starts, k, side="right") - 1) - 1
    q_prev, q_next = q.take(np.where(k == first, last, k - 1)), q.take(np.where(k == last, first, k + 1))
    seg_end = n_seg.cumsum()
    step = np.arange(q.size).repeat(n_seg)
    margin = np.where(q >= 0, guide.margin.take(np.maximum(q, 0)), np.where(q == -2, -1.0, 0.0)).take(step)
    # a run also ends at a node where the next step is pulled back into another face and the
    # owner's own face lies between the two there (it touches the node): the outline goes
    # back to the node in between, so that no joint of the two insets cuts the owner's face
    cut = (q >= 0) & (q_prev >= 0) & (q != q_prev)
    at = cut.nonzero()[0]
    cut[at] = guide.touches(owner.take(at), x.take(at))
    cut_next = cut.take(np.where(k == last, first, k + 1))
    begin = ((q >= 0) & ((q_prev < 0) | cut)).nonzero()[0]
    set_rows(f_in, seg_end.take(begin) - n_seg.take(begin), guide.turn(q.take(begin), x.take(begin), True))
    finish = ((q >= 0) & ((q_next < 0) | cut_next)).nonzero()[0]
    # the last segment written up to the step: its piece's last (or, where the loop starts
    # within that piece, written at its end, the loop's last)
    last_seg = seg_end.take(finish) - 1
    before_loop = last_seg < (seg_end - n_seg).take(first.take(finish))
    last_seg[before_loop] = seg_end.take(last.take(finish.compress(before_loop))) - 1
    y = x.take(np.where(k == last, first, k + 1))  # where each step ends
    set_rows(f_out, last_seg, guide.turn(q.take(finish), y.take(finish), False))
    return RunMarks(margin, f_in, f_out)


def inset_runs(segments: Segments, marks: RunMarks,
               grid: float | None) -> tuple[Segments, np.ndarray, np.ndarray]:
    """The loops with every segment whose margin is positive moved that far to its right
    (into the shape: loops run with the shape on their right, y down) and joined to its
    neighbours (see the module docstring); per segment, the run it belongs to (lines to and
    from its nodes included) or -1, and per run its margin."""
    kind, ctrl, ctrl2, end, loop_ptr = segments
    margin, f_in, f_out = marks
    inset = margin > 0
    n = kind.size
    n_loops = loop_ptr.size - 1
    loop_of = np.arange(n_loops).repeat(loop_ptr[1:] - loop_ptr[:-1])
    k = np.arange(n)
    first, last = loop_ptr.take(loop_of), loop_ptr.take(loop_of + 1) - 1
    prev = np.where(k == first, last, k - 1)
    nxt = np.where(k == last, first, k + 1)
    if not np.logical_or.reduce(inset, initial=False):
        return segments, np.full(n, -1, np.int64), np.zeros(0)
    hidden, margin = margin < 0, np.maximum(margin, 0.0)
    start = end.take(prev, axis=0)
    line, cubic = kind == LINE, kind == CUBIC
    lead = np.where(line[:, None], end, ctrl)  # the point the segment leaves its start towards
    trail = np.where(line[:, None], start, np.where(cubic[:, None], ctrl2, ctrl))  # and arrives from
    t0, t1 = unit(lead - start, end - start), unit(end - trail, end - start)
    n0, n1 = _right(t0), _right(t1)
    m = margin[:, None]
    ins_prev, ins_next = inset.take(prev), inset.take(nxt)
    # where each inset segment starts and ends, and how far along itself from its ends (an
    # end of a run moves at most a third of the segment's leg there, a convex corner's joint
    # at most half of it)
    degree = np.where(line, 1, np.where(cubic, 3, 2))
    first_leg, last_leg = np.hypot(*(lead - start).T), np.hypot(*(end - trail).T)
    joint, bevel, back_a, back_b = _joints(end, t1, n1, m, t0.take(nxt, axis=0), n0.take(nxt, axis=0),
                                           m.take(nxt, axis=0), np.minimum(last_leg, first_leg.take(nxt)) / 2)
    # a run ends where the next segment is not inset, or where it starts a run of its own (a
    # cut: the face's other edge known at both)
    run_end = inset & (~ins_next | ~np.isnan(f_out[:, 0]))
    run_start = inset & (~ins_prev | ~np.isnan(f_in[:, 0]))
    bevel &= inset & ~run_end
    end_at, end_back = _corner(end, -t1, n1, f_out, m, last_leg / 3)
    start_at, start_ahead = _corner(start, t0, n0, f_in, m, first_leg / 3)
    end_back = np.where(run_end, end_back, np.where(bevel, 0.0, back_a))
    start_ahead = np.where(run_start, start_ahead, np.where(bevel.take(prev), 0.0, back_b.take(prev)))
    new_end = np.where(run_end[:, None], end_at, np.where(bevel[:, None], end + m * n1, joint))
    # the part of the segment between those places (de Casteljau), moved: a line along its
    # normal, a quadratic's control where its moved legs meet, a cubic's controls where its
    # moved middle leg meets the moved first and last legs (Tiller and Hanson)
    a = start_ahead / np.maximum(degree * first_leg, 1e-12)
    b = 1.0 - end_back / np.maximum(degree * last_leg, 1e-12)
    p0, c1, c2, p1 = _part(kind, start, ctrl, ctrl2, end, a, b)
    s0 = _right(unit(np.where(line[:, None], p1, c1) - p0, p1 - p0))
    s1 = _right(unit(p1 - np.where(line[:, None], p0, np.where(cubic[:, None], c2, c1)), p1 - p0))
    s_mid = _right(unit(c2 - c1, p1 - p0))
    new_ctrl = c1 + m * np.where(cubic[:, None], _meet(s0, s_mid), _meet(s0, s1))
    new_ctrl2 = c2 + m * _meet(s_mid, s1)
    # lines added: before a run (from its start node to its inset), after a run (back to its
    # end node) and at a sharp reflex turn (round the corner to the next inset's start); a
    # hidden segment next to a run instead ends (or starts) where the inset does
    lead_in, lead_out = run_start & ~hidden.take(prev), run_end & ~hidden.take(nxt)
    count = 1 + lead_in + lead_out + 2 * bevel
    pos = np.concatenate(([0], count.cumsum()))
    total = int(pos[-1])
    at = pos[:-1] + lead_in  # where each segment lands
    out_kind = np.full(total, LINE, np.uint8)
    out_ctrl, out_ctrl2 = np.full((total, 2), np.nan), np.full((total, 2), np.nan)
    out_end = np.empty((total, 2))
    out_kind[at] = kind
    set_rows(out_end, at, np.where(inset[:, None], on_grid(new_end, grid), end))
    set_rows(out_ctrl, at, np.where((inset & ~line)[:, None], on_grid(new_ctrl, grid), ctrl))
    set_rows(out_ctrl2, at, np.where((inset & cubic)[:, None], on_grid(new_ctrl2, grid), ctrl2))
    into = lead_in.nonzero()[0]
    set_rows(out_end, pos.take(into), on_grid(start_at.take(into, axis=0), grid))
    back = lead_out.nonzero()[0]
    set_rows(out_end, at.take(back) + 1, end.take(back, axis=0))
    moved = (run_start & hidden.take(prev)).nonzero()[0]
    set_rows(out_end, at.take(prev.take(moved)), on_grid(start_at.take(moved, axis=0), grid))
    round_corner = bevel.nonzero()[0]
    set_rows(out_end, at.take(round_corner) + 1, on_grid(joint.take(round_corner, axis=0), grid))
    beyond = nxt.take(round_corner)
    set_rows(out_end, at.take(round_corner) + 2,
             on_grid(end.take(round_corner, axis=0) + m.take(beyond, axis=0) * n0.take(beyond, axis=0), grid))
    out = Segments(out_kind, out_ctrl, out_ctrl2, out_end, pos.take(loop_ptr))
    return (out, *_labels(margin, run_start, run_end, loop_of, at,
                          ((pos[:-1], lead_in), (at + 1, lead_out), (at + 1, bevel), (at + 2, bevel)), total))


def _labels(margin: np.ndarray, run_start: np.ndarray, run_end: np.ndarray, loop_of: np.ndarray, at: np.ndarray,
            lines: tuple, total: int) -> tuple[np.ndarray, np.ndarray]:
    """Per output segment, the run it belongs to (-1: none), the lines ``lines`` added to
    the runs included (``(where, after which segments)``), and per run the least margin
    along it: what :func:`depixel.svg.runfit.fit_runs` may redraw. Segments land at ``at``;
    a run that goes on past its loop's start is left as it is."""
    out_run = np.full(total, -1, np.int64)
    start_of, end_of = run_start.nonzero()[0], run_end.nonzero()[0]
    if start_of.size == 0 or end_of.size == 0:
        return out_run, np.zeros(start_of.size)
    end_of = end_of.take(np.minimum(end_of.searchsorted(start_of), end_of.size - 1))  # its first end after
    whole = (end_of >= start_of) & (loop_of.take(end_of) == loop_of.take(start_of))
    rid = np.cumsum(run_start) - 1
    ok = np.maximum(rid, 0)
    mine = (margin > 0) & (rid >= 0) & whole.take(ok) & (np.arange(margin.size) <= end_of.take(ok))
    out_run[at.compress(mine)] = rid.compress(mine)
    for where, of in lines:
        out_run[where.compress(of & mine)] = rid.compress(of & mine)
    least = np.full(start_of.size, np.inf)
    np.minimum.at(least, rid.compress(mine), margin.compress(mine))
    return out_run, np.where(np.isfinite(least), least, 0.0)


def _part(kind: np.ndarray, p0: np.ndarray, c1: np.ndarray, c2: np.ndarray, p1: np.ndarray, a: np.ndarray,
          b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The points ``(start, ctrl, ctrl2, end)`` of the part of each segment between
    parameters ``a`` and ``b`` (blossoms: exact for lines, quadratics and cubics)."""
    a, b = a[:, None], b[:, None]
    line, cubic = (kind == LINE)[:, None], (kind == CUBIC)[:, None]
    q1 = np.where(line, p1, c1)  # (a line as a degenerate quadratic: its blossoms are its points)

    def quad(s, t):
        return (1 - s) * (1 - t) * p0 + ((1 - s) * t + s * (1 - t)) * q1 + s * t * p1

    def cub(r, s, t):
        near = (1 - r) * (1 - s) * t + (1 - r) * s * (1 - t) + r * (1 - s) * (1 - t)
        far = (1 - r) * s * t + r * (1 - s) * t + r * s * (1 - t)
        return (1 - r) * (1 - s) * (1 - t) * p0 + near * c1 + far * c2 + r * s * t * p1

    start = np.where(cubic, cub(a, a, a), quad(a, a))
    stop = np.where(cubic, cub(b, b, b), quad(b, b))
    first = np.where(cubic, cub(a, a, b), quad(a, b))
    second = np.where(cubic, cub(a, b, b), np.nan)
    return start, first, second, stop


def _joints(point: np.ndarray, t_a: np.ndarray, n_a: np.ndarray, m_a: np.ndarray, t_b: np.ndarray,
            n_b: np.ndarray, m_b: np.ndarray, limit: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the insets of two segments meet at their joint ``point`` (the first arriving
    in unit direction ``t_a``, the second leaving in ``t_b``, normals ``n``, margins ``m``):
    on the bisector of the corner, at the mean margin from both. At a convex corner (the
    insets cross) at most ``limit`` along either segment, nearer the corner if need be; at a
    reflex one the mitre, and past a turn of 120° (``bevel``) the point of the bisector at
    the mean margin from the corner, joined by lines to both insets. Also how far back along
    each segment the point lies (negative: beyond)."""
    cos = (n_a * n_b).sum(axis=1)
    reflex = (t_b * n_a).sum(axis=1) < 0
    half_cos = np.sqrt(np.maximum((1.0 + cos) / 2, 0.0))
    half_sin = np.sqrt(np.maximum((1.0 - cos) / 2, 0.0))
    # the bisector into the shape: n_a + n_b, or where they cancel (a hairpin), along the
    # difference of the directions, which points the same way at any reflex turn and the
    # opposite way at any convex one
    u = unit(n_a + n_b + np.where(reflex, 1.0, -1.0)[:, None] * (t_a - t_b), n_a)
    m = (m_a[:, 0] + m_b[:, 0]) / 2
    bevel = reflex & (cos <= SHARP)
    reach = np.where(reflex, m / np.maximum(half_cos, 0.5),
                     np.minimum(m / np.maximum(half_cos, 1e-9), limit / np.maximum(half_sin, 1e-9)))
    reach = np.where(bevel, m, reach)
    offset = reach[:, None] * u
    return point + offset, bevel, -(offset * t_a).sum(axis=1), (offset * t_b).sum(axis=1)


def _corner(node: np.ndarray, along: np.ndarray, normal: np.ndarray, other: np.ndarray, m: np.ndarray,
            limit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The point on the bisector of the corner at ``node`` between an edge leaving it in
    direction ``along`` and the ``other`` edge there (unit directions; the corner on the
    ``normal`` side) at distance ``m`` from the edge, or nearer the node where that lies more
    than ``limit`` along the edge, and how far along the edge it lies. A reflex corner, or
    no other edge known (NaN), gives the point ``m`` along the normal."""
    cos, sin = (along * other).sum(axis=1), (normal * other).sum(axis=1)
    cot = np.nan_to_num(np.where(sin > 0, (1.0 + cos) / np.where(sin > 0, sin, 1.0), 0.0))  # cot(α/2)
    shift = np.minimum(cot * m[:, 0], limit)
    depth = np.where(cot > 0, shift / np.where(cot > 0, cot, 1.0), m[:, 0])
    return node + depth[:, None] * normal + shift[:, None] * along, shift


def merge_lines(segments: Segments, marks: RunMarks, grid: float | None) -> tuple[Segments, RunMarks]:
    """Merge consecutive lines that continue each other (cyclically in each loop) and have
    the same margin, unless a run ends between them (a merged line keeps the first one's
    ``f_in``)."""
    kind, ctrl, ctrl2, end, loop_ptr = segments
    margin, f_in, f_out = marks
    n = kind.size
    if n == 0:
        return segments, marks
    n_loops = loop_ptr.size - 1
    loop_of = np.arange(n_loops).repeat(loop_ptr[1:] - loop_ptr[:-1])
    first, last = loop_ptr.take(loop_of), loop_ptr.take(loop_of + 1)
    last -= 1
    k = np.arange(n)
    at_last = k == last
    before = np.where(k == first, last, k - 1)
    after = np.where(at_last, first, k + 1)
    start, following = end.take(before, axis=0), end.take(after, axis=0)
    tol = 1e-12 if grid is None else 0.25 * grid * grid
    line = kind == LINE
    ax, ay = end[:, 0] - start[:, 0], end[:, 1] - start[:, 1]
    bx, by = following[:, 0] - end[:, 0], following[:, 1] - end[:, 1]
    merge = line & line.take(after) & (np.abs(ax * by - ay * bx) <= tol) & (ax * bx + ay * by > 0) & (after != k)
    merge &= (margin == margin.take(after)) & np.isnan(f_out[:, 0]) & np.isnan(f_in.take(after, axis=0)[:, 0])
    if not np.logical_or.reduce(merge):
        return segments, marks
    carry = merge & ~np.isnan(f_in[:, 0])  # a run starting at a line merged into the next
    for _ in range(n):  # (along a chain of merged lines)
        if not np.logical_or.reduce(carry):
            break
        f_in[after[carry]] = f_in[carry]
        carry = carry.take(before) & merge
    keep = ~merge
    kept_per_loop = np.bincount(loop_of.compress(keep), minlength=n_loops)
    keep |= (kept_per_loop.take(loop_of) == 0) & at_last  # never drop every segment of a loop
    loop_ptr = loop_of.compress(keep).searchsorted(np.arange(loop_ptr.size)).astype(np.int64)
    ctrl, ctrl2, end, f_in, f_out = (a.compress(keep, axis=0) for a in (ctrl, ctrl2, end, f_in, f_out))
    return Segments(kind.compress(keep), ctrl, ctrl2, end, loop_ptr), RunMarks(margin.compress(keep), f_in, f_out)


def _meet(n_a: np.ndarray, n_b: np.ndarray) -> np.ndarray:
    """Where the lines one unit along unit normals ``n_a`` and ``n_b`` meet (two moved
    tangents), at most twice as far (turns up to 120°)."""
    return (n_a + n_b) / np.maximum(1.0 + (n_a * n_b).sum(axis=1), 0.5)[:, None]


def _right(d: np.ndarray) -> np.ndarray:
    """The directions turned a right angle to the right (y down: (-dy, dx))."""
    return np.stack((-d[:, 1], d[:, 0]), axis=1)


def unit(direction: np.ndarray, fallback: np.ndarray | None = None) -> np.ndarray:
    """(n, 2) unit vectors along ``direction``, along ``fallback`` where it has no length;
    zero where neither has."""
    d = direction
    if fallback is not None:
        d = np.where((np.abs(direction).sum(axis=1) > 0)[:, None], direction, fallback)
    length = np.hypot(d[:, 0], d[:, 1])
    length[length == 0] = np.inf
    return d / length[:, None]


def on_grid(xy: np.ndarray, grid: float | None) -> np.ndarray:
    return xy if grid is None else (xy / grid).round() * grid
