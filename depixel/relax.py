"""Stage 5b — paper §3.4 — the relaxation: curve control points move to lower the energy.

Energy of the control point of slot i (equations 1-4 of the paper)::

    E(i) = E_s(i) + E_p(i),   E_s = ∫ |κ(s)| ds over the three spans i shapes,
                              E_p = ‖p_i − p̂_i‖⁴   (pixels; p̂_i its place before relaxing)

E_s is exact, not sampled (:func:`depixel.bspline.half_turns`); the halves of spans next to
a corner are left out (:func:`depixel.corners.excluded_halves`).

The paper's relaxation, vectorized: ``iterations`` sweeps; in each sweep the slots are
visited class by class, in a random order of the classes (slots of one class are three or
more slots apart along their curve, so their energies are independent and they move
together); each tries ``candidates`` random offsets within ``radius`` of its place and keeps
the best, or stays (:func:`step`). A move farther than ``max_offset`` from p̂ or too close
to a protected point (:mod:`depixel.fidelity`) is refused. T-junction ends follow the curve
they end on after every sweep. All randomness comes from ``numpy.random.default_rng(seed)``;
the draws depend only on array sizes, so a run is reproducible.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .bspline import Bezier, flatten, half_turns, span
from .fidelity import protected_points, unique_rows
from .params import Params
from .splines import SplineSet

#: each span is checked against the protected points at t = 0, ¼, ½, ¾, 1
CLEARANCE_PIECES = 4


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
    marks the span halves left out of E_s.
    """
    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    movable = ~end & ~corners[splines.curve_nodes]
    model = Energy(splines, excluded)
    ctrl = splines.controls_for(start)  # T-junction ends snapped onto their curves
    anchor = ctrl.copy()
    energy_before = model.total(ctrl, anchor)
    rng = np.random.default_rng(params.seed)
    classes = [model.prepare(m) for m in independent_classes(splines, movable) if m.size]
    for _ in range(params.iterations):
        for c in rng.permutation(len(classes)):
            group = classes[c]
            ctrl[group.members] = step(model, ctrl, anchor, group, rng, params)
        ctrl = splines.snap(ctrl)  # ends that sit on a moved curve follow it
    return Relaxed(ctrl, movable, energy_before, model.total(ctrl, anchor))


def step(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group,
         rng: np.random.Generator, params: Params) -> np.ndarray:
    """(M, 2) new places of one class of independent slots: each tries ``candidates``
    offsets uniform in the disc of ``radius`` and keeps the one of least energy, or stays.
    A trial farther than ``max_offset`` from its anchor is never taken; the best trial is
    refused if it brings a span closer than ``centre_clearance`` to a protected point (and
    closer than staying would)."""
    size = (group.members.size, params.candidates)
    angle = rng.uniform(0.0, 2.0 * np.pi, size=size)
    radius = params.radius * np.sqrt(rng.uniform(0.0, 1.0, size=size))
    here = ctrl[group.members][:, None, :]
    offsets = np.stack([np.cos(angle), np.sin(angle)], axis=-1) * radius[..., None]
    trial = np.concatenate([here, here + offsets], axis=1)  # (M, K+1, 2), 0 = stay
    energy = model.energy(ctrl, anchor, group, trial)
    too_far = ((trial - anchor[group.members][:, None]) ** 2).sum(axis=-1) > params.max_offset**2
    too_far[:, 0] = False
    best = np.argmin(np.where(too_far, np.inf, energy), axis=1)  # ties keep the lower index
    # the best trial must not bring a curve closer to a protected point than allowed
    # (unless it was closer already); only moving slots need the check
    rows = np.flatnonzero(best > 0)
    chosen = trial[rows, best[rows]][:, None]
    clear = model.clearance(ctrl, group, chosen, rows)[:, 0]
    near = clear < params.centre_clearance
    if near.any():
        stay = trial[rows[near], 0][:, None]
        clear_stay = model.clearance(ctrl, group, stay, rows[near])[:, 0]
        refuse = np.zeros(rows.size, bool)
        refuse[near] = clear[near] < clear_stay
        best[rows[refuse]] = 0
    return trial[np.arange(best.size), best]


@dataclass(frozen=True, eq=False)
class Group:
    """One class of independent slots with every index its evaluation needs, precomputed."""

    members: np.ndarray  # (M,) slots being moved
    a: np.ndarray  # previous slots
    b: np.ndarray  # next slots
    a2: np.ndarray  # slot before a (a itself when a is an end)
    b2: np.ndarray  # slot after b
    has_a: np.ndarray  # (M,) bool: the span of a exists (a is interior)
    has_b: np.ndarray
    end_a: np.ndarray  # (M, 1) bool, broadcastable over candidates
    end_b: np.ndarray
    end_a2: np.ndarray
    end_b2: np.ndarray
    keep_own: np.ndarray  # (M, 1, 2) bool: halves of each span counted in E_s
    keep_a: np.ndarray
    keep_b: np.ndarray
    protected: np.ndarray  # (M, 1, 1, Q, 2) points the spans must keep clear of


