"""Stage 5b — paper §3.4 — the energy the relaxation lowers, slot by slot (:mod:`.relax` searches).

Energy of the control point of slot i (equations 1-4 of the paper)::

    E(i) = E_s(i) + E_p(i),   E_s = ∫ |κ(s)| ds over the three spans i shapes,
                              E_p = ‖p_i − p̂_i‖⁴   (pixels; p̂_i its place before relaxing)

E_s is exact, not sampled (:func:`depixel.curves.bspline.half_turns`); the halves of spans next to
a corner are left out (:func:`depixel.optimize.corners.excluded_halves`). :class:`Energy` also
measures a trial's clearance from the protected points (:mod:`depixel.optimize.fidelity`);
:class:`Group` holds every index the evaluation of one class of independent slots needs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..curves.bspline import Bezier, half_turns, span
from ..curves.splines import SplineSet
from .fidelity import protected_points, unique_rows
from .junctions import Junctions

#: each span is checked against the protected points at t = 0, ¼, ½, ¾, 1
CLEARANCE_PIECES = 4

#: a step of fewer members writes the spans' end points of all of them for the spans with one
#: half counted; a larger one, only of the members with such a span (~13 % of a frame's),
#: which saves arithmetic but costs a few calls (a sprite's steps have ~100 members)
SPANS_OF_FEW = 1 << 10

#: at most this many movable slots are prepared in one :meth:`Energy.prepare` and each colour
#: class is a slice of it (a sprite's 3-4 preparations were ~15 % of its relaxation, mostly
#: their numpy calls); more are prepared class by class, which bounds the preparation's
#: temporaries on a large image (all at once raised the 512² stripes' peak to ~1245 bytes a
#: pixel, benchmarks/memory_per_pixel.py)
PREPARE_ONCE = 1 << 12


def trial_points(knots: np.ndarray, group: Group, trial: np.ndarray, rows: np.ndarray, at: np.ndarray
                  ) -> np.ndarray:
    """(9, 2, N, J) :meth:`Energy.points` of the members ``rows`` (N,) at their trials
    ``at`` (N, J) (columns of ``trial`` (2, M, T)), given the members' :func:`knots_of`."""
    flat = rows[:, None] * trial.shape[-1] + at
    chosen = trial.reshape(2, -1).take(flat.ravel(), axis=1).reshape((2,) + flat.shape)
    return Energy.points(knots.take(rows, axis=2), group.ends.take(rows, axis=1), chosen)


def knots_of(around: np.ndarray) -> np.ndarray:
    """(2, 4, M, 1) the points of the members' spans that do not move with them, for ``around`` =
    ``ctrl[g.around]`` as (7, 2, M, 1): P0 of the span before (the midpoint of a2 and its
    partner), a, b, P2 of the span after (of b2 and its partner); computed once a step for the
    energy and the clearance's points."""
    knots = np.empty((2, 4) + around.shape[2:])
    by_row = knots.transpose(1, 0, 2, 3)  # (4, 2, M, 1), around's layout
    np.add(around[A2_ROW::B2_ROW - A2_ROW], around[A2_PARTNER_ROW:], out=by_row[::3])  # (a2, b2) + their partners
    by_row[::3] /= 2.0
    by_row[1:3] = around[A_ROW:B_ROW + 1:B_ROW - A_ROW]
    return knots


@dataclass(frozen=True, eq=False)
class Group:
    """One class of independent slots with every index its evaluation needs, precomputed."""

    members: np.ndarray  # (M,) slots being moved
    around: np.ndarray  # (7, M) int32: in curve order the slot before a (a itself when a is an
    #                     end) a2, the previous slot a, the member, the next slot b, the slot
    #                     after b b2; then the partners of a2 and b2: the span before starts at
    #                     the midpoint of a2 and its partner (a, or a2 itself where a2 is an
    #                     open-curve end: (p + p)/2 is p exactly), the span after ends at that
    #                     of b2 and its partner (b, or b2)
    ends: np.ndarray  # (2, M, 1) bool: a, b is an open-curve end (broadcastable over trials)
    keep: np.ndarray  # (2, 3, M, 1) 1.0 or 0.0: halves (first, second) of the spans before,
    #                   own, after counted in E_s (0 for the span of an end a or b; float, not
    #                   bool: numpy casts a bool operand through a buffer, slower)
    protected: np.ndarray  # (2, Q, M) x and y of the points the spans must keep clear of (float32 beyond
    #                        PREPARE_ONCE members)
    ends_on: np.ndarray  # (3K, M) int32: the T-junction ends snapped onto the spans of a, of the member
    #                      and of b (rows 3k + 0, 1, 2: they follow its moves, :class:`.junctions.Junctions`), or -1

    def part(self, members: slice | np.ndarray) -> Group:
        """The group of some of the members (a slice or indices into ``members``); indices are
        gathered with ``take`` (numpy 2's fancy indexing is several times slower here)."""
        if isinstance(members, slice):
            return Group(self.members[members], self.around[:, members], self.ends[:, members],
                         self.keep[:, :, members], self.protected[..., members], self.ends_on[:, members])
        return Group(self.members.take(members), self.around.take(members, axis=1), self.ends.take(members, axis=1),
                     self.keep.take(members, axis=2), self.protected.take(members, axis=2),
                     self.ends_on.take(members, axis=1))


