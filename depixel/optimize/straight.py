"""Stage 5a — paper §3.4 — straight runs of the outline stay straight (issue 46).

Two things the smoothness energy E_s = ∫|κ| cannot see, found on the quantized outline like
the corners (:mod:`depixel.optimize.corners`):

* **Constant-slope staircases start on their line** (:func:`place_staircases`). A 45°
  staircase of pixels is already a straight line of cell nodes (paper §3.2), a staircase of
  another constant slope is not: its cells alternate 45° runs and axis-parallel ones (a 2:3
  staircase: 1.5 px at 45°, then a kink). The relaxation cannot straighten it one node at a
  time: a node moved off a 45° run bends it, and where the tangent swings between two
  directions the total turn, so E_s, stays whatever one node does while E_p grows; the stripe
  stays wavy. So, as :meth:`~depixel.optimize.corners.Corners.place` puts a block's corner
  back on its lattice point, the nodes of such a staircase start (and have their home p̂) on
  its line, where E_s is 0 and the relaxation keeps them.
* **A curve that is one straight run keeps it** (:func:`straight_curves`): when every step
  between a curve's inner nodes is the same (a pixel edge, a 45° run), those nodes stay where
  they are. Its ends are off its line only because of what lies beyond them (a corner cut by
  a diagonal link, a T-junction end snapped onto a rounded curve), and straightening the
  curve between them tilts it: a one-pixel line beside it tapers (win31_setup's grey stripe).
  A curve that bends is relaxed as before, its straight parts too, so round shapes stay round.
* **A T-junction on a straight side stays on it** (:func:`straight_runs` too): where a curve
  ends on another, leaving along the straight run by which the other arrives (or leaves),
  that run going on for ``run_reach`` or to its curve's end, the junction is a point of one
  straight boundary even though the other curve bends off it there; relaxing the bend pulled
  the node off the side and a one-pixel line along it widened by a quarter pixel before the
  junction (win31_setup's light-grey box line, 1.0 to 1.27 px).

A node lies on a **constant-slope staircase** when the quarter-pixel steps of its curve
(cell node to cell node, exact integers) repeat with some period m ≥ 2 over the m steps
before it and the m after it (period 1 is a straight run already), the period's vector V is
at most ``run_reach`` long (so the node's place depends on the curve within that reach),
every step goes V's way in x and in y (a staircase, not a wave), and every node of those two
periods lies within ``run_tolerance`` of the line below. **The line** runs along V through
the mean of one period's nodes: any m consecutive nodes of a periodic run have their mean on
the same line (moving the window by a node swaps a node for its copy V further on), so every
node of the staircase goes onto one line, the middle of its steps. The mean is taken over
the two periods around the node, their two end nodes weighed ½ (the mean of two windows of m
nodes, the same either way along the curve), in exact quarter-pixel integers; a node moves
to its projection on the line. Nodes inside two curves (a crossing of curves) stay.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from ..arrays import batch_slices, in_sorted, set_rows
from ..curves.splines import SplineSet
from ..params import Params

#: the least distance (px) between consecutive cell nodes (a quarter pixel diagonally): a
#: period of ``run_reach`` pixels has at most ``run_reach / MIN_STEP`` steps
MIN_STEP = 0.35
#: window entries (slots × nodes around each) handled at a time: bounds the memory whatever
#: the number of slots and ``run_reach``
WINDOW_BATCH = 1 << 18
#: quarter-pixel coordinates and steps of cell nodes are below these (a node's place is one
#: integer, ``x * _SPAN + y``; a step between consecutive nodes is at most 4 each way)
_SPAN = 1 << 24
_STEP = 8


def place_staircases(splines: SplineSet, start: np.ndarray, params: Params = Params()) -> np.ndarray:
    """(N, 2) ``start`` with every node of a constant-slope staircase moved onto its line
    (module docstring); ``start`` itself is left as it is. Off with ``params.straight_runs``."""
    placed = start.copy()
    if params.straight_runs:
        for window in _windows(splines, params):
            slots, point = _staircase_slots(window, params)
            set_rows(placed, splines.curve_nodes.take(slots), point)
    return placed


def straight_runs(splines: SplineSet, params: Params = Params()) -> np.ndarray:
    """(N,) bool: the nodes inside a straight run of their curve (every step the same, in
    quarter pixels) that goes on for ``run_reach`` or to the curve's end each way (the step
    onto the end may differ), and the T-junctions on such a run where another curve goes on
    along it: they stay where they are (module docstring). None with ``params.straight_runs``
    off."""
    kept = np.zeros(len(splines.positions), bool)
    if params.straight_runs:
        branch = _branches(splines)
        for window in _windows(splines, params):
            kept[splines.curve_nodes.take(_run_slots(window, params))] = True
            kept[splines.curve_nodes.take(_junction_slots(window, branch, params))] = True
    return kept


class _Window(NamedTuple):
    """Slots and the nodes around each along its curve: rows -R..R (R = ``reach``), the slot
    at row R; quarter-pixel coordinates (2R+1, S) and steps (2R, S), step k from node k to
    node k + 1; ``valid`` (2R+1, S): the node exists (not past an open end)."""

    slots: np.ndarray
    reach: int
    valid: np.ndarray
    x: np.ndarray
    y: np.ndarray
    sx: np.ndarray
    sy: np.ndarray


def _windows(splines: SplineSet, params: Params) -> Iterator[_Window]:
    """The :class:`_Window` of every inner slot of a node inside one curve only (a node inside
    two curves, where curves cross, is left as it is), :data:`WINDOW_BATCH` entries at a
    time; ``R`` the most steps ``run_reach`` can hold."""
    prev, nxt = splines.neighbours()
    node = splines.curve_nodes
    inner = ((prev >= 0) & (nxt >= 0)).nonzero()[0]
    once = np.bincount(node.take(inner), minlength=len(splines.positions)) == 1
    inner = inner.compress(once.take(node.take(inner)))
    reach = max(int(np.ceil(params.run_reach / MIN_STEP)), 2)
    quarter = splines.cells.nodes.astype(np.int64)
    prev_, nxt_ = np.append(prev, -1), np.append(nxt, -1)  # index -1 (past an end) stays -1
    for part in batch_slices(inner.size, max(WINDOW_BATCH // (2 * reach + 1), 1)):
        slots = inner[part]
        window = np.full((2 * reach + 1, slots.size), -1, np.int64)
        window[reach] = slots
        for k in range(1, reach + 1):
            window[reach + k] = nxt_.take(window[reach + k - 1])
            window[reach - k] = prev_.take(window[reach - k + 1])
        q = quarter.take(node.take(np.maximum(window, 0)), axis=0)
        x, y = q[..., 0], q[..., 1]
        yield _Window(slots, reach, window >= 0, x, y, np.diff(x, axis=0), np.diff(y, axis=0))


def _run_slots(w: _Window, params: Params) -> np.ndarray:
    """The slots of ``w`` inside a straight run that goes on for ``run_reach`` or to the
    curve's end each way (:func:`straight_runs`)."""
    r = w.reach
    # the run's step: the one ahead, or behind where the node ahead ends the curve (the step
    # onto an end may differ); a slot between two ends has no run
    end_ahead, end_behind = ~w.valid[r + 2], ~w.valid[r - 2]
    run_x = np.where(end_ahead, w.sx[r - 1], w.sx[r])
    run_y = np.where(end_ahead, w.sy[r - 1], w.sy[r])
    kept = ~(end_ahead & end_behind) & _goes_on(w, 1, run_x, run_y, params) & _goes_on(w, -1, run_x, run_y, params)
    return w.slots.compress(kept)


