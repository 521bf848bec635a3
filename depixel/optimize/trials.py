"""Stage 5b — paper §3.4 — where a control point tries to go in one round of the relaxation.

The paper tries "several random new offset positions within a small radius"; here every slot
tries the same kinds of places, built from the geometry alone (no draws, no slot numbers, no
order of curves), so that the result does not depend on how the curves were numbered, which
way they run, or how the image is turned or mirrored:

* **staying** (trial 0: staying is always allowed and wins every tie);
* **the pattern**: the four offsets of :data:`PATTERN` (the axis directions) at the slot's
  radius: the pattern is its own image under the eight symmetries of the square, exactly, so
  a mirrored or turned slot tries the mirrored or turned offsets;
* **the candidate** of :func:`candidates`: the slot's home p̂ projected onto the chord of its
  neighbours (where a step of a staircase is straightened: E_s is least there), and the point
  half-way to it from where the slot is (a half step leaves room for a neighbour moving at
  the same time).

Seven trials a slot (issue 31, for speed: each trial costs every slot every round). Tried on
the paper corpus (the output's mean energy, against 150.42 for the random relaxation, and
the sprites no higher than it): the four diagonals as well and the slot itself projected onto
the chord and half-way there as well (13 trials): 140.32, 49 of 54; these seven: 140.41, 50
of 54; the diagonals instead of the axis directions: 141.47, 44; the slot's own projection
instead of home's: 140.81, 50; without the half-way point: 140.87, 49; the pattern alone:
143.12, 48. Home itself, and home projected onto the lines that continue the legs before and
after, were tried earlier and left out too.

Every construction is symmetric in x and y and in the two directions of a curve.
"""
from __future__ import annotations

import numpy as np

from .energy import A_ROW, B_ROW, MEMBER_ROW

#: (2, 4) the unit offsets of the pattern: +x, −x, +y, −y
PATTERN = np.array([[1.0, -1.0, 0.0, 0.0],
                    [0.0, 0.0, 1.0, -1.0]])
PATTERN.flags.writeable = False
#: geometric candidates a member tries (:func:`candidates`), and as many points half-way to them
CANDIDATES = 1
#: trials a member tries in one round: staying, the pattern, the candidates and their halves
TRIALS = 1 + PATTERN.shape[1] + 2 * CANDIDATES


def trials(around: np.ndarray, home: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(2, M, :data:`TRIALS`) the places the members try: staying, the :data:`PATTERN` scaled
    by each member's ``radius`` (M,), the :func:`candidates` and the points half-way to them;
    ``around`` (7, 2, M, 1) the rows of :attr:`depixel.optimize.energy.Group.around`, ``home``
    (2, M, 1) the members' places before relaxing."""
    here = around[MEMBER_ROW]
    members = here.shape[1]
    out = np.empty((2, members, TRIALS))
    out[:, :, :1] = here
    pattern = out[:, :, 1:1 + PATTERN.shape[1]]
    np.multiply(PATTERN[:, None, :], radius[:, None], out=pattern)
    pattern += here
    far = out[:, :, TRIALS - 2 * CANDIDATES:TRIALS - CANDIDATES]
    candidates(around, home, far)
    half = np.add(far, here, out=out[:, :, TRIALS - CANDIDATES:])
    half /= 2.0
    return out


def candidates(around: np.ndarray, home: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The :data:`CANDIDATES` geometric trial of each member into ``out`` (2, M, 1): its home
    projected onto the chord from the slot before (a) to the slot after (b), within the chord."""
    return _project(home, around[A_ROW], around[B_ROW], out)


def _project(point: np.ndarray, a: np.ndarray, b: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The nearest point to ``point`` on the segment from ``a`` to ``b`` (each (2, M, 1)), into
    ``out``; the midpoint where they coincide. Written from the midpoint m = (a + b) / 2 along
    d = b − a, so that swapping a and b gives the same numbers (−d, −along: exact), and dot
    products add x's term to y's (a turned or mirrored input gives the turned or mirrored
    point)."""
    middle = a + b
    middle /= 2.0
    d = b - a
    rel = point - middle
    length2 = d[0] * d[0] + d[1] * d[1]
    along = (rel[0] * d[0] + rel[1] * d[1]) / np.where(length2 > 0.0, length2, 1.0)
    np.clip(along, -0.5, 0.5, out=along)
    np.multiply(d, along, out=out)
    out += middle
    return out
