"""Stage 5b — paper §3.4 — the relaxation: curve control points move to lower the energy.

Energy of the control point of slot i (equations 1-4 of the paper)::

    E(i) = E_s(i) + E_p(i),   E_s = ∫ |κ(s)| ds over the three spans i shapes,
                              E_p = ‖p_i − p̂_i‖⁴   (pixels; p̂_i its place before relaxing)

E_s is exact, not sampled (:func:`depixel.bspline.half_turns`); the halves of spans next to
a corner are left out (:func:`depixel.corners.excluded_halves`).

The paper's relaxation, vectorized: ``iterations`` sweeps; in each sweep the slots are
visited class by class, in a random order of the classes (slots of one class are three or
more slots apart along their curve, so their energies are independent and they move
together); each tries ``candidates`` random offsets within ``radius`` of its place (a
turned pattern: :func:`disc_offsets`), :data:`GRADIENT_STEPS` points down the gradient of
its energy as a line search (analytic: :meth:`Energy.descent`) and its move of the sweep
before once more, and keeps the best trial the guards allow, or stays (:func:`step`).
After the first sweep only the slots within two slots of one that moved in the sweep
before are tried (the others' energies are unchanged: :meth:`Energy.near`), and the sweeps
stop once none moved. A move farther than ``max_offset`` from p̂ or too close to a
protected point (:mod:`depixel.fidelity`) is refused. T-junction ends follow the curve
they end on after every sweep. All randomness comes from SplitMix64 seeded with ``seed``
(:mod:`depixel.splitmix`: ``numpy.random`` would cost every process ~13 ms to import); the
draws depend only on array sizes and on the moves made, so a run is reproducible.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .arrays import batch_slices, consecutive_slices, set_rows
from .bspline import Bezier, half_turns, span
from .fidelity import protected_points, unique_rows
from .params import Params
from .splines import SplineSet
from .splitmix import SplitMix64

#: each span is checked against the protected points at t = 0, ¼, ½, ¾, 1
CLEARANCE_PIECES = 4
#: trials weighed together in one step: bounds the memory of their spans (about 150 bytes a
#: trial) whatever the number of slots moved at once
STEP_TRIALS = 1 << 15
#: trials whose clearance is measured in one call: bounds the memory of their distances (about
#: 2 KB a trial: 13 points × the protected points, x and y, float64)
CLEARANCE_PAIRS = 1 << 12
#: a step of fewer members writes the spans' end points of all of them for the spans with one
#: half counted; a larger one, only of the members with such a span (~13 % of a frame's),
#: which saves arithmetic but costs a few calls (a sprite's steps have ~100 members)
SPANS_OF_FEW = 1 << 10
#: at most this many movable slots are prepared in one :meth:`Energy.prepare` and each colour
#: class is a slice of it (a sprite's 3-4 preparations were ~15 % of its relaxation, mostly
#: their numpy calls); more are prepared class by class, which bounds the preparation's
#: temporaries on a large image (all at once raised the 512² stripes' peak to ~1245 bytes a
#: pixel: docs/performance.md)
PREPARE_ONCE = 1 << 12
#: trials down the gradient of a slot's energy, at these multiples of ``radius`` from it (a
#: short step where the energy curves fast, a long one where it is flat; docs/design.md)
GRADIENT_STEPS = np.array([0.5, 2.0])
#: the turn between consecutive trials of a slot's pattern of random trials, π(3 − √5)
GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


class Relaxed(NamedTuple):
    """The result of :func:`relax`."""

    ctrl: np.ndarray  # (P, 2) relaxed control points (T-junction ends snapped)
    movable: np.ndarray  # (P,) bool: the slots that were free to move
    energy_before: float  # total energy before relaxing
    energy_after: float  # and after


def relax(splines: SplineSet, start: np.ndarray, corners: np.ndarray, excluded: np.ndarray,
          params: Params = Params()) -> Relaxed:
    """Relax the control points of ``splines`` from node positions ``start`` (N, 2).

    Open-curve ends and the slots at ``corners`` (N,) bool stay fixed; ``excluded`` (P, 2)
    marks the span halves left out of E_s. After the first sweep only the slots of
    :meth:`Energy.near` a slot that moved in the sweep before are tried again (the others'
    energies did not change); the sweeps stop early once none moved.
    """
    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    movable = ~end & ~corners[splines.curve_nodes]
    model = Energy(splines, excluded)
    ctrl = splines.controls_for(start)  # T-junction ends snapped onto their curves
    anchor = ctrl.copy()
    energy_before = model.total(ctrl, anchor)
    rng = SplitMix64(params.seed)
    classes = _prepared_classes(model, independent_classes(splines, movable))
    active = movable  # the slots tried in this sweep
    last = np.zeros_like(ctrl)  # each slot's move in the sweep before
    for sweep in range(params.iterations):
        before = ctrl.copy()
        tried = []  # the group of each class with a slot to try, in this sweep's random order
        for c in rng.permutation(len(classes)):
            group = classes[c]
            chosen = active.take(group.members)
            if not chosen.all():
                if not chosen.any():
                    continue
                group = group.part(chosen.nonzero()[0])
            tried.append(group)
        for group, offsets in zip(tried, _sweep_offsets(rng, [g.members.size for g in tried], params)):
            # no last move to repeat in the first sweep
            set_rows(ctrl, group.members, step(model, ctrl, anchor, group, offsets, params, last if sweep else None))
        ctrl = splines.snap(ctrl)  # ends that sit on a moved curve follow it
        np.subtract(ctrl, before, out=last)
        moved = last != 0
        active = model.near(moved[:, 0] | moved[:, 1]) & movable  # (not .any(axis=1): slow over an axis of two)
        if not active.any():
            break
    return Relaxed(ctrl, movable, energy_before, model.total(ctrl, anchor))


def _prepared_classes(model: Energy, classes: list[np.ndarray]) -> list[Group]:
    """The :class:`Group` of each non-empty class of slots: slices of one preparation of them
    all when they are at most :data:`PREPARE_ONCE` (each member's numbers are its own; only
    the protected points' padding is wider), else one preparation a class."""
    classes = [c for c in classes if c.size]
    sizes = [c.size for c in classes]
    if not classes or sum(sizes) > PREPARE_ONCE:
        return [model.prepare(c) for c in classes]
    whole = model.prepare(np.concatenate(classes))
    return [whole.part(part) for part in consecutive_slices(sizes)]


def _sweep_offsets(rng: SplitMix64, sizes: list[int], params: Params) -> list[np.ndarray]:
    """The :func:`disc_offsets` (2, M, K) of each of a sweep's steps of ``sizes`` members, in
    turn: drawn for the whole sweep in one call when its members are at most
    :data:`PREPARE_ONCE` (a call is ~25 numpy calls whatever its size, and each member's
    offsets depend only on its own draw, the next of the stream: the same numbers as a call a
    step), else a call a step (which bounds their memory on a large image)."""
    if sum(sizes) > PREPARE_ONCE:
        return [disc_offsets(rng, size, params.candidates, params.radius) for size in sizes]
    offsets = disc_offsets(rng, sum(sizes), params.candidates, params.radius)
    return [offsets[:, part] for part in consecutive_slices(sizes)]


def disc_offsets(rng: SplitMix64, members: int, candidates: int, radius: float) -> np.ndarray:
    """(2, M, K) random trial offsets within ``radius``: for each member the same pattern of
    ``candidates`` points, turned by a random angle, its radii shifted by a random fraction.
    Point i lies at radius ``radius·√((i + u)/K)`` (one point in each ring of equal area) and
    angle ``θ + i·`` :data:`GOLDEN_ANGLE` (consecutive points far apart): the disc is covered
    more evenly than by independent draws, so the best of K trials lies lower (docs/design.md).
    One draw per member, not per trial."""
    draws = rng.unit_pairs(members)  # (turn θ / 2π, radial shift u) per member
    index, pattern = _pattern(candidates)
    turned = np.exp((2j * np.pi) * draws[:, :1]) * pattern  # (M, K) unit
    turned *= radius * np.sqrt((index + draws[:, 1:]) / candidates)
    offsets = np.empty((2, members, candidates))
    offsets[0], offsets[1] = turned.real, turned.imag
    return offsets


@functools.cache
def _pattern(candidates: int) -> tuple[np.ndarray, np.ndarray]:
    """The trial indices 0..K-1 and the pattern's own turns e^(i·k·golden angle) of
    :func:`disc_offsets` (the same every step: computed once a K; read only)."""
    index = np.arange(candidates)
    pattern = np.exp((1j * GOLDEN_ANGLE) * index)
    index.flags.writeable = pattern.flags.writeable = False
    return index, pattern


@functools.cache
def _gradient_lengths(radius: float) -> np.ndarray:
    """:data:`GRADIENT_STEPS` times ``radius`` (computed once a radius; read only)."""
    lengths = radius * GRADIENT_STEPS
    lengths.flags.writeable = False
    return lengths


def step(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group, offsets: np.ndarray,
         params: Params, last: np.ndarray | None = None) -> np.ndarray:
    """(M, 2) new places of one class of independent slots: each tries its ``offsets``
    (2, M, K) from its place, the points :data:`GRADIENT_STEPS` down its gradient and, given
    ``last`` (P, 2) (every slot's move in the sweep before), the same move again; and takes
    the trial of least energy that the guards allow, or stays. A trial farther than
    ``max_offset`` from its anchor is never taken, nor one that brings a span closer than
    ``centre_clearance`` to a protected point (and closer than staying would). The trials are
    weighed :data:`STEP_TRIALS` at a time (the members do not depend on each other)."""
    members, k = offsets.shape[1:]
    repeat = None if last is None else last.take(group.members, axis=0).T[..., None]  # (2, M, 1)
    trials = 1 + k + len(GRADIENT_STEPS) + (repeat is not None)
    if members * trials <= STEP_TRIALS:
        return _best_trials(model, ctrl, anchor, group, offsets, repeat, params).T
    moved = np.empty((2, members))  # x and y planes
    for part in batch_slices(members, max(1, STEP_TRIALS // trials)):
        moved[:, part] = _best_trials(model, ctrl, anchor, group.part(part), offsets[:, part],
                                      None if repeat is None else repeat[:, part], params)
    return moved.T


def _best_trials(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group, offsets: np.ndarray,
                 repeat: np.ndarray | None, params: Params) -> np.ndarray:
    """:func:`step` for the members of ``group``, given their random ``offsets`` (2, M, K)
    and last moves ``repeat`` (2, M, 1) or None.
    Rows are picked with ``take`` and masks applied with ``putmask``: numpy 2's fancy indexing
    copies the rows of these arrays one at a time (docs/performance.md)."""
    members, k = offsets.shape[1:]
    around = ctrl.take(group.around, axis=0).transpose(0, 2, 1)[..., None]  # (7, 2, M, 1): Group.around's rows
    here = around[_MEMBER]
    home = anchor.take(group.members, axis=0).T[..., None]
    # trials (2, M, 1+K+L+R): x and y planes; column 0 = stay, then K random, L down the
    # gradient and R (0 or 1) the last move again
    grad = k + 1 + len(GRADIENT_STEPS)
    trial = np.empty((2, members, grad + (repeat is not None)))
    trial[:, :, :1] = here
    np.add(here, offsets, out=trial[:, :, 1:k + 1])
    descent = model.descent(around, home, group)
    np.multiply(descent, _gradient_lengths(params.radius), out=trial[:, :, k + 1:grad])
    trial[:, :, k + 1:grad] += here
    if repeat is not None:
        np.add(here, repeat, out=trial[:, :, grad:])
    knots = _knots(around)
    energy, offset2 = model.evaluate(knots, home, group, trial)
    too_far = offset2 > params.max_offset**2
    too_far[:, 0] = False
    np.putmask(energy, too_far, np.inf)  # never taken
    best = energy.argmin(axis=1)  # ties keep the lower index
    # the trial taken must not bring a curve closer to a protected point than allowed (unless
    # it was closer already), so the clearance is measured only where it can decide: of the
    # best trial, where it is not staying; where the best one comes within the clearance, of
    # staying and of the trials lower than staying (the others cannot be taken: staying is
    # always allowed and wins ties) in one call; where the best one is refused (staying is
    # not as close), the best one of those allowed is taken. Each number is the one a
    # clearance of every trial would give (a minimum)
    trials = trial.shape[-1]
    rows = (best > 0).nonzero()[0]
    if rows.size:
        chosen = best.take(rows)
        near = model.clearance_of(_trial_points(knots, group, trial, rows, chosen[:, None]), group, rows).ravel()
        close = near < params.centre_clearance
        rows, chosen, near = rows.compress(close), chosen.compress(close), near.compress(close)
    if rows.size:
        energy = energy.take(rows, axis=0)  # (R, T)
        energy.ravel()[np.arange(0, rows.size * trials, trials) + chosen] = np.inf  # the best, not allowed
        lower = energy < energy[:, :1]  # the others lower than staying
        lower[:, 0] = True  # and staying, the first of each row
        pairs = lower.ravel().nonzero()[0]  # flat (row, trial)
        pick, at = np.divmod(pairs, trials)
        clear = np.empty(pairs.size)
        for part in batch_slices(pairs.size, CLEARANCE_PAIRS):
            member = rows.take(pick[part])
            clear[part] = model.clearance_of(_trial_points(knots, group, trial, member, at[part, None]), group,
                                             member).ravel()
        stay = clear.compress(at == 0)  # (R,)
        refused = near < stay
        # of the refused rows, the trials coming closer than allowed and than staying
        closer = (clear < params.centre_clearance) & (clear < stay.take(pick))
        closer &= refused.take(pick)
        energy.ravel()[pairs.compress(closer)] = np.inf
        best[rows.compress(refused)] = energy.compress(refused, axis=0).argmin(axis=1)
    return trial.reshape(2, -1).take(np.arange(0, best.size * trials, trials) + best, axis=1)  # (2, M)


def _trial_points(knots: np.ndarray, group: Group, trial: np.ndarray, rows: np.ndarray, at: np.ndarray
                  ) -> np.ndarray:
    """(9, 2, N, J) :meth:`Energy.points` of the members ``rows`` (N,) at their trials
    ``at`` (N, J) (columns of ``trial`` (2, M, T)), given the members' :func:`_knots`."""
    flat = rows[:, None] * trial.shape[-1] + at
    chosen = trial.reshape(2, -1).take(flat.ravel(), axis=1).reshape((2,) + flat.shape)
    return Energy.points(knots.take(rows, axis=2), group.ends.take(rows, axis=1), chosen)


def _knots(around: np.ndarray) -> np.ndarray:
    """(2, 4, M, 1) the points of the members' spans that do not move with them, for ``around`` =
    ``ctrl[g.around]`` as (7, 2, M, 1): P0 of the span before (the midpoint of a2 and its
    partner), a, b, P2 of the span after (of b2 and its partner); computed once a step for the
    energy and the clearance's points."""
    knots = np.empty((2, 4) + around.shape[2:])
    by_row = knots.transpose(1, 0, 2, 3)  # (4, 2, M, 1), around's layout
    np.add(around[_A2::_B2 - _A2], around[_A2_PARTNER:], out=by_row[::3])  # (a2, b2) + their partners
    by_row[::3] /= 2.0
    by_row[1:3] = around[_A:_B + 1:_B - _A]
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
    scale: np.ndarray  # (2, 3, 1, M, 1) d0 and d1 of the spans before, own, after over their control legs
    slope: np.ndarray  # (3, 3, M, 1) ∂E_s/∂φ of d0, dm, d1 of each span, times how fast each turns
    #                    with the member (signs of the turns and lengths left out: Energy.descent)

    def part(self, members: slice | np.ndarray) -> Group:
        """The group of some of the members (a slice or indices into ``members``); indices are
        gathered with ``take`` (numpy 2's fancy indexing is several times slower here)."""
        if isinstance(members, slice):
            return Group(self.members[members], self.around[:, members], self.ends[:, members],
                         self.keep[:, :, members], self.protected[..., members], self.scale[..., members, :],
                         self.slope[:, :, members])
        return Group(self.members.take(members), self.around.take(members, axis=1), self.ends.take(members, axis=1),
                     self.keep.take(members, axis=2), self.protected.take(members, axis=2),
                     self.scale.take(members, axis=3), self.slope.take(members, axis=2))


#: :attr:`Group.around`'s rows
_A2, _A, _MEMBER, _B, _B2, _A2_PARTNER, _B2_PARTNER = range(7)
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
#: how dm of the span before and of the span after moves with the member: ½ and -½ (the own
#: span's dm moves by the difference of its legs' shares, s_a - s_b)
_DM_SLOPE = np.array([[0.5], [-0.5]])
#: the smallest positive float64: a floor for the descent's squared lengths
_TINY = np.finfo(float).tiny


class Energy:
    """E_s + E_p of slots and their clearance from protected points, over the curve slots.

    The hot path keeps x and y on a leading axis (arrays ``(2, M, K)``) and the three spans
    a member shapes stacked on another, so one step is a few dozen whole-array operations.
    The spans' points and their clearance are computed by the same floating-point operations,
    in the same order, as :func:`depixel.bspline.span` and :func:`depixel.bspline.flatten`;
    E_s agrees with :func:`depixel.bspline.half_turns` up to rounding: a turn is the
    difference of two leg directions wrapped into [0, π], and a span whose two halves count
    turns from d0 to d1 in one (its halves turn the same way, through dm = d0 + d1; except a
    span that doubles back onto its start, P2 = P0: its halves give 0, the whole π). The legs
    run in a chain (the d1 of a span is the d0 of the next), and those that move with a trial
    point two ways, from a to the member and from the member to b, so the three spans of a
    trial take two ``arctan2`` (the most costly operation of a large step) instead of six."""

    def __init__(self, splines: SplineSet, excluded: np.ndarray):
        self.prev, self.nxt = splines.neighbours()
        self.end = (self.prev < 0) | (self.nxt < 0)
        self.halves = ~excluded.T  # (2, P) halves (first, second) of each slot's span counted in E_s
        # the clearance's distances, the largest array of a step, in one buffer kept (and grown)
        # across the steps: a new one each call came from freshly grown heap on a frame (the 3
        # frames' relaxation: 25,000-30,000 page faults, ~8,600 with the buffer; docs/performance.md)
        self._distances = np.empty(0)
        self.splines = splines  # protected points are found per class, not held for every slot

    def prepare(self, members: np.ndarray) -> Group:
        a, b = self.prev.take(members), self.nxt.take(members)
        a2 = np.where(self.end.take(a), a, self.prev.take(a))
        b2 = np.where(self.end.take(b), b, self.nxt.take(b))
        slots = np.stack([a2, a, members, b, b2])  # (5, M): the slots whose spans a move changes, and b2
        end = self.end.take(slots)  # (5, M): which is an open-curve end (never the member)
        # the protected points of the four slots whose spans a move changes; computed once a slot
        # where that is no more work (nor memory) than four a member (a sprite's one preparation)
        if self.splines.n_slots <= 4 * members.size:
            points = protected_points(self.splines).take(slots[:4].T, axis=0)
        else:
            points = protected_points(self.splines, slots[:4].T)
        protected = unique_rows(points.reshape(members.size, -1, 2))
        # halves (first, second) of the spans before, own, after counted in E_s (none of the
        # span of an end a or b)
        keep = self.halves.take(slots[1:4], axis=1)  # (2, 3, M)
        keep[:, 0] &= ~end[1]
        keep[:, 2] &= ~end[3]
        # a leg's share of a span vector: whole at an open-curve end, half otherwise
        share = np.where(end, 1.0, 0.5)  # (5, M)
        s_a, s_b = share[1], share[3]
        scale = np.full((2, 3, members.size), 0.5)
        scale[0, :2], scale[1, 1:] = share[:2], share[3:]  # (a2, a) and (b, b2)
        # how d0, dm, d1 of the spans before, own, after move with the member (multiples of it),
        # times the halves counted: E_s = Σ |φ(dm) − φ(d0)| (first half) + |φ(d1) − φ(dm)| (second)
        first, second = keep.astype(float)  # (3, M)
        slope = np.zeros((3, 3, members.size))
        slope[0, 1], slope[0, 2] = -s_a * first[1], 0.5 * first[2]  # d0 (before: fixed)
        dm = np.subtract(first, second, out=slope[1])
        dm[::2] *= _DM_SLOPE
        dm[1] *= s_a - s_b
        slope[2, 0], slope[2, 1] = 0.5 * second[0], -s_b * second[1]  # d1 (after: fixed)

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
            scale.astype(np.float32)[:, :, None, :, None], slope.astype(np.float32)[..., None],
        )

    @staticmethod
    def points(knots: np.ndarray, ends: np.ndarray, trial: np.ndarray) -> np.ndarray:
        """The distinct Bézier points of the three spans (before, own, after) of each member at
        ``trial`` (2, M, K), given its :func:`_knots` (2, 4, M, 1) and :attr:`Group.ends`:
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
        """(M, K) energy of each member at ``trial`` (2, M, K), given its :func:`_knots`, and the
        squared distance of each trial from its ``anchor`` (2, M, 1). E_s from the directions of the spans' legs (no
        points written: only those of the few trials whose clearance is measured are,
        :func:`_trial_points`)."""
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

    def descent(self, around: np.ndarray, anchor: np.ndarray, g: Group) -> np.ndarray:
        """(2, M, 1) unit direction of steepest descent of each member's energy at its place
        (zero where the gradient vanishes), for ``around`` as in :func:`_knots` and ``anchor`` as
        in :meth:`evaluate`."""
        edge = around[_A:_B2 + 1] - around[_A2:_B2]  # (4, 2, M, 1) along a2, a, member, b, b2
        vec = np.empty((3, 3) + edge.shape[1:])  # (3, 3, 2, M, 1): d0, dm, d1 of each span
        d0, d1 = vec[0], vec[2]
        np.multiply(edge[:3], g.scale[0], out=d0)  # P1 - P0 of the spans before, own, after
        np.multiply(edge[1:], g.scale[1], out=d1)  # P2 - P1
        np.add(d0, d1, out=vec[1])
        # x and y together where both are multiplied alike (a call a product, not one a coordinate)
        cross = d0 * d1[:, ::-1]  # (3, 2, M, 1): x0·y1, y0·x1
        turn = np.sign(cross[:, 0] - cross[:, 1])  # (3, M, 1) the way each span turns
        square = np.square(vec)
        length2 = np.maximum(square[:, :, 0] + square[:, :, 1], _TINY)
        coef = g.slope * turn / length2  # (3, 3, M, 1)
        along = np.add.reduce(coef[:, :, None] * vec[:, :, ::-1], axis=(0, 1))  # (2, M, 1): Σ coef·y, Σ coef·x
        offset = around[_MEMBER] - anchor
        square = np.square(offset)
        down = (-4.0 * (square[0] + square[1])) * offset  # E_p = |o|^4: gradient 4 |o|^2 o, negated
        down[0] += along[0]  # minus the gradient, negated exactly term by term
        down[1] -= along[1]
        np.square(down, out=square)
        norm = np.sqrt(square[0] + square[1])
        down /= np.where(norm > 0, norm, 1.0)
        return down

    def energy(self, ctrl: np.ndarray, anchor: np.ndarray, g: Group, trial: np.ndarray) -> np.ndarray:
        """(M, K) energy of each member at each trial position ``trial`` (M, K, 2)."""
        around = ctrl[g.around].transpose(0, 2, 1)[..., None]
        return self.evaluate(_knots(around), anchor[g.members].T[..., None], g, np.moveaxis(trial, -1, 0))[0]

    def clearance_of(self, points: np.ndarray, g: Group, rows: np.ndarray) -> np.ndarray:
        """(N, J) smallest distance from the three spans of the members ``rows`` (N,) at J
        trials each, given by their :meth:`points` (9, 2, N, J), to their protected points
        (pixel centres beside them, diagonal-link corners)."""
        # the points at t = 0, ¼, ½, ¾, 1 of the spans in curve order (the before span without
        # its last point, the after span without its first: the own span's ends), W0·P0 + W1·P1
        # + W2·P2 as bspline.flatten; their distances to each protected point (2, Q, 3n+1, N, J)
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
        points = self.points(_knots(around), g.ends[:, rows], np.moveaxis(trial, -1, 0))  # (9, 2, R, K)
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
        p = (~self.end).nonzero()[0]
        a, b = self.prev.take(p), self.nxt.take(p)
        # the points gathered from x and y rows: (N, 2) views whose columns are rows, so that the
        # operations on them (and the sums over their axis of two) run along N, not along pairs
        planes = np.ascontiguousarray(ctrl.T)
        spans = span(planes.take(a, axis=1).T, planes.take(p, axis=1).T, planes.take(b, axis=1).T,
                     self.end.take(a)[:, None], self.end.take(b)[:, None])
        smooth = smoothness(spans, self.halves.take(p, axis=1).T).sum()
        return float(smooth + positional(ctrl, anchor).sum())


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


def independent_classes(splines: SplineSet, movable: np.ndarray) -> list[np.ndarray]:
    """Split movable slots into classes whose members are ≥ 3 slots apart along each curve
    (a slot's energy involves its neighbours and theirs): every three slots in a row along a
    curve, around a closed one's seam too, have three colours. Colours 0-2 by index modulo 3;
    a closed curve whose length is not a multiple of 3 ends in a slot of colour 3 (length
    3q + 1) or in two blocks 0, 1, 2, 3 (length 3q + 2, from 8 on); a closed curve of 5
    slots takes colours 0-4. Four classes, not five: a step is a fixed ~0.3 ms of numpy
    calls however few members it moves (docs/performance.md)."""
    curve = splines.slot_curve()
    first = splines.curve_ptr[:-1][curve]
    length = np.diff(splines.curve_ptr)[curve]
    index = np.arange(curve.size) - first
    closed = splines.curve_closed[curve]
    colour = index % 3
    rest = length % 3
    colour = np.where(closed & (rest == 1) & (index == length - 1), 3, colour)
    block = closed & (rest == 2) & (index >= length - 8)  # 0, 1, 2, 3, 0, 1, 2, 3 at the end
    colour = np.where(block, (index - (length - 8)) % 4, colour)
    colour = np.where(closed & (length == 5), index, colour)
    return [(movable & (colour == c)).nonzero()[0] for c in range(5)]
