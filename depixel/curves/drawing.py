"""What a :class:`~depixel.curves.splines.SplineSet` is drawn into, and the plans that draw it.

:class:`Geometry` and :class:`Drawing` are the drawing of a SplineSet at some node
positions; :class:`DrawPlan` and :class:`SnapPlan` hold the indices a SplineSet computes once
to draw its curves and to snap its T-junction ends (§3.3, last paragraph).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import flat_rows
from .bspline import joint, midpoint


class Geometry(NamedTuple):
    """The drawing of a SplineSet at some node positions (the fields of a VectorImage)."""

    points: np.ndarray  # (N, 2) display point of every node: its curve point S on a curve
    curved: np.ndarray  # (E,) bool: the edge is drawn as two quadratic Béziers
    controls: np.ndarray  # (E, 3, 2) c0, c1, c2 of "points[u] Q c0 c1 Q c2 points[v]"


class Drawing(NamedTuple):
    """:class:`Geometry` with the controls of the curved edges alone (for measuring it)."""

    points: np.ndarray  # (N, 2) as Geometry.points
    edges: np.ndarray  # (C,) the curved edges, in slot order
    controls: np.ndarray  # (C, 3, 2) their Geometry.controls
    ctrl: np.ndarray | None = None  # (P, 2) the control points drawn (SplineSet.controls_for), if known


class DrawPlan(NamedTuple):
    """What a drawing of a SplineSet needs besides the control points C, fixed per SplineSet.

    The joint of a slot and the next one, J_j = joint(C_j, C_next), is also the start of the
    next slot's span (the same sum), so the spans' ends are rows of the table [C; S; J] (P
    rows each, :meth:`SplineSet._table`): ``ends`` (2, P) the start and stop of every slot's
    span (a neighbour that is an open end: its control point; past an end: a meaningless
    row); ``is_end`` (P, 1). The curved edges' operands of
    :func:`depixel.curves.bspline.between_curve_points` are rows of the same table: ``operands``
    (5, C) mid, near_a, near_b (swapped where the edge is stored against the curve), start,
    stop; ``split`` (C, 1). ``inner`` the inner slots and ``inner_flat`` the
    flat indices (x, y) of their nodes in an (N, 2) array; ``edges`` the curved edges."""

    after: np.ndarray
    ends: np.ndarray
    is_end: np.ndarray
    inner: np.ndarray
    inner_flat: np.ndarray
    operands: np.ndarray
    split: np.ndarray
    edges: np.ndarray


class SnapPlan(NamedTuple):
    """What :meth:`SplineSet.snap` needs: each T-junction end, the slot it snaps to, that
    slot's neighbours and whether they are ends ((T, 1) bool, broadcastable over x, y);
    ``rows``: the neighbours, the slots and the ends one after another (one gather a pass);
    ``flat``: the ends' flat indices (x, y) in a (P, 2) array (one ``put`` a pass)."""

    ends: np.ndarray
    through: np.ndarray
    before: np.ndarray
    after: np.ndarray
    before_is_end: np.ndarray
    after_is_end: np.ndarray
    rows: np.ndarray
    flat: np.ndarray

    @classmethod
    def of(cls, ends: np.ndarray, through: np.ndarray, before: np.ndarray, after: np.ndarray,
           before_is_end: np.ndarray, after_is_end: np.ndarray) -> SnapPlan:
        return cls(ends, through, before, after, before_is_end, after_is_end,
                   np.concatenate([before, through, after, ends]), flat_rows(ends, 2))

    def move(self, ctrl: np.ndarray, check: bool = True) -> bool:
        """One snapping pass over these ends, in place; whether any of them moved (False
        without ``check``)."""
        t = self.ends.size
        rows = ctrl.take(self.rows, axis=0)
        before, through, after = rows[:t], rows[t:2 * t], rows[2 * t:3 * t]
        start, stop = joint(before, through), joint(through, after)  # the span of span(), its ends by copyto
        np.copyto(start, before, where=self.before_is_end)
        np.copyto(stop, after, where=self.after_is_end)
        snapped = midpoint(start, through, stop)
        moved = check and not np.logical_and.reduce(snapped == rows[3 * t:], axis=None)
        if ctrl.shape[1] == 2:
            ctrl.put(self.flat, snapped)
        else:  # several position sets side by side (SplineSet.drawings)
            ctrl[self.ends] = snapped
        return moved

    def chained(self, n_slots: int) -> SnapPlan:
        """The ends whose snap point depends on another snapped end (a neighbour of their
        slot is one): after the first pass only they can still move."""
        snapped = np.zeros(n_slots, bool)
        snapped[self.ends] = True
        rows = (snapped[self.before] | snapped[self.after]).nonzero()[0]
        return SnapPlan.of(*(field[rows] for field in self[:6]))
