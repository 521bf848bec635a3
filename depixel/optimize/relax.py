"""Stage 5b — paper §3.4 — the relaxation: curve control points move to lower the energy
E_s + E_p of :mod:`depixel.optimize.energy`, the same way whatever the numbering.

The paper optimizes each node locally, in a random order, from random trial offsets. Here
every movable slot takes part in every round at once, with the same trials built from the
geometry (:mod:`depixel.optimize.trials`), so the result depends on the picture alone: not
on draws, slot numbers, the order or direction of the curves, or the image's position. One
round (:func:`propose`, then :func:`shares`):

1. each slot weighs its trials with its neighbours where they are, and takes the one of least
   energy that the guards allow (never farther than ``max_offset`` from its home p̂, never
   bringing a span closer than ``centre_clearance`` to a protected point unless it was
   closer already); trials whose energies agree within :data:`TIE` are tied, and a slot
   tied between several places goes to their mean (a slot on a mirror axis stays on it);
2. neighbours moving together could undo each other (a zigzag's points each jumping onto
   their neighbours' line would swap sides), so each slot moves only its **share** of the
   way: its gain over the largest sum of the gains of three consecutive slots whose spans it
   shapes (:func:`shares`). A slot whose neighbours stay moves all the way; three in a row
   of equal gains move a third each. With spans convex in their points this never raises
   the energy, and it is a continuous function of the gains (no discrete choice that a
   mirrored image's rounding could flip).

A slot that stays halves its pattern's radius (down to :data:`MIN_RADIUS`): coarse steps
first, fine ones where a slot has settled. Only slots whose trials changed are weighed
again: those within two slots of one that moved (their energies changed) and those whose
radius shrank; the others would stay again. The number of rounds is fixed (``iterations``)
and a slot's move depends only on slots within two of it along its curve (and on the
T-junction ends those move), so after k rounds a slot's place depends on nothing farther
than 2k slots along its curve; in practice a change fades within a few pixels (docs/design.md,
Optimization: over the corpus's one-pixel edits no drawn number changed farther than 7 px).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import batch_slices, row_any, row_count, row_min, set_rows
from ..curves.splines import SplineSet
from ..params import Params
from .energy import MEMBER_ROW, PREPARE_ONCE, Energy, Group, knots_of, trial_points
from .trials import TRIALS, trials
from .walkback import Moves

#: trials weighed together: bounds the memory of their spans (about 150 bytes a trial)
#: whatever the number of slots
STEP_TRIALS = 1 << 15
#: trials whose clearance is measured in one call: bounds the memory of their distances (about
#: 2 KB a trial: 13 points × the protected points, x and y, float64)
CLEARANCE_PAIRS = 1 << 12
#: energies closer than this are equal (the rounding of a mirrored image's arithmetic is ~1e-15)
TIE = 1e-9
#: the smallest radius of a slot's pattern of trials (pixels)
MIN_RADIUS = 0.02


class Relaxed(NamedTuple):
    """The result of :func:`relax`."""

    ctrl: np.ndarray  # (P, 2) relaxed control points (T-junction ends snapped)
    movable: np.ndarray  # (P,) bool: the slots that were free to move
    energy_before: float  # total energy before relaxing
    energy_after: float  # and after
    rounds: list[Moves]  # each round's moves, first to last (to walk them back: walkback)


def relax(splines: SplineSet, start: np.ndarray, corners: np.ndarray, excluded: np.ndarray,
          params: Params = Params()) -> Relaxed:
    """Relax the control points of ``splines`` from node positions ``start`` (N, 2) in
    ``params.iterations`` rounds.

    Open-curve ends and the slots at ``corners`` (N,) bool stay fixed; ``excluded`` (P, 2)
    marks the span halves left out of E_s. The rounds stop early once no slot would be weighed
    again (the rounds left would move nothing)."""
    model, anchor, done = relax_rounds(splines, start, corners, excluded, params)
    return done._replace(energy_before=model.total(anchor, anchor), energy_after=model.total(done.ctrl, anchor))


def relax_rounds(splines: SplineSet, start: np.ndarray, corners: np.ndarray, excluded: np.ndarray,
                 params: Params = Params(), parts: np.ndarray | None = None,
                 protected: np.ndarray | None = None) -> tuple[Energy, np.ndarray, Relaxed]:
    """:func:`relax`'s rounds: the energy model, the control points before relaxing (the
    anchors) and the result without its energies (NaN).

    ``parts`` (S+1,) cuts the slots into the curves of S images laid side by side, each in its
    own coordinates (:mod:`depixel.optimize.pack`): each part's rounds are those it would have
    alone (a part stops where it would have stopped: a round none of whose members is weighed
    leaves it as it is, its T-junction ends not snapped again). ``protected`` (P, 3, 2): the
    :func:`depixel.optimize.fidelity.protected_points` of every slot, when ``splines`` has no
    cell graph of its own to find them in."""
    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    movable = ~end & ~corners[splines.curve_nodes]
    model = Energy(splines, excluded, protected)
    ctrl = splines.controls_for(start)  # T-junction ends snapped onto their curves
    anchor = ctrl.copy()
    members = movable.nonzero()[0]
    # each member's part; each slot's part's length, to spread a part's verdict to its slots
    part_of = None if parts is None else parts.searchsorted(members, side="right") - 1
    lengths = None if parts is None else np.diff(parts)
    chunks = [(part.start, model.prepare(members[part])) for part in batch_slices(members.size, PREPARE_ONCE)]
    radius = np.full(members.size, params.radius)
    # staying's clearances (M, 2), NaN where not known: they change only when a slot within two
    # moved or the curve of an end snapped onto the member's spans did
    near = np.full((members.size, 2), np.nan)
    ends_on = np.concatenate([whole.ends_on for _, whole in chunks], axis=1) if chunks else np.zeros((3, 0), np.int32)
    active = np.ones(members.size, bool)  # the members weighed this round
    gains = np.zeros(ctrl.shape[0])  # every slot's gain this round (0: it stays)
    rounds = []
    for _ in range(params.iterations):
        rows = active.nonzero()[0]
        if rows.size == 0:
            break
        target = np.empty((2, rows.size))
        gain = np.empty(rows.size)
        known = near.take(rows, axis=0)
        for first, whole in chunks:
            lo, hi = rows.searchsorted([first, first + whole.members.size])
            if hi > lo:
                group = whole.part(rows[lo:hi] - first)
                target[:, lo:hi], gain[lo:hi] = propose(model, ctrl, anchor, group, radius.take(rows[lo:hi]),
                                                        known[lo:hi], params)
        near[rows] = known
        slots = members.take(rows)
        gains[slots] = gain
        share = shares(gains, prev, nxt).take(slots)
        gains[slots] = 0.0
        before = ctrl.copy()
        here = ctrl.take(slots, axis=0).T  # (2, R)
        target -= here
        target *= share
        target += here
        set_rows(ctrl, slots, target.T)
        ctrl = splines.snap(ctrl)  # ends that sit on a moved curve follow it
        if part_of is not None and lengths is not None:  # parts with no member weighed sit this round out
            busy = np.zeros(lengths.size, bool)
            busy[part_of.take(rows)] = True
            if not busy.all():
                np.copyto(ctrl, before, where=~busy.repeat(lengths)[:, None])
        moved = either_differs(ctrl, before)
        shrunk = rows.compress(gain <= 0.0)
        smaller = np.maximum(radius.take(shrunk) * 0.5, MIN_RADIUS)
        changed = smaller < radius.take(shrunk)
        radius[shrunk] = smaller
        stale = np.append(model.near(moved), False)  # index -1 (no end) reads False
        active = stale.take(members)
        near[active | np.logical_or.reduce(stale.take(ends_on), axis=0)] = np.nan
        active[shrunk.compress(changed)] = True
        went = members.compress(moved.take(members))
        if went.size:
            rounds.append(Moves(splines.curve_nodes.take(went), before.take(went, axis=0)))
    return model, anchor, Relaxed(ctrl, movable, np.nan, np.nan, rounds)


def either_differs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P,) bool: row i of ``a`` and ``b`` (P, 2) differ in x or y."""
    return (a[:, 0] != b[:, 0]) | (a[:, 1] != b[:, 1])