def _junction_slots(w: _Window, branch: np.ndarray, params: Params) -> np.ndarray:
    """The slots of ``w`` where another curve ends (a T-junction) and leaves along the
    straight run by which this curve arrives there (or, backwards, leaves), that run going
    on for ``run_reach`` or to the curve's end: the junction is a point of one straight
    boundary, however this curve bends off it. ``branch``: sorted :func:`_step_keys` of the
    other curves' first steps from their ends."""
    r = w.reach
    node = w.x[r] * _SPAN + w.y[r]  # (a node's quarter-pixel place identifies it)
    behind = in_sorted(branch, _step_keys(node, w.sx[r - 1], w.sy[r - 1]))
    behind &= _goes_on(w, -1, w.sx[r - 1], w.sy[r - 1], params)
    ahead = in_sorted(branch, _step_keys(node, -w.sx[r], -w.sy[r])) & _goes_on(w, 1, w.sx[r], w.sy[r], params)
    return w.slots.compress(behind | ahead)


def _goes_on(w: _Window, way: int, run_x: np.ndarray, run_y: np.ndarray, params: Params) -> np.ndarray:
    """(S,) bool: from each slot of ``w`` its curve goes on ``way`` (1: ahead, -1: behind) by
    steps (``run_x``, ``run_y``) for ``run_reach`` or to the curve's end (the step onto the
    end may differ)."""
    r = w.reach
    length = np.sqrt(w.sx * w.sx + w.sy * w.sy) / 4.0
    going, done = np.ones(w.slots.size, bool), np.zeros(w.slots.size, bool)
    walked = np.zeros(w.slots.size)
    for k in range(r):  # ahead: steps r, r + 1, …; behind: r - 1, r - 2, …
        step = r + k if way > 0 else r - 1 - k
        far = step + 1 if way > 0 else step  # the node the step reaches
        beyond = far + way  # and the one after it (none: the curve ends at the far node)
        ends = w.valid[far] & ~(w.valid[beyond] if 0 <= beyond <= 2 * r else np.zeros_like(going))
        same = (w.sx[step] == run_x) & (w.sy[step] == run_y)
        walked += length[step]
        done |= going & (ends | (same & (walked >= params.run_reach - 1e-9)))
        going &= ~done & same & w.valid[far]
    return done