#: :attr:`Group.around`'s rows (the last, 6, is b2's partner: read with a2's, ``around[A2_PARTNER_ROW:]``)
A2_ROW, A_ROW, MEMBER_ROW, B_ROW, B2_ROW, A2_PARTNER_ROW = range(6)
#: t of the points each span is checked at
_T = np.arange(CLEARANCE_PIECES + 1) / CLEARANCE_PIECES
#: (3, 3n+1) the row of :meth:`Energy.points` holding Bézier point P0-P2 of the span of each of a
#: trial's 3n+1 points, in curve order: the span before (without its last point: the own
#: span's P0), the own span, the span after (without its first point)
_SAMPLE_ROWS = np.repeat([[0, 7, 6], [1, 4, 2], [5, 8, 3]], [CLEARANCE_PIECES, CLEARANCE_PIECES + 1, CLEARANCE_PIECES],
                         axis=1)
#: (3, 3n+1, 1, 1, 1) the weights of the Bézier points P0-P2 at each of those points
_SAMPLE_WEIGHTS = np.stack([np.concatenate([w[:-1], w, w[1:]]) for w in ((1 - _T) ** 2, 2 * _T * (1 - _T), _T**2)]
                           )[..., None, None, None]

class Energy:
    """E_s + E_p of slots and their clearance from protected points, over the curve slots.

    The hot path keeps x and y on a leading axis (arrays ``(2, M, K)``) and the three spans
    a member shapes stacked on another, so one step is a few dozen whole-array operations.
    The spans' points and their clearance are computed by the same floating-point operations,
    in the same order, as :func:`depixel.curves.bspline.span` and :func:`depixel.curves.bspline.bezier_polylines`;
    E_s agrees with :func:`depixel.curves.bspline.half_turns` up to rounding: a turn is the
    difference of two leg directions wrapped into [0, π], and a span whose two halves count
    turns from d0 to d1 in one (its halves turn the same way, through dm = d0 + d1; except a
    span that doubles back onto its start, P2 = P0: its halves give 0, the whole π). The legs
    run in a chain (the d1 of a span is the d0 of the next), and those that move with a trial
    point two ways, from a to the member and from the member to b, so the three spans of a
    trial take two ``arctan2`` (the most costly operation of a large step) instead of six."""

    def __init__(self, splines: SplineSet, excluded: np.ndarray, protected: np.ndarray | None = None):
        self.prev, self.nxt = splines.neighbours()
        self.end = (self.prev < 0) | (self.nxt < 0)
        self.halves = ~excluded.T  # (2, P) halves (first, second) of each slot's span counted in E_s
        # the clearance's distances, the largest array of a step, in one buffer kept (and grown)
        # across the steps: a new one each call came from freshly grown heap on a frame (the 3
        # frames' relaxation: 25,000-30,000 page faults, ~8,600 with the buffer)
        self._distances = np.empty(0)
        self.splines = splines  # protected points are found per class, not held for every slot
        self.protected = protected  # unless given for every slot (P, 3, 2): curves without a cell graph
        self.junctions = Junctions(splines, protected)  # the T-junction ends that follow the slots' moves

    def prepare(self, members: np.ndarray) -> Group:
        a, b = self.prev.take(members), self.nxt.take(members)
        a2 = np.where(self.end.take(a), a, self.prev.take(a))
        b2 = np.where(self.end.take(b), b, self.nxt.take(b))
        slots = np.stack([a2, a, members, b, b2])  # (5, M): the slots whose spans a move changes, and b2
        end = self.end.take(slots)  # (5, M): which is an open-curve end (never the member)
        # the protected points of the four edges whose drawing a move changes (a2-a, a-member,
        # member-b, b-b2: those leaving the slots a2, a, member, b) and the split corners at the
        # five nodes a2..b2 (the same set read either way along the curve); computed once a slot
        # where that is no more work (nor memory) than five a member (a sprite's one preparation)
        if self.protected is not None:
            points = self.protected.take(slots.T, axis=0)
        elif self.splines.n_slots <= 5 * members.size:
            points = protected_points(self.splines).take(slots.T, axis=0)
        else:
            points = protected_points(self.splines, slots.T)
        points = np.concatenate([points[:, :4].reshape(members.size, -1, 2), points[:, 4, 2:]], axis=1)
        protected = unique_rows(points)
        # halves (first, second) of the spans before, own, after counted in E_s (none of the
        # span of an end a or b)
        keep = self.halves.take(slots[1:4], axis=1)  # (2, 3, M)
        keep[:, 0] &= ~end[1]
        keep[:, 2] &= ~end[3]
        around = np.empty((7, members.size), np.int32)
        around[:5] = slots
        around[5:] = np.where(end[::4], slots[::4], slots[1:4:2])  # the partners of a2 and b2
        return Group(
            members, around, end[1:4:2, :, None],
            # float32 holds these exactly (0, ±½, ±1 and their products): half the memory of
            # float64 for every slot of every class, the arithmetic still in float64
            keep.astype(np.float32)[..., None],
            # a compact copy (not a view of the padded rows); float32 holds these exactly, and
            # saves their memory on a large image, but a small one's float64 are subtracted
            # without a cast (its clearance's largest operation, ~1.5x faster)
            protected.transpose(2, 1, 0).astype(np.float64 if members.size <= PREPARE_ONCE else np.float32),
            self.junctions.ending.take(slots[1:4], axis=1).reshape(-1, members.size),
        )

    @staticmethod
    def points(knots: np.ndarray, ends: np.ndarray, trial: np.ndarray) -> np.ndarray:
        """The distinct Bézier points of the three spans (before, own, after) of each member at
        ``trial`` (2, M, K), given its :func:`knots_of` (2, 4, M, 1) and :attr:`Group.ends`:
        ``(9, 2, M, K)``, rows P0 of the span before, a, b, P2 of the span after (the knots),
        the trial, the midpoints of a and of b with it (P2 of the span before, P0 of the span
        after), P0 and P2 of the own span; written in place, pairs of rows in one call."""
        points = np.empty((9,) + trial.shape)
        points[:4] = knots.transpose(1, 0, 2, 3)
        points[4] = trial
        middle = np.add(points[1:3], trial, out=points[5:7])  # where the span before meets the own span, and
        middle /= 2.0  # the own span the span after (a + t and b + t: a sum is the same either way round)
        points[7:] = middle
        np.copyto(points[7:], points[1:3], where=ends[:, None])  # at an open end a (b) itself
        return points

    def evaluate(self, knots: np.ndarray, anchor: np.ndarray, g: Group, trial: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(M, K) energy of each member at ``trial`` (2, M, K), given its :func:`knots_of`, and the
        squared distance of each trial from its ``anchor`` (2, M, 1). E_s from the directions of the spans' legs (no
        points written: only those of the few trials whose clearance is measured are,
        :func:`trial_points`)."""
        c_a, c_b = knots[:, 1], knots[:, 2]
        members, k = trial.shape[1:]
        # the directions of the legs d0, d1 of the spans before, own, after run in a chain, the
        # d1 of one span the d0 of the next: (d0 before: fixed) a → member (d1 before, d0 own),
        # member → b (d1 own, d0 after), (d1 after: fixed); so the three turns are differences
        # of four directions, two arctan2 a trial
        chord = knots[:, 1::2] - knots[:, ::2]  # the fixed legs: P0 before → a, b → P2 after
        fixed = np.arctan2(chord[1], chord[0])  # (2, M, 1)
        legs = np.empty((2, 2, members, k))
        np.subtract(trial, c_a, out=legs[:, 0])
        np.subtract(c_b, trial, out=legs[:, 1])
        phi = np.empty((4, members, k))  # the four directions
        np.arctan2(legs[1], legs[0], out=phi[1:3])
        phi[::3] = fixed
        one = (g.keep[0] != g.keep[1]).ravel().nonzero()[0]  # spans (s·M + m) of which one half counts
        # the changes of direction of the spans (3, M, K): before, own, after; then of the halves
        # of the spans with one half counted: both wrapped into turns by one call
        change = np.empty((3 * members + one.size, k))
        smooth = np.subtract(phi[1:], phi[:-1], out=change[:3 * members].reshape(3, members, k))
        if one.size:
            # a half turns from d0 to dm = P2 - P0 or from dm to d1; the spans' end points in a
            # chain too (the span before ends where the own one starts unless a is an open end,
            # and then it counts no half; the same for the span after)
            if members < SPANS_OF_FEW:
                chain, rows, n = _span_tips(knots, g.ends, trial), one, members
            else:  # of the members with such a span alone (~13 % of a frame's)
                span, member = np.divmod(one, members)
                has = np.zeros(members, bool)
                has[member] = True
                who = has.nonzero()[0]
                n = who.size
                chain = _span_tips(knots.take(who, axis=2), g.ends.take(who, axis=1), trial.take(who, axis=1))
                rows = span * n + (has.cumsum() - 1).take(member)
            chord = chain.take(rows + n, axis=1) - chain.take(rows, axis=1)  # dm of those spans
            middle = np.arctan2(chord[1], chord[0])
            # the first half turns from d0 (phi's row s·M + m) to dm, the second from dm to d1
            # (row (s+1)·M + m); a turn's size does not depend on its sign (a - b is -(b - a) exactly)
            side = np.where(g.keep[1].ravel().take(one), one + members, one)
            np.subtract(phi.reshape(-1, k).take(side, axis=0), middle, out=change[3 * members:])
        _turns(change)
        smooth *= g.keep[0] * g.keep[1]
        if one.size:
            smooth.reshape(-1, k)[one] = change[3 * members:]  # (rows of K: faster than put or set_rows)
        offset = np.subtract(trial, anchor)
        np.square(offset, out=offset)
        offset2 = np.add(offset[0], offset[1])
        energy = np.add(smooth[1], smooth[0], out=smooth[1])
        energy += smooth[2]
        energy += np.square(offset2, out=offset[0])
        return energy, offset2

    def energy(self, ctrl: np.ndarray, anchor: np.ndarray, g: Group, trial: np.ndarray) -> np.ndarray:
        """(M, K) energy of each member at each trial position ``trial`` (M, K, 2)."""
        around = ctrl[g.around].transpose(0, 2, 1)[..., None]
        return self.evaluate(knots_of(around), anchor[g.members].T[..., None], g, np.moveaxis(trial, -1, 0))[0]

    def clearance_of(self, points: np.ndarray, g: Group, rows: np.ndarray) -> np.ndarray:
        """(N, J) smallest distance from the three spans of the members ``rows`` (N,) at J
        trials each, given by their :meth:`points` (9, 2, N, J), to their protected points
        (pixel centres beside them, diagonal-link corners)."""
        # the points at t = 0, ¼, ½, ¾, 1 of the spans in curve order (the before span without
        # its last point, the after span without its first: the own span's ends), W0·P0 + W1·P1
        # + W2·P2 as bspline.bezier_polylines; their distances to each protected point (2, Q, 3n+1, N, J)
        # with the trials innermost (an inner loop of N·J, not of 3n+1 with a protected point
        # broadcast over it: ~2.5x faster on a sprite's step), and the minimum over the two
        # leading axes (an elementwise minimum of rows; a minimum is exact in any order)
        weighed = points.take(_SAMPLE_ROWS.ravel(), axis=0).reshape(_SAMPLE_ROWS.shape + points.shape[1:])
        weighed *= _SAMPLE_WEIGHTS
        flat = np.add(weighed[0], weighed[1], out=weighed[0])
        flat += weighed[2]
        # float32 protected points widened (exactly) first: a subtraction that casts runs buffered, ~1.4x slower
        protected = g.protected.take(rows, axis=2).astype(np.float64, copy=False)
        shape = (2, protected.shape[1]) + flat.shape[:1] + flat.shape[2:]  # (2, Q, 3n+1, N, J)
        size = math.prod(shape)
        if self._distances.size < size:
            self._distances = np.empty(size)
        d = np.subtract(flat.transpose(1, 0, 2, 3)[:, None], protected[:, :, None, :, None],
                        out=self._distances[:size].reshape(shape))
        np.square(d, out=d)  # in place: these are the largest arrays of a step
        np.add(d[0], d[1], out=d[0])
        return np.sqrt(d[0].min(axis=(0, 1)))

    def clearance(self, ctrl: np.ndarray, g: Group, trial: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """(R, K) :meth:`clearance_of` the members ``rows`` at trial positions ``trial`` (R, K, 2)."""
        around = ctrl[g.around[:, rows]].transpose(0, 2, 1)[..., None]
        points = self.points(knots_of(around), g.ends[:, rows], np.moveaxis(trial, -1, 0))  # (9, 2, R, K)
        return self.clearance_of(points, g, rows)

    def near(self, moved: np.ndarray) -> np.ndarray:
        """(P,) bool: the slots within two slots along their curve of a ``moved`` slot (P,)
        bool, those whose energy a move of theirs changes."""
        reach = np.zeros(moved.size + 1, bool)  # index -1 (past an open end) reads False
        reach[:-1] = moved
        for _ in range(2):
            reach[:-1] |= reach.take(self.prev) | reach.take(self.nxt)
        return reach[:-1]

    def total(self, ctrl: np.ndarray, anchor: np.ndarray) -> float:
        """The energy of all the curves: E_s of every span plus E_p of every slot."""
        return self.totals(ctrl, anchor, np.array([0, ctrl.shape[0]]))[0]

    def totals(self, ctrl: np.ndarray, anchor: np.ndarray, parts: np.ndarray) -> list[float]:
        """:meth:`total` of each part of the slots that ``parts`` (S+1,) cuts (the curves of
        images side by side, :mod:`depixel.optimize.pack`): each sum runs over that part's
        terms alone, in order, as it would on its own."""
        p = (~self.end).nonzero()[0]
        a, b = self.prev.take(p), self.nxt.take(p)
        # the points gathered from x and y rows: (N, 2) views whose columns are rows, so that the
        # operations on them (and the sums over their axis of two) run along N, not along pairs
        planes = np.ascontiguousarray(ctrl.T)
        spans = span(planes.take(a, axis=1).T, planes.take(p, axis=1).T, planes.take(b, axis=1).T,
                     self.end.take(a)[:, None], self.end.take(b)[:, None])
        smooth = smoothness(spans, self.halves.take(p, axis=1).T)
        place = positional(ctrl, anchor)
        inner = p.searchsorted(parts)
        return [float(smooth[inner[i]:inner[i + 1]].sum() + place[parts[i]:parts[i + 1]].sum())
                for i in range(parts.size - 1)]


def _span_tips(knots: np.ndarray, ends: np.ndarray, trial: np.ndarray) -> np.ndarray:
    """(2, 4·N, K) the end points P0 of the span before, P0 and P2 of the own span, P2 of the
    span after, of N members at their ``trial`` (2, N, K), given :meth:`Energy.evaluate`'s
    ``knots`` (2, 4, N, 1) and :attr:`Group.ends`; the own span's two as :meth:`Energy.points`'."""
    n, k = trial.shape[1:]
    tips = np.empty((2, 4, n, k))
    tips[:, ::3] = knots[:, ::3]
    own = np.add(knots[:, 1:3], trial[:, None], out=tips[:, 1:3])
    own /= 2.0
    np.copyto(own, knots[:, 1:3], where=ends)
    return tips.reshape(2, -1, k)


def _turns(change: np.ndarray) -> np.ndarray:
    """The turns of changes of direction (differences of ``arctan2`` angles, in (−2π, 2π)): their
    size, the short way round, in [0, π]; in place."""
    np.abs(change, out=change)
    return np.minimum(change, 2.0 * np.pi - change, out=change)


def smoothness(spans: Bezier, keep: np.ndarray) -> np.ndarray:
    """E_s of spans: ∫|κ| ds over the halves that ``keep`` (..., 2) selects."""
    first, second = half_turns(*spans)
    return first * keep[..., 0] + second * keep[..., 1]


def positional(p: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """E_p = ‖p − p̂‖⁴ (the paper's fourth power: free near home, stiff beyond)."""
    square = np.square(p - anchor)
    return (square[..., 0] + square[..., 1]) ** 2  # (the sum of an axis of two, without its slow reduction)