def shares(gains: np.ndarray, prev: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """(P,) the share of its move each slot makes: its gain over the largest sum of the gains of
    the three slots shaping a span it shapes (its own, the one before, the one after); 0 where
    it gains nothing. The shares of any three consecutive slots add up to at most 1, so every
    span's points move by at most a convex combination of the single moves. Sums add the
    two neighbours first (the same either way along a curve)."""
    padded = np.append(gains, 0.0)  # index -1 (past an open end) reads 0
    span = padded.take(prev) + padded.take(nxt)
    span += gains
    padded[:-1] = span
    most = np.maximum(np.maximum(padded.take(prev), padded.take(nxt)), span)
    return gains / np.where(most > 0.0, most, 1.0)


def propose(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group, radius: np.ndarray,
            near: np.ndarray, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """Where each member of ``group`` would go with its neighbours where they are, (2, M), and
    how much energy that saves, (M,) (0: it stays); the :func:`depixel.optimize.trials.trials`
    at ``radius`` (M,) are weighed :data:`STEP_TRIALS` at a time (the members do not depend on
    each other). ``near`` (M, 2): staying's clearances where known, NaN elsewhere; those
    measured are written in."""
    members = group.members.size
    if members * TRIALS <= STEP_TRIALS:
        return _best(model, ctrl, anchor, group, radius, near, params)
    target, gain = np.empty((2, members)), np.empty(members)
    for part in batch_slices(members, STEP_TRIALS // TRIALS):
        target[:, part], gain[part] = _best(model, ctrl, anchor, group.part(part), radius[part], near[part], params)
    return target, gain


def _best(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group, radius: np.ndarray,
          near: np.ndarray, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """:func:`propose` for the members of one batch (``near``: their staying's clearances, NaN
    where not known, measured here where needed).

    A trial is refused if it lies farther than ``max_offset`` from home,
    brings a span closer than ``centre_clearance`` to a protected point and closer than
    staying does, or moves farther than the curve could without crossing a protected point.
    Clearances decide only between trials lower than staying, so they are measured where they
    can: of staying, of the trials tied for the least energy and, where one of those is
    refused, of every trial lower than staying. Each verdict is then the one a clearance of
    every trial would give."""
    around = ctrl.take(group.around, axis=0).transpose(0, 2, 1)[..., None]  # (7, 2, M, 1)
    here = around[MEMBER_ROW]
    home = anchor.take(group.members, axis=0).T[..., None]
    trial = trials(around, home, radius)  # (2, M, T)
    knots = knots_of(around)
    energy, offset2 = model.evaluate(knots, home, group, trial)
    too_far = offset2 > params.max_offset**2
    too_far[:, 0] = False
    np.putmask(energy, too_far, np.inf)
    stay = energy[:, 0].copy()
    guard = _Guard(model, ctrl, knots, group, trial, params.centre_clearance, near)
    tied = _tied(energy)
    rows = (~tied[:, 0]).nonzero()[0]  # the members that would move
    if rows.size:  # staying and the trials tied for the least energy, in one call
        pairs = tied.take(rows, axis=0).ravel().nonzero()[0]
        pick, at = np.divmod(pairs, trial.shape[-1])
        member = rows[pick]
        refused = guard.staying_and(rows, here, member, at)
        near[rows] = guard.near[rows]
        across = guard.across()
        np.putmask(energy, across, np.inf)
        again = np.zeros(trial.shape[1], bool)  # the members with such a trial, in order (no sort)
        again[member.compress(refused | across.ravel().take(member * across.shape[1] + at))] = True
        rows = again.nonzero()[0]
    if rows.size:  # where one of them is refused, every other trial lower than staying
        energy.ravel()[(member * trial.shape[-1] + at).compress(refused)] = np.inf
        lower = energy.take(rows, axis=0) < stay.take(rows)[:, None]
        lower[:, 0] = False
        pick, at = np.divmod(lower.ravel().nonzero()[0], trial.shape[-1])
        member = rows[pick]
        refused = guard.refused(member, at)
        energy.ravel()[(member * trial.shape[-1] + at).compress(refused)] = np.inf
    tied = _tied(energy)
    count = row_count(tied)
    target = np.einsum("cmt,mt->cm", trial, tied) / count
    gain = stay - row_min(energy)
    gain[tied[:, 0]] = 0.0
    target[:, tied[:, 0]] = here[:, tied[:, 0], 0]
    rows = (count > 1).nonzero()[0]
    if rows.size:  # tied trials at different places (not one place reached two ways)
        spread = np.abs(trial.take(rows, axis=1) - target.take(rows, axis=1)[..., None]).max(axis=0)
        rows = rows.compress(row_any(tied.take(rows, axis=0) & (spread > 1e-12)))
    if rows.size:  # the mean of places tied (mirror images of each other) is a place of its own
        gain[rows] = _weigh_mean(model, guard, home, here, target, rows, stay, params)
        still = rows.compress(gain.take(rows) <= 0.0)
        target[:, still] = here[:, still, 0]
    return target, gain


def _weigh_mean(model: Energy, guard: _Guard, home: np.ndarray, here: np.ndarray, target: np.ndarray,
                rows: np.ndarray, stay: np.ndarray, params: Params) -> np.ndarray:
    """(R,) the gain of the members ``rows`` at the mean ``target`` of their tied trials, weighed
    and guarded as a trial of its own: 0 where it is no lower than staying, farther than
    ``max_offset`` from home, or refused by the ``guard``."""
    part = guard.group.part(rows)
    both = np.empty((2, rows.size, 2))
    both[:, :, 0] = here[:, rows, 0]
    both[:, :, 1] = target[:, rows]
    energy, offset2 = model.evaluate(guard.knots.take(rows, axis=2), home.take(rows, axis=1), part, both)
    sub = _Guard(model, guard.ctrl, guard.knots.take(rows, axis=2), part, both, guard.clearance)
    sub.near = guard.near.take(rows, axis=0)
    step = both[:, :, 1] - both[:, :, 0]
    sub.step[:, 1] = np.hypot(step[0], step[1])
    one = np.ones(rows.size, np.intp)
    refused = sub.refused(np.arange(rows.size), one) | sub.across()[:, 1]
    gain = stay.take(rows) - energy[:, 1]
    gain[refused | (offset2[:, 1] > params.max_offset**2) | (gain <= TIE)] = 0.0
    return gain


class _Guard:
    """The clearance verdicts on the trials (2, M, T) of one batch of members: a trial is refused
    if it brings a span closer than ``clearance`` to a protected point and closer than staying
    does, on either side of :func:`_clearance` (both by more than 1e-9: a verdict rounding
    cannot flip), or if it moves farther than the curve could without crossing one.

    Every point of the spans a trial shapes (its own, and those of the curves ending on them)
    moves by at most the trial's step from staying, so a trial whose step is shorter than
    staying's clearance less ``clearance`` is allowed unmeasured: only the others' clearances
    are measured, and each verdict is the one a measurement would give."""

    def __init__(self, model: Energy, ctrl: np.ndarray, knots: np.ndarray, group: Group, trial: np.ndarray,
                 clearance: float, near: np.ndarray | None = None):
        self.model, self.ctrl, self.knots, self.group, self.trial = model, ctrl, knots, group, trial
        self.clearance = clearance
        # staying's clearances (M, 2), NaN where not measured yet
        self.near = np.full((trial.shape[1], 2), np.nan) if near is None else near.copy()
        self.step = np.zeros(trial.shape[1:])  # each trial's distance from staying (M, T)

    def staying_and(self, rows: np.ndarray, here: np.ndarray, member: np.ndarray, at: np.ndarray) -> np.ndarray:
        """Measure the clearances of the members ``rows`` where they are (trial 0) where not
        known, and how far each trial is from there (``here`` (2, M, 1)); return which of the
        trials ``at`` of the members ``member`` (N,) are refused (:meth:`refused`), measured in
        the same call (those of members whose staying was not known yet: no bound to spare them)."""
        step = self.trial - here
        np.square(step, out=step)
        np.sqrt(np.add(step[0], step[1], out=self.step), out=self.step)
        unknown = np.isnan(self.near[:, 0])
        fresh = rows.compress(unknown.take(rows))
        doubt = (unknown.take(member) | (self._bound(member, at) < self.clearance)).nonzero()[0]
        clear = _clearance(self.model, self.ctrl, self.knots, self.group, self.trial,
                           np.concatenate([fresh, member.take(doubt)]),
                           np.concatenate([np.zeros(fresh.size, np.intp), at.take(doubt)]))
        self.near[fresh] = clear[:fresh.size]
        refused = np.zeros(member.size, bool)
        refused[doubt] = self.closer(clear[fresh.size:], member.take(doubt))
        return refused

    def _bound(self, member: np.ndarray, at: np.ndarray) -> np.ndarray:
        """(N,) a lower bound of the clearances of trials ``at`` of ``member``: staying's less the step."""
        return row_min(self.near.take(member, axis=0)) - self.step.ravel().take(member * self.trial.shape[-1] + at)

    def across(self) -> np.ndarray:
        """(M, T) bool: the trials that move farther than the curve could without crossing a
        protected point: every point of a span moves by at most the member's move, so the curve
        crosses a point only if the move is at least its distance before (d) plus after (at
        least min(d, clearance) for a trial the clearance allows)."""
        reach = row_min(self.near)
        reach += np.minimum(reach, self.clearance)
        far = self.step > reach[:, None] - 1e-9
        far[:, 0] = False
        return far

    def refused(self, member: np.ndarray, at: np.ndarray) -> np.ndarray:
        """(N,) bool: the trials ``at`` of the members ``member`` (N,) that come closer than
        allowed; measured only where staying's clearance less the step could be under
        ``clearance`` (the others are allowed)."""
        refused = np.zeros(member.size, bool)
        doubt = (self._bound(member, at) < self.clearance).nonzero()[0]
        if doubt.size:
            member, at = member.take(doubt), at.take(doubt)
            clear = _clearance(self.model, self.ctrl, self.knots, self.group, self.trial, member, at)
            refused[doubt] = self.closer(clear, member)
        return refused

    def closer(self, clear: np.ndarray, member: np.ndarray) -> np.ndarray:
        """(N,) bool: clearances ``clear`` (N, 2) of trials of the members ``member`` that are
        under the clearance and under staying's, on either side."""
        closer = (clear < self.clearance - 1e-9) & (clear < self.near.take(member, axis=0) - 1e-9)
        return closer[:, 0] | closer[:, 1]


def _tied(energy: np.ndarray) -> np.ndarray:
    """(M, T) bool: the trials within :data:`TIE` of each row's least energy; a row whose
    staying is among them stays (only staying is marked)."""
    tied = energy <= (row_min(energy) + TIE)[:, None]
    tied[tied[:, 0], 1:] = False
    return tied


def _clearance(model: Energy, ctrl: np.ndarray, knots: np.ndarray, group: Group, trial: np.ndarray,
               member: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(N, 2) the clearance of the members ``member`` (N,) at their trials ``at`` (N,): of their
    three spans, and of the first spans of the curves ending on them (T-junctions; +inf where
    none does), :data:`CLEARANCE_PAIRS` at a time. Apart, so that a curve already too close
    on one side does not free the other from its guard."""
    clear = np.full((member.size, 2), np.inf)
    for part in batch_slices(member.size, CLEARANCE_PAIRS):
        rows = member[part]
        points = trial_points(knots, group, trial, rows, at[part, None])
        clear[part, 0] = model.clearance_of(points, group, rows).ravel()
        clear[part, 1] = model.junctions.clearance(points, ctrl, group.ends_on.take(rows, axis=1)).ravel()
    return clear
