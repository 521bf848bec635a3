"""The curve maths, in one place: uniform quadratic B-splines as quadratic Béziers.

A uniform quadratic B-spline with control points C_0 … C_{n-1} is, exactly, a chain of
quadratic Béziers (TrueType's ``qCurveTo`` with implied on-curve points): the **span** of an
interior control point C_j is the Bézier

    (start, C_j, stop),  start = mid(C_{j-1}, C_j),  stop = mid(C_j, C_{j+1}),

where a neighbour that is an open curve's end point (clamped, interpolated) is used itself
instead of the midpoint. S_j, the span's point at t = ½, is the *curve point* of C_j.
Everything is vectorized over leading axes: points are ``(..., 2)`` float64 arrays (x, y).

The formulas below are written once and used by the spline stage, the optimizer, the smooth
renderer, the stage figure and the SVG writer (its boundary pieces, and the cubic Béziers of
``--simplify`` at the end of this module); their floating-point evaluation order is part of the output
(SVG bytes are compared in ``benchmarks/check_output_stable.py``), so keep it as it is.
"""
from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np


class Bezier(NamedTuple):
    """Quadratic Béziers ``(p0, p1, p2)``: on-curve start, off-curve control, on-curve end,
    each ``(..., 2)``."""

    p0: np.ndarray
    p1: np.ndarray
    p2: np.ndarray


def span(before: np.ndarray, control: np.ndarray, after: np.ndarray,
         before_is_end: np.ndarray | bool = False, after_is_end: np.ndarray | bool = False) -> Bezier:
    """The span of control point ``control`` between its neighbours ``before`` and ``after``.

    ``before_is_end`` / ``after_is_end`` (broadcastable to the points, e.g. ``(..., 1)``) mark
    neighbours that are open-curve end points: the span then starts (ends) at them instead of
    at the midpoint of the control leg.
    """
    start = joint(before, control)
    stop = joint(control, after)
    if before_is_end is not False:
        start = np.where(before_is_end, before, start)
    if after_is_end is not False:
        stop = np.where(after_is_end, after, stop)
    return Bezier(start, control, stop)