def _branches(splines: SplineSet) -> np.ndarray:
    """Sorted :func:`_step_keys` of every open curve's first step from each of its ends."""
    prev, nxt = splines.neighbours()
    ends = ((prev < 0) ^ (nxt < 0)).nonzero()[0]  # (a curve of one slot has no step)
    into = np.where(prev.take(ends) < 0, nxt.take(ends), prev.take(ends))
    quarter = splines.cells.nodes.astype(np.int64)
    at, to = quarter.take(splines.curve_nodes.take(ends), axis=0), quarter.take(splines.curve_nodes.take(into), axis=0)
    return np.sort(_step_keys(at[:, 0] * _SPAN + at[:, 1], to[:, 0] - at[:, 0], to[:, 1] - at[:, 1]))


def _step_keys(node: np.ndarray, sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
    """One integer per (node place, quarter-pixel step) (steps are within ±``_STEP``)."""
    return (node * (2 * _STEP + 1) + sx + _STEP) * (2 * _STEP + 1) + sy + _STEP


def _staircase_slots(w: _Window, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """The slots of ``w`` on a constant-slope staircase and their places on its line (K, 2), pixels."""
    reach, valid, x, y, sx, sy = w.reach, w.valid, w.x, w.y, w.sx, w.sy
    # the least period m: steps -m..-1 repeat as 0..m-1, all nodes -m..m on the curve
    period = np.zeros(w.slots.size, np.int64)
    for m in range(1, reach + 1):
        ok = valid[reach - m] & valid[reach + m] & (period == 0)
        ok &= (sx[reach - m:reach] == sx[reach:reach + m]).all(axis=0)
        ok &= (sy[reach - m:reach] == sy[reach:reach + m]).all(axis=0)
        period[ok] = m
    keep = (period >= 2).nonzero()[0]  # (period 1: a straight run already)
    kept_period = period.take(keep)
    x, y, sx, sy = x[:, keep], y[:, keep], sx[:, keep], sy[:, keep]
    cols = np.arange(keep.size)
    vx = x[reach + kept_period, cols] - x[reach, cols]  # the period's vector, quarter pixels
    vy = y[reach + kept_period, cols] - y[reach, cols]
    offset = np.abs(np.arange(-reach, reach + 1))[:, None]
    inside = offset <= kept_period  # the window's nodes
    weight = np.where(offset < kept_period, 2, np.where(offset == kept_period, 1, 0))  # twice the trapezoid weights
    # the line's point: the mean of the window's nodes, 4m weights × 4 quarter pixels a pixel
    cx = (weight * x).sum(axis=0) / (16.0 * kept_period)
    cy = (weight * y).sum(axis=0) / (16.0 * kept_period)
    length2 = (vx * vx + vy * vy).astype(float)
    # every node within the tolerance of the line (its cross product with V over |V|), every
    # step of the two periods going V's way in x and in y, the period within reach
    across = np.abs((x / 4.0 - cx) * vy - (y / 4.0 - cy) * vx)
    near = np.where(inside, across <= params.run_tolerance * np.sqrt(length2), True).all(axis=0)
    inside_steps = np.arange(-reach, reach)[:, None]
    steps = (inside_steps >= -kept_period) & (inside_steps < kept_period)
    forward = np.where(steps, _along(sx, vx) & _along(sy, vy), True).all(axis=0)
    good = near & forward & (length2 <= (4.0 * params.run_reach) ** 2)
    keep, cx, cy, vx, vy, length2 = (a.compress(good) for a in (keep, cx, cy, vx, vy, length2))
    px, py = x[reach].compress(good) / 4.0, y[reach].compress(good) / 4.0
    along = ((px - cx) * vx + (py - cy) * vy) / length2
    return w.slots.take(keep), np.stack([cx + along * vx, cy + along * vy], axis=1)


def _along(step: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Steps (one coordinate) that go the period's way or not at all: a staircase never
    goes back in x or in y (a wavy line, a zigzag does)."""
    return (np.sign(step) * np.sign(period) >= 0) & ((step == 0) | (period != 0))