class Energy:
    """E_s + E_p of slots and their clearance from protected points, over the curve slots."""

    def __init__(self, splines: SplineSet, excluded: np.ndarray):
        self.prev, self.nxt = splines.neighbours()
        self.end = (self.prev < 0) | (self.nxt < 0)
        self.keep = ~excluded  # (P, 2) halves counted in E_s
        self.protected = protected_points(splines)  # (P, 3, 2)

    def prepare(self, members: np.ndarray) -> Group:
        a, b = self.prev[members], self.nxt[members]
        has_a, has_b = ~self.end[a], ~self.end[b]
        a2 = np.where(has_a, self.prev[a], a)
        b2 = np.where(has_b, self.nxt[b], b)
        protected = unique_rows(np.concatenate([self.protected[x] for x in (a2, a, members, b)], axis=1))

        def col(x: np.ndarray) -> np.ndarray:
            return x[:, None]

        return Group(
            members, a, b, a2, b2, has_a, has_b,
            col(self.end[a]), col(self.end[b]), col(self.end[a2]), col(self.end[b2]),
            col(self.keep[members]), col(self.keep[a]), col(self.keep[b]),
            protected[:, None, None],
        )

    def _spans(self, ctrl: np.ndarray, g: Group, trial: np.ndarray,
               rows: np.ndarray | slice = slice(None)) -> tuple[Bezier, Bezier, Bezier]:
        """The three spans a member shapes: before (of a), own, after (of b)."""
        c_a, c_b = ctrl[g.a[rows]][:, None], ctrl[g.b[rows]][:, None]
        c_a2, c_b2 = ctrl[g.a2[rows]][:, None], ctrl[g.b2[rows]][:, None]
        end_a, end_b = g.end_a[rows][..., None], g.end_b[rows][..., None]
        end_a2, end_b2 = g.end_a2[rows][..., None], g.end_b2[rows][..., None]
        own = span(c_a, trial, c_b, end_a, end_b)
        before = span(c_a2, c_a, trial, end_a2)
        after = span(trial, c_b, c_b2, after_is_end=end_b2)
        return before, own, after

    def energy(self, ctrl: np.ndarray, anchor: np.ndarray, g: Group, trial: np.ndarray) -> np.ndarray:
        """(M, K) energy of each member at each trial position."""
        before, own, after = self._spans(ctrl, g, trial)
        energy = smoothness(own, g.keep_own)
        energy = energy + np.where(g.has_a[:, None], smoothness(before, g.keep_a), 0.0)
        energy = energy + np.where(g.has_b[:, None], smoothness(after, g.keep_b), 0.0)
        return energy + positional(trial, anchor[g.members][:, None])

    def clearance(self, ctrl: np.ndarray, g: Group, trial: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """(R, K) smallest distance from the three spans of the members ``rows`` to their
        protected points (pixel centres beside them, diagonal-link corners), per trial."""
        before, own, after = self._spans(ctrl, g, trial, rows)
        n = CLEARANCE_PIECES
        points = np.concatenate([
            flatten(*before, n)[..., :-1, :], flatten(*own, n), flatten(*after, n)[..., 1:, :],
        ], axis=-2)  # (M, K, 3n + 1, 2)
        gap = ((points[..., None, :] - g.protected[rows]) ** 2).sum(axis=-1).min(axis=(-1, -2))
        return np.sqrt(gap)

    def total(self, ctrl: np.ndarray, anchor: np.ndarray) -> float:
        """The energy of all the curves: E_s of every span plus E_p of every slot."""
        p = np.flatnonzero(~self.end)
        a, b = self.prev[p], self.nxt[p]
        spans = span(ctrl[a], ctrl[p], ctrl[b], self.end[a][:, None], self.end[b][:, None])
        smooth = smoothness(spans, self.keep[p]).sum()
        return float(smooth + positional(ctrl, anchor).sum())


def smoothness(spans: Bezier, keep: np.ndarray) -> np.ndarray:
    """E_s of spans: ∫|κ| ds over the halves that ``keep`` (..., 2) selects."""
    first, second = half_turns(*spans)
    return first * keep[..., 0] + second * keep[..., 1]


def positional(p: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """E_p = ‖p − p̂‖⁴ (the paper's fourth power: free near home, stiff beyond)."""
    return (((p - anchor) ** 2).sum(axis=-1)) ** 2


def independent_classes(splines: SplineSet, movable: np.ndarray) -> list[np.ndarray]:
    """Split movable slots into classes whose members are ≥ 3 slots apart along each curve
    (a slot's energy involves its neighbours and theirs). Three classes by index modulo 3;
    a closed curve whose length is not a multiple of 3 puts its last one or two slots in
    two extra classes."""
    curve = splines.slot_curve()
    first = splines.curve_ptr[:-1][curve]
    length = np.diff(splines.curve_ptr)[curve]
    index = np.arange(curve.size) - first
    closed = splines.curve_closed[curve]
    rest = length % 3
    colour = index % 3
    tail = closed & (index >= length - rest)  # wrap-around leftovers of a closed curve
    colour = np.where(tail, 3 + (index - (length - rest)), colour)
    return [np.flatnonzero(movable & (colour == c)) for c in range(5)]
