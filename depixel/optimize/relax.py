"""Stage 5b — paper §3.4 — the relaxation: curve control points move to lower the energy
E_s + E_p of :mod:`depixel.optimize.energy`.

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
protected point (:mod:`depixel.optimize.fidelity`) is refused. T-junction ends follow the curve
they end on after every sweep. All randomness comes from SplitMix64 seeded with ``seed``
(:mod:`depixel.optimize.splitmix`: ``numpy.random`` would cost every process ~13 ms to import); the
draws depend only on array sizes and on the moves made, so a run is reproducible.
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from ..arrays import batch_slices, consecutive_slices, set_rows
from ..curves.splines import SplineSet
from ..params import Params
from .energy import MEMBER_ROW, PREPARE_ONCE, Energy, Group, knots_of, trial_points
from .splitmix import SplitMix64

#: trials weighed together in one step: bounds the memory of their spans (about 150 bytes a
#: trial) whatever the number of slots moved at once
STEP_TRIALS = 1 << 15
#: trials whose clearance is measured in one call: bounds the memory of their distances (about
#: 2 KB a trial: 13 points × the protected points, x and y, float64)
CLEARANCE_PAIRS = 1 << 12
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
    here = around[MEMBER_ROW]
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
    knots = knots_of(around)
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
        near = model.clearance_of(trial_points(knots, group, trial, rows, chosen[:, None]), group, rows).ravel()
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
            clear[part] = model.clearance_of(trial_points(knots, group, trial, member, at[part, None]), group,
                                             member).ravel()
        stay = clear.compress(at == 0)  # (R,)
        refused = near < stay
        # of the refused rows, the trials coming closer than allowed and than staying
        closer = (clear < params.centre_clearance) & (clear < stay.take(pick))
        closer &= refused.take(pick)
        energy.ravel()[pairs.compress(closer)] = np.inf
        best[rows.compress(refused)] = energy.compress(refused, axis=0).argmin(axis=1)
    return trial.reshape(2, -1).take(np.arange(0, best.size * trials, trials) + best, axis=1)  # (2, M)


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