def joint(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where the spans of consecutive interior control points ``a``, ``b`` meet: the
    midpoint of their control leg (the implied on-curve point)."""
    return (a + b) / 2.0


def slot_spans(ctrl: np.ndarray, prev: np.ndarray, nxt: np.ndarray, end: np.ndarray,
               part: slice = slice(None)) -> Bezier:
    """The span of every slot of flat curve arrays (the layout of
    :class:`depixel.curves.splines.SplineSet`): ``ctrl`` (P, 2) control points, ``prev``/``nxt``
    (P,) neighbouring slots (-1 past an open end), ``end`` (P,) open-curve end points;
    or of the slots ``part`` alone.

    Rows of end slots are meaningless (an end point has no span of its own; the curve's
    first and last spans start and stop on it)."""
    p_prev, p_next = np.maximum(prev[part], 0), np.maximum(nxt[part], 0)
    return span(ctrl.take(p_prev, axis=0), ctrl[part], ctrl.take(p_next, axis=0), end[p_prev][:, None],
                end[p_next][:, None])


def midpoint(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """The point at t = ½ of quadratic Béziers (of a span: its curve point S)."""
    return (p0 + 2.0 * p1 + p2) / 4.0


def split_half(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[Bezier, Bezier]:
    """de Casteljau at t = ½: the two halves of quadratic Béziers, exactly."""
    middle = midpoint(p0, p1, p2)
    return Bezier(p0, (p0 + p1) / 2.0, middle), Bezier(middle, (p1 + p2) / 2.0, p2)


def evaluate(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points of quadratic Béziers at parameters ``t`` (all four broadcast together; give
    ``t`` a trailing axis of 1 for the coordinates)."""
    return (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t**2 * p2


def bezier_polylines(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, pieces: int) -> np.ndarray:
    """``(..., pieces + 1, 2)`` polylines of quadratic Béziers ``(..., 2)``, at equal steps
    of t (both end points included)."""
    t = (np.arange(pieces + 1) / pieces)[:, None]
    return evaluate(p0[..., None, :], p1[..., None, :], p2[..., None, :], t)


def bend(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """``|p0 − 2 p1 + p2|`` of quadratic Béziers: the flattening error of ``n`` equal pieces
    is at most bend / 4n² (the second derivative is 2 (p0 − 2 p1 + p2))."""
    return np.linalg.norm(p0 - 2 * p1 + p2, axis=-1)


def pieces_for(bend_max: float, tolerance: float, most: int = 64) -> int:
    """The fewest equal pieces (1 … ``most``) keeping a Bézier of this bend within
    ``tolerance`` of its polyline."""
    return int(np.clip(np.ceil(np.sqrt(bend_max / (4 * tolerance))), 1, most))


def half_turns(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """∫|κ| ds over the first and over the second half of quadratic Béziers.

    The tangent of a quadratic Bézier turns monotonically (by less than π), so the angle
    between its directions at t = 0 and ½ (and ½ and 1) is exactly the integral over that
    half — no sampling error."""
    d0, d1 = p1 - p0, p2 - p1
    dm = d0 + d1  # the tangent at t = ½ (up to a factor that does not change its direction)
    return _angle(d0, dm), _angle(dm, d1)


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unsigned angle between directions u and v (..., 2)."""
    cross = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    dot = (u * v).sum(axis=-1)
    return np.abs(np.arctan2(cross, dot))


def between_curve_points(mid: np.ndarray, near_a: np.ndarray, near_b: np.ndarray, start: np.ndarray,
                         stop: np.ndarray, split: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``(E, 3, 2)`` controls (c0, c1, c2) of the curve between consecutive control points
    C_a → C_b, from the curve point S_a to S_b, as two Béziers ``S_a Q c0 c1 Q c2 S_b``.

    Both interior: the second half of C_a's span and the first half of C_b's, which meet
    at ``mid`` = :func:`joint` (C_a, C_b): c0 = (C_a + m) / 2, c1 = m, c2 = (m + C_b) / 2. With an
    end point (``split``, (E, 1) bool; the curve starts or stops there instead of at S): the
    one Bézier (``start``, m, ``stop``) — C_a or S_a, C_b or S_b — split at t = ½ (:func:`split_half`):
    c0 = (start + m) / 2, c1 its :func:`midpoint`, c2 = (m + stop) / 2. Either way the result is
    exactly the B-spline; at most one of the two may be an end (an open curve of one edge is
    a straight segment). So c0 = (``near_a`` + m) / 2 with ``near_a`` = C_a, or S_a where C_b is
    the end, and c2 = (m + ``near_b``) / 2 likewise: the caller gathers those rows. Swapping
    ``near_a`` and ``near_b`` gives the controls from S_b to S_a (c2, c1, c0) to the bit (a sum
    does not depend on the order of its terms). Written into ``out`` when given."""
    out = np.empty((mid.shape[0], 3, 2)) if out is None else out
    out[:, 0] = (near_a + mid) / 2.0
    out[:, 2] = (mid + near_b) / 2.0
    out[:, 1] = mid
    np.copyto(out[:, 1], midpoint(start, mid, stop), where=split)
    return out


def edge_halves(start: np.ndarray, controls: np.ndarray, stop: np.ndarray) -> tuple[Bezier, Bezier]:
    """The two Béziers of curved cell edges as :class:`depixel.vector.VectorImage` stores
    them: ``start`` Q c0 c1 Q c2 ``stop`` with ``controls`` (E, 3, 2) = (c0, c1, c2)."""
    c0, c1, c2 = controls[:, 0], controls[:, 1], controls[:, 2]
    return Bezier(start, c0, c1), Bezier(c1, c2, stop)


def flatten_edges(start: np.ndarray, controls: np.ndarray, stop: np.ndarray, pieces: int) -> np.ndarray:
    """``(E, 2 * pieces + 1, 2)`` polylines of curved cell edges, ``pieces`` per Bézier."""
    first, second = edge_halves(start, controls, stop)
    return np.concatenate([bezier_polylines(*first, pieces), bezier_polylines(*second, pieces)[:, 1:]], axis=1)



def flatten_edges_planes(start: np.ndarray, controls: np.ndarray, stop: np.ndarray,
                         pieces: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`flatten_edges` as x and y planes ``(2 * pieces + 1, E)`` (point j of edge e at
    ``[j, e]``), the same numbers: every operation runs along the E edges instead of over
    rows of two coordinates."""
    weights = _piece_weights(pieces)
    planes = []
    for axis in range(2):
        c0, c1, c2 = controls[:, 0, axis], controls[:, 1, axis], controls[:, 2, axis]
        first = weights[0] * start[:, axis] + weights[1] * c0 + weights[2] * c1
        second = weights[0] * c1 + weights[1] * c2 + weights[2] * stop[:, axis]
        planes.append(np.concatenate([first, second[1:]]))
    return planes[0], planes[1]


@lru_cache(maxsize=8)
def _piece_weights(pieces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Bernstein weights ((pieces + 1, 1) each) of :func:`flatten_edges_planes`, computed
    as :func:`evaluate` computes them, once per number of pieces (read-only)."""
    t = np.arange(pieces + 1) / pieces
    weights = ((1 - t) ** 2)[:, None], (2 * t * (1 - t))[:, None], (t**2)[:, None]
    for weight in weights:
        weight.setflags(write=False)
    return weights


# --- cubic Béziers: the SVG writer's simplified curves (depixel/svg/curvefit.py) ---------------------

def elevate(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inner control points ``(c1, c2)`` of the cubic Bézier that draws the quadratic
    Bézier ``(p0, p1, p2)`` exactly (degree elevation)."""
    return p0 + 2.0 / 3.0 * (p1 - p0), p2 + 2.0 / 3.0 * (p1 - p2)


def cubic_weights(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The Bernstein weights ``(B0, B1, B2, B3)`` of cubic Béziers at parameters ``t``."""
    s = 1 - t
    return s**3, 3 * t * s**2, 3 * t**2 * s, t**3


def evaluate_cubic(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points of cubic Béziers at parameters ``t`` (all five broadcast together; give ``t`` a
    trailing axis of 1 for the coordinates)."""
    b0, b1, b2, b3 = cubic_weights(t)
    return b0 * p0 + b1 * p1 + b2 * p2 + b3 * p3


def flatten_cubic(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``(..., T, 2)``: the points of cubic Béziers ``(..., 2)`` at each of the parameters
    ``t`` ``(T,)``."""
    return evaluate_cubic(p0[..., None, :], p1[..., None, :], p2[..., None, :], p3[..., None, :], t[:, None])
