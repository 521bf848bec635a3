"""Stage 5b — paper §3.3–3.4 — the T-junction ends that follow a control point's moves.

A curve that ends on another one at a T-junction has its end snapped onto the point S of the
span of the continuing curve (§3.3, last paragraph), so moving a control point of the
continuing curve moves that end too, and with it the first span of the ending curve. The
relaxation's guard (:mod:`depixel.optimize.relax`) measures that span's clearance from its
protected points as well as the member's own three spans'; everything it needs that does
not move with the member is computed here once per relaxation.
"""
from __future__ import annotations

from functools import partial

import numpy as np

from ..curves.splines import SplineSet
from .fidelity import protected_points

#: t of the points the ending span is checked at (as :mod:`depixel.optimize.energy`'s spans)
_T = np.arange(5) / 4.0
#: the rows of :meth:`depixel.optimize.energy.Energy.points` whose (P0 + 2 P1 + P2) / 4 is the
#: point S of the span of a (P0 before, a, P2 before), of the member (own P0, trial, own P2)
#: and of b (P0 after, b, P2 after)
_TIPS = np.array([[0, 1, 5], [7, 4, 8], [6, 2, 3]])
#: (1, 2, 1) x and y's rows among a point row's two
_XY = np.arange(2)[None, :, None]
#: (3, 5, 1, 1, 1) the weights of P0, P1, P2 at those t, computed as :meth:`Junctions.clearance` did
_W = np.stack([(1 - _T) ** 2, 2 * _T * (1 - _T), _T**2])[:, :, None, None, None]


class Junctions:
    """The T-junction ends of a SplineSet: which slot's span each is snapped onto, and the
    fixed parts of its curve's first span."""

    def __init__(self, splines: SplineSet, protected: np.ndarray | None = None):
        prev, nxt = splines.neighbours()
        self.end = (prev < 0) | (nxt < 0)
        ends, through = splines.snap_pairs()
        # the ends snapped onto each slot's span, (K, P) (-1: none; a contour and the bands
        # between its colours can end at the same node)
        order = through.argsort(kind="stable")
        ends, through = ends.take(order), through.take(order)
        first = np.ones(through.size, bool)
        first[1:] = through[1:] != through[:-1]
        rank = np.arange(through.size) - np.maximum.accumulate(np.where(first, np.arange(through.size), 0))
        self.ending = np.full((int(rank.max(initial=0)) + 1, prev.size), -1, np.int32)
        self.ending[rank, through] = ends
        # each end's curve: the next two slots away from the end (c2 = c1 on a curve of two)
        self.row = np.full(prev.size, -1)
        self.row[ends] = np.arange(ends.size)
        forward = nxt.take(ends) >= 0
        self.c1 = np.where(forward, nxt.take(ends), prev.take(ends))
        c2 = np.where(forward, nxt.take(self.c1), prev.take(self.c1))
        self.c2 = np.where(c2 >= 0, c2, self.c1)
        # its protected points: the centres beside the edges end-c1 and c1-c2 (each stored with
        # the lower slot of its pair) and the split corners at the three nodes, (T, 7, 2): the
        # same whichever way the curve runs
        # (``protected``: every slot's, given where the curves have no cell graph of their own)
        points = partial(protected_points, splines) if protected is None else partial(protected.take, axis=0)
        centres = points(np.stack([np.minimum(ends, self.c1), np.minimum(self.c1, self.c2)], 1))
        corners = points(np.stack([ends, self.c1, self.c2], 1))[:, :, 2]
        protected = np.concatenate([centres[:, :, :2].reshape(ends.size, 4, 2), corners], axis=1)
        self.protected_xy = np.ascontiguousarray(protected.transpose(2, 1, 0))  # (2, 7, T)
        self.end_c2 = self.end.take(self.c2)  # the joint of C1 and C2 is C2 itself

    def clearance(self, points: np.ndarray, ctrl: np.ndarray, ends_on: np.ndarray) -> np.ndarray:
        """(N, J) the smallest distance from the first spans of the curves ending on N members'
        spans (``ends_on`` (3K, N), as :attr:`depixel.optimize.energy.Group.ends_on`) to their
        protected points, with the members at the trials of their ``points`` (9, 2, N, J)
        (:meth:`depixel.optimize.energy.Energy.points`); +inf where none ends there. The end
        follows the point S = (P0 + 2 P1 + P2) / 4 of the span it is snapped onto (as
        :meth:`depixel.curves.splines.SplineSet.snap`); the span is (S, C1, joint of C1 and C2),
        sampled at t = 0, ¼, ½, ¾, 1 as the member's own spans are. Every array is gathered by
        flat indices, x and y on a leading axis (a few calls whatever the number of ends)."""
        n, j = points.shape[2:]
        flat = (ends_on.ravel() >= 0).nonzero()[0]  # (which, member) pairs as which * N + member
        if flat.size == 0:
            return np.full((n, j), np.inf)
        which, member = np.divmod(flat, n)
        row = self.row.take(ends_on.ravel().take(flat))
        # the three points of the span each end is snapped onto, x and y: rows (3, 2, E) of
        # points seen as (9 * 2 * N, J)
        tips = _TIPS.T.take(which % 3, axis=1)[:, None] * 2 + _XY  # (3, 2, E): row * 2 + x or y
        tips *= n
        tips += member
        chosen = points.reshape(-1, j).take(tips.ravel(), axis=0).reshape(tips.shape + (j,))
        start = chosen[0] + 2.0 * chosen[1]
        start += chosen[2]
        start /= 4.0  # (2, E, J)
        planes = ctrl.T
        middle = planes.take(self.c1.take(row), axis=1)  # (2, E)
        after = planes.take(self.c2.take(row), axis=1)
        stop = np.where(self.end_c2.take(row), after, (middle + after) / 2.0)[..., None]  # (2, E, 1)
        curve = _W[0] * start + _W[1] * middle[..., None] + _W[2] * stop  # (5, 2, E, J)
        d = curve[:, :, None] - self.protected_xy.take(row, axis=2)[..., None]  # (5, 2, 7, E, J)
        np.square(d, out=d)
        near = np.add(d[:, 0], d[:, 1], out=d[:, 0]).min(axis=(0, 1))  # (E, J)
        every = np.full((ends_on.shape[0] * n, j), np.inf)
        every[flat] = np.sqrt(near, out=near)
        return every.reshape(-1, n, j).min(axis=0)
