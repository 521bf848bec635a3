"""Where the simplification may cut a boundary piece: the straight runs it keeps and the
knots it cuts at first, features of the curve itself.

The SVG writer's simplification (:mod:`depixel.svg.simplify`) replaces runs of a piece's exact
segments by single Béziers. Which runs it tries must not depend on where a piece's numbering
starts, on its direction, or on anything far away: otherwise mirroring or turning the image
changes the curves (not only their place), and a one-pixel edit rewrites curves across the
sprite. So the places where a piece is cut are features of the curve, the same whichever way
it is walked and after any of the square's symmetries:

* **Straight runs** — :data:`MIN_STRAIGHT` pixels or more of collinear line segments: a pixel
  edge two pixels long or more, a 45° staircase — are kept exactly as they are, never bent
  into a curve. Their ends always cut, like a piece's ends (:data:`BREAK`). So do those of
  the spline's own straight runs, :data:`MIN_STRAIGHT_SPLINE` or more of collinear spans
  each within the grid of its chord, which the simplification writes as one line: a
  diagonal fitted together with the bend at its end would be re-drawn whole by an edit
  that moves the bend.
* **Knots** (:data:`KNOT`) are the joints where the tangent is horizontal or vertical: where
  the curve is farthest in x or y. A quadratic whose tangent turns through such a direction
  marks its nearer end (both ends when it does so at its middle, within :data:`_TIE`). The
  mirrors and quarter turns map these directions onto themselves.

A run that does not fit as one curve is cut at all its knots, else at the joint farthest
from its chord (:meth:`Breaks.split`). A closed curve without junction and without straight
run (an eye, a dot) cannot be one curve: its knots cut it at once, and it starts at one of
them (:func:`piece_breaks`), so where its numbering started does not matter.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..arrays import ranges
from .boundaries import LINE, QUAD, BoundaryPieces
from .reference import planes

#: straight runs at least this long (pixels) are kept as lines: the run of lines between the
#: spans at the ends of a pixel edge two pixels long is one pixel long
MIN_STRAIGHT = 1.0 - 1e-6
#: straight runs of the spline (with a quadratic lying within the grid of its chord: a 45-degree
#: staircase's spans) at least this long are kept straight too, written as one line; shorter
#: ones are left to the fits (a cut at every one a pixel long costs a seventh more commands)
MIN_STRAIGHT_SPLINE = 2.0 - 1e-6
#: the class of a joint: always a cut, a knot, neither
BREAK, KNOT, NONE = 0, 1, 2
#: a unit tangent's component this small is zero (a mirrored image's numbers differ from the
#: image's in the last bits)
_EPS = 1e-9
#: a direction met within this of a segment's middle (in its parameter) marks both ends; two
#: joints within this of the farthest from a chord are as far (pixels)
_TIE = 1e-6


class Breaks:
    """The straight runs and the class of every joint of ``pieces``: ``fixed[k]``, segment k
    is part of a straight run (kept as it is); ``joint[k]``, the class of the joint where
    segment k starts (:data:`BREAK` at a piece's start and at a straight run's ends; on a
    closed piece the joint before its first segment is its last one's end)."""

    def __init__(self, pieces: BoundaryPieces) -> None:
        n, ptr = pieces.kind.size, pieces.ptr
        piece = np.arange(len(pieces)).repeat(np.diff(ptr))
        k = np.arange(n)
        first, last = ptr[:-1].take(piece), ptr[1:].take(piece) - 1
        # the segment before each one: on a closed piece, the last one before the first
        before = np.where(k == first, np.where(pieces.closed.take(piece), last, -1), k - 1)
        self.ptr = ptr
        # (2, K) x and y planes (reference.planes) of the segments' ends and legs
        self.end = planes(pieces.end)
        self.start = np.where(k == first, planes(pieces.start).take(piece, axis=1),
                              self.end.take(np.maximum(k - 1, 0), axis=1))
        line = pieces.kind == LINE
        chord = self.end - self.start
        ctrl = planes(pieces.ctrl)
        leg0 = np.where(line, chord, ctrl - self.start)  # a line's legs: its chord
        leg1 = np.where(line, chord, self.end - ctrl)
        t0, t1 = _unit(leg0), _unit(leg1)
        length = np.sqrt(chord[0] * chord[0] + chord[1] * chord[1])
        # a quadratic whose control lies within twice the grid of its chord is within the grid
        # of it: straight as written (a 45-degree staircase's spans, their controls rounded)
        off = np.abs((ctrl[0] - self.start[0]) * chord[1] - (ctrl[1] - self.start[1]) * chord[0])
        flat = (pieces.kind == QUAD) & (length > 0) & (off <= (2 * (pieces.grid or 0.0) + 1e-9) * length)
        along = (ctrl[0] - self.start[0]) * chord[0] + (ctrl[1] - self.start[1]) * chord[1]
        flat &= (along > 0) & (along < length * length)
        straight = line | flat
        self.fixed, self.run = _straight_runs(straight, np.where(line, t0, _unit(chord)), length, before, first,
                                              last, flat)
        has_before = before >= 0
        b = np.maximum(before, 0)
        tangent = _unit(t0 + np.where(has_before, t1.take(b, axis=1), 0.0))
        joint = np.where((np.abs(tangent[0]) <= _EPS) | (np.abs(tangent[1]) <= _EPS), KNOT, NONE).astype(np.int8)
        after = np.where(k == last, np.where(before.take(first) >= 0, first, n), k + 1)  # the joint at each end
        _mark_turns(joint, leg0, leg1, t0, t1, line, after)
        joint[~has_before | self.fixed | (has_before & self.fixed.take(b))] = BREAK
        self.joint = joint

    def reorder(self, order: np.ndarray) -> None:
        """Segment ``order[k]`` becomes segment k (:func:`piece_breaks` starts a closed piece elsewhere)."""
        self.fixed, self.joint, self.run = self.fixed.take(order), self.joint.take(order), self.run.take(order)
        self.start, self.end = self.start.take(order, axis=1), self.end.take(order, axis=1)

    def stretches(self) -> tuple[np.ndarray, np.ndarray]:
        """The runs [lo, hi) of segments between breaks that are not straight runs and hold
        more than one segment."""
        n = self.fixed.size
        starts = (~self.fixed & (self.joint == BREAK)).nonzero()[0]
        stops = np.concatenate(((self.fixed | (self.joint == BREAK)).nonzero()[0], [n]))
        ends = stops.take(stops.searchsorted(starts, side="right"))
        many = ends - starts > 1
        return starts.compress(many), ends.compress(many)

    def split(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The parts of more than one segment of the runs [lo, hi) (two segments or more
        each), cut at all their knots, or where they have none at the joint farthest from
        the run's chord (the middle one or two of those as far: a run along a periodic wave):
        ``(lo, hi, run)``, ``run`` the place of each part's run in [lo, hi)."""
        if lo.size == 0:
            return lo, hi, lo
        # every joint of every run, its ends included: the cuts and the ends bound the parts
        count = hi - lo + 1
        j = ranges(lo, count)
        firsts = count.cumsum() - count
        end = np.zeros(j.size, bool)
        end[firsts] = True
        end[firsts + count - 1] = True
        cut = self.joint.take(j, mode="clip") == KNOT  # (hi may be the last joint + 1)
        cut &= ~end
        plain = ~np.logical_or.reduceat(cut, firsts)  # runs without a knot
        if plain.any():
            inner = plain.nonzero()[0]  # their inner joints: from the second to the one before the last
            self._cut_farthest(cut, ranges(firsts.take(inner) + 1, count.take(inner) - 2), lo.take(inner),
                               hi.take(inner), count.take(inner) - 2)
        bound = cut | end
        at = j.compress(bound)  # consecutive bounds of one run bound a part
        of = np.arange(lo.size).repeat(count).compress(bound)
        part = ((of[1:] == of[:-1]) & (at[1:] - at[:-1] > 1)).nonzero()[0]
        return at.take(part), at.take(part + 1), of.take(part)

    def _cut_farthest(self, cut: np.ndarray, place: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                      inner: np.ndarray) -> None:
        """Set ``cut`` at the inner joint of each run [lo, hi) farthest from the run's chord,
        the middle one or two of those as far (``place``: where the runs' inner joints, each
        run's ``inner`` of them in turn, are in ``cut``)."""
        j = ranges(lo + 1, inner)
        firsts = inner.cumsum() - inner
        a = self.start.take(lo, axis=1).repeat(inner, axis=1)
        chord = self.end.take(hi - 1, axis=1).repeat(inner, axis=1) - a
        length = np.sqrt(chord[0] * chord[0] + chord[1] * chord[1])
        off = self.start.take(j, axis=1) - a
        across = np.abs(off[0] * chord[1] - off[1] * chord[0]) / np.maximum(length, 1e-300)
        dist = np.where(length > 0, across, np.sqrt(off[0] * off[0] + off[1] * off[1]))  # (closed: from its start)
        far = dist >= np.maximum.reduceat(dist, firsts).repeat(inner) - _TIE
        count = np.add.reduceat(far, firsts, dtype=np.int64)
        if (count > 1).any():  # ties (a periodic wave): the middle one or two
            seen = far.cumsum()
            rank = seen - 1 - (seen - far).take(firsts).repeat(inner)  # place among the farthest of its run
            count = count.repeat(inner)
            far &= (rank == (count - 1) // 2) | (rank == count // 2)
        cut[place.compress(far)] = True


def joined_breaks(parts: Sequence[Breaks]) -> Breaks:
    """The :class:`Breaks` of several images' pieces as one, each image's segments after the
    one before's (its straight runs renumbered so)."""
    out = Breaks.__new__(Breaks)
    offsets = np.cumsum([0] + [b.fixed.size for b in parts])
    out.ptr = np.concatenate([b.ptr[:-1] + offsets[i] for i, b in enumerate(parts)] + [offsets[-1:]])
    out.start, out.end = (np.concatenate([getattr(b, name) for b in parts], axis=1) for name in ("start", "end"))
    out.fixed, out.joint = (np.concatenate([getattr(b, name) for b in parts]) for name in ("fixed", "joint"))
    labels = np.cumsum([0] + [int(b.run.max(initial=-1)) + 1 for b in parts])
    out.run = np.concatenate([np.where(b.run >= 0, b.run + labels[i], -1) for i, b in enumerate(parts)])
    return out


def piece_breaks(pieces: BoundaryPieces) -> tuple[BoundaryPieces, Breaks]:
    """The pieces with every closed piece started at a place of the curve's own — the start
    of a straight run, else a knot — and their :class:`Breaks`, a piece's start a
    :data:`BREAK`; on a closed piece without straight run every knot is one."""
    breaks = Breaks(pieces)
    ptr = pieces.ptr
    closed = (pieces.closed & (ptr[1:] > ptr[:-1])).nonzero()[0]
    n = (ptr[1:] - ptr[:-1]).take(closed)
    seg = ranges(ptr.take(closed), n)
    owner = np.arange(closed.size).repeat(n)
    firsts = n.cumsum() - n
    fixed = breaks.fixed.take(seg)
    has_fixed = np.logical_or.reduceat(fixed, firsts) if n.size else np.zeros(0, bool)
    previous = np.where(seg == ptr.take(closed).repeat(n), ptr.take(closed + 1).repeat(n) - 1, seg - 1)
    starts_run = fixed & ~breaks.fixed.take(previous)
    target = np.where(has_fixed.take(owner), starts_run, breaks.joint.take(seg) == KNOT)
    none = np.iinfo(np.int64).max
    found = np.minimum.reduceat(np.where(target, seg, none), firsts) if n.size else np.zeros(0, np.int64)
    found = np.where(found == none, ptr.take(closed), found)
    shift = found - ptr.take(closed)
    if (shift > 0).any():
        order = np.arange(pieces.kind.size)
        order[seg] = ptr.take(closed).repeat(n) + (ranges(0, n) + shift.repeat(n)) % n.repeat(n)
        start = pieces.start.copy()
        start[closed] = pieces.end.take(np.where(shift > 0, found, ptr.take(closed + 1)) - 1, axis=0)
        pieces = replace(pieces, start=start, kind=pieces.kind.take(order), ctrl=pieces.ctrl.take(order, axis=0),
                         end=pieces.end.take(order, axis=0), span_slot=pieces.span_slot.take(order),
                         ctrl2=pieces.ctrl2.take(order, axis=0))
        breaks.reorder(order)  # (a closed piece's joints are those of its curve, wherever it starts)
    joint = breaks.joint
    joint[ptr[:-1].compress(ptr[1:] > ptr[:-1])] = BREAK
    free = seg.compress(~has_fixed.take(owner)) if n.size else seg
    joint[free.compress(joint.take(free) == KNOT)] = BREAK
    return pieces, breaks


def _unit(v: np.ndarray) -> np.ndarray:
    """(2, N) the unit vectors along the (2, N) planes ``v`` (0 stays 0)."""
    return v / np.maximum(np.sqrt(v[0] * v[0] + v[1] * v[1]), 1e-300)


def _straight_runs(line: np.ndarray, direction: np.ndarray, length: np.ndarray, before: np.ndarray,
                   first: np.ndarray, last: np.ndarray, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K,) bool: the straight segments (``line``: lines and the ``flat`` quadratics) of runs of
    collinear ones :data:`MIN_STRAIGHT` long or more, :data:`MIN_STRAIGHT_SPLINE` with a flat
    quadratic (on a closed piece a run may go on through its start; ``direction``: (2, K)
    planes), and (K,) the run of each (-1: none)."""
    b = np.maximum(before, 0)
    back = direction.take(b, axis=1)
    cont = line & (before >= 0) & line.take(b)
    cont &= np.abs(direction[0] * back[1] - direction[1] * back[0]) <= _EPS
    cont &= direction[0] * back[0] + direction[1] * back[1] > 0
    run_start = line & ~cont
    label = run_start.cumsum() - 1
    # the lines at a closed piece's start that go on from its last segment are its last run's
    gaps = (~cont).cumsum()
    leading = cont & (gaps == gaps.take(first) - (~cont).take(first))
    label[leading] = label.take(last.compress(leading))
    total = np.bincount(label.compress(line), weights=length.compress(line), minlength=int(run_start.sum()))
    if total.size == 0:
        return np.zeros(line.size, bool), np.full(line.size, -1, np.int64)
    curved = np.bincount(label.compress(line), weights=flat.compress(line), minlength=total.size) > 0
    enough = total >= np.where(curved, MIN_STRAIGHT_SPLINE, MIN_STRAIGHT)
    fixed = line & enough.take(np.maximum(label, 0))
    return fixed, np.where(fixed, label, -1)


def _mark_turns(joint: np.ndarray, leg0: np.ndarray, leg1: np.ndarray, t0: np.ndarray, t1: np.ndarray,
                line: np.ndarray, after: np.ndarray) -> None:
    """Make :data:`KNOT` the nearer joint of every quadratic whose tangent turns through a
    horizontal or vertical direction (both when it does so at its middle; the legs and unit
    tangents are (2, K) planes; ``after``: the joint where each segment ends, ``joint.size``
    for none)."""
    for axis in range(2):  # the tangent's x, then y, changes sign
        f0, f1 = t0[axis], t1[axis]
        seg = (~line & (f0 * f1 < 0) & (np.abs(f0) > _EPS) & (np.abs(f1) > _EPS)).nonzero()[0]
        a, b = leg0[axis].take(seg), leg1[axis].take(seg)
        t = a / (a - b)  # where (1 - t) a + t b, the tangent's component, is 0
        at_end = after.take(seg.compress(t >= 0.5 - _TIE))
        joint[seg.compress(t <= 0.5 + _TIE)] = KNOT
        joint[at_end.compress(at_end < joint.size)] = KNOT
