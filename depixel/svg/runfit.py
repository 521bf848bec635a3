"""Pulled-back runs drawn with fewer segments (part of :mod:`depixel.svg.insets`).

A run of a stacked outline pulled back into an upper face Q (:mod:`depixel.svg.insets`) is
hidden under Q: its only job is to stay a margin inside Q's visible edge, and to leave and
reach the nodes at its ends along the bisectors of Q's corners there. Its exact shape does
not show, so it need not follow every segment of the boundary it is pulled back from, nor
take a line of its own to each node. Each run, with the lines that lead into and out of it,
is replaced by one curve where one fits (two where the lines are kept): the quadratic
through the meeting point of its end tangents, else the least-squares cubic with those
tangents (Schneider's fit, chord-length parameters), kept only where it lies within
:data:`FIT` of the margin of the path it replaces, both ways (every sample of each within
that distance of the other's). So the curve keeps its start and end, its directions there
(the bisector at a node), and stays between 0.6 and 1.4 margins from Q's visible edge.
"""
from __future__ import annotations

import numpy as np

from ..arrays import ranges, set_rows
from ..curves.bspline import cubic_weights
from .boundaries import CUBIC, LINE, QUAD
from .insets import Segments, on_grid, unit

#: how far the curve of a run may depart from the path it replaces, as a fraction of the
#: run's margin (the margin is more than a render pixel's diagonal at 8x, so the curve stays
#: farther from the visible edge than that pixel's size at 0.6 margins of 0.25 px)
FIT = 0.5
#: samples along each segment of a run, and along its new curve
SAMPLES, CURVE_SAMPLES = 9, 33
#: the cubic weights of the samples along a new curve (4, CURVE_SAMPLES)
_CURVE_WEIGHTS = np.stack(cubic_weights(np.linspace(0.0, 1.0, CURVE_SAMPLES)))


def fit_runs(segments: Segments, run: np.ndarray, margin: np.ndarray, grid: float | None) -> Segments:
    """The loops with each run of two or more segments (``run``: per segment, the run it
    belongs to, in loop order and not across a loop's start, or -1; ``margin``: per run)
    replaced by one curve where one fits, else each half of it, and so on down to
    :data:`DEPTH` halvings (see the module docstring)."""
    kind, ctrl, ctrl2, end, loop_ptr = segments
    n = kind.size
    ids, lo, count = np.unique(run, return_index=True, return_counts=True)
    wanted = (ids >= 0) & (count >= 2)
    if n == 0 or not np.logical_or.reduce(wanted):
        return segments
    ids, lo, count = ids.compress(wanted), lo.compress(wanted), count.compress(wanted)
    loop_of = np.arange(loop_ptr.size - 1).repeat(loop_ptr[1:] - loop_ptr[:-1])
    k = np.arange(n)
    first, last = loop_ptr.take(loop_of), loop_ptr.take(loop_of + 1) - 1
    cubics = _as_cubic(end.take(np.where(k == first, last, k - 1), axis=0), kind, ctrl, ctrl2, end)
    tol = FIT * margin.take(ids)
    done_lo, done_count, done = [], [], []
    for _ in range(DEPTH + 1):
        fitted, curve, quad = _fit(cubics, lo, count, tol, grid)
        done_lo.append(lo.compress(fitted))
        done_count.append(count.compress(fitted))
        done.append((curve.compress(fitted, axis=0), quad.compress(fitted)))
        split = ~fitted & (count >= 4)  # (halves of two segments or more)
        half = count.compress(split) // 2
        lo = np.concatenate((lo.compress(split), lo.compress(split) + half))
        count = np.concatenate((half, count.compress(split) - half))
        tol = np.concatenate((tol.compress(split), tol.compress(split)))
        if lo.size == 0:
            break
    lo, count = np.concatenate(done_lo), np.concatenate(done_count)
    curve = np.concatenate([c for c, _ in done], axis=0)
    quad = np.concatenate([q for _, q in done])
    if lo.size == 0:
        return segments
    # each fitted range's last segment becomes its curve, the others go
    kind, ctrl, ctrl2 = kind.copy(), ctrl.copy(), ctrl2.copy()
    at = lo + count - 1
    kind[at] = np.where(quad, QUAD, CUBIC)
    # (a quadratic's control: where the elevated legs point, 3/2 of the first leg)
    set_rows(ctrl, at, np.where(quad[:, None], curve[:, 0] + 1.5 * (curve[:, 1] - curve[:, 0]), curve[:, 1]))
    set_rows(ctrl, at, on_grid(ctrl.take(at, axis=0), grid))
    set_rows(ctrl2, at, np.where(quad[:, None], np.nan, curve[:, 2]))
    keep = np.ones(n, bool)
    keep[ranges(lo, count - 1)] = False
    kept = np.bincount(loop_of.compress(keep), minlength=loop_ptr.size - 1)
    loop_ptr = np.concatenate(([0], kept.cumsum())).astype(np.int64)
    return Segments(kind.compress(keep), ctrl.compress(keep, axis=0), ctrl2.compress(keep, axis=0),
                    end.compress(keep, axis=0), loop_ptr)


#: a run whose curve does not fit is halved and each half tried, at most this many times
DEPTH = 2


def _fit(cubics: np.ndarray, lo: np.ndarray, count: np.ndarray, tol: np.ndarray,
         grid: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each range [lo, lo + count) of the segments (``cubics``: each as a cubic's
    points): whether one curve with its start, end and end tangents lies within ``tol`` of
    it, that curve as a cubic's points (its controls on the grid) and whether it is a
    quadratic."""
    seg = ranges(lo, count)
    owner = np.arange(lo.size).repeat(count)
    parts = cubics.take(seg, axis=0)
    w = np.stack(cubic_weights(np.linspace(0.0, 1.0, SAMPLES)))  # (4, SAMPLES)
    path = np.einsum("kt,nkd->ntd", w, parts).reshape(-1, 2)
    path_owner = owner.repeat(SAMPLES)
    firsts, lasts = cubics.take(lo, axis=0), cubics.take(lo + count - 1, axis=0)
    p0, p3 = firsts[:, 0], lasts[:, 3]
    t0 = unit(firsts[:, 1] - p0, unit(firsts[:, 2] - p0, p3 - p0))
    t3 = unit(p3 - lasts[:, 2], unit(p3 - lasts[:, 1], p3 - p0))
    u = _chord_parameters(path, path_owner, lo.size)
    # the quadratic through the meeting point of the end tangents, where they meet ahead
    cross = t0[:, 0] * t3[:, 1] - t0[:, 1] * t3[:, 0]
    d = p3 - p0
    meets = np.abs(cross) > 1e-9
    safe = np.where(meets, cross, 1.0)
    a = np.where(meets, (d[:, 0] * t3[:, 1] - d[:, 1] * t3[:, 0]) / safe, -1.0)  # along t0 from p0
    b = np.where(meets, (d[:, 1] * t0[:, 0] - d[:, 0] * t0[:, 1]) / safe, -1.0)  # back along t3 from p3
    q = on_grid(p0 + a[:, None] * t0, grid)
    quad = np.stack((p0, p0 + 2.0 / 3.0 * (q - p0), p3 + 2.0 / 3.0 * (q - p3), p3), axis=1)
    # else the least-squares cubic with those end tangents, or that cubic with shorter legs
    # (least squares is not the least largest distance: a run's straight middle between two
    # leads draws its legs out too far); every candidate measured in one pass (each range's
    # answer is its own), the first that fits taken
    c1, c2 = _least_squares(p0, p3, t0, t3, path, path_owner, u, lo.size)
    cubic = np.stack((p0, on_grid(c1, grid), on_grid(c2, grid), p3), axis=1)
    shorter = [np.stack((p0, on_grid(p0 + scale * (c1 - p0), grid), on_grid(p3 + scale * (c2 - p3), grid), p3), axis=1)
               for scale in LEGS]
    tries = len(LEGS) + 2
    n = lo.size
    ok = _close(np.concatenate([quad, cubic] + shorter), np.tile(path, (tries, 1)),
                (path_owner + n * np.arange(tries)[:, None]).reshape(-1), np.tile(u, tries),
                np.tile(tol, tries)).reshape(tries, n)
    quad_ok = (a > 0) & (b > 0) & ok[0]
    cubic_ok = ~quad_ok & ok[1]
    for curve, fits in zip(shorter, ok[2:]):
        fits = fits & ~quad_ok & ~cubic_ok
        cubic = np.where(fits[:, None, None], curve, cubic)
        cubic_ok |= fits
    return quad_ok | cubic_ok, np.where(quad_ok[:, None, None], quad, cubic), quad_ok


#: the shorter legs tried where the least-squares cubic does not fit, as fractions of its
LEGS = (0.75, 0.5, 0.35)


def _as_cubic(start: np.ndarray, kind: np.ndarray, ctrl: np.ndarray, ctrl2: np.ndarray,
              end: np.ndarray) -> np.ndarray:
    """(n, 4, 2) each segment as a cubic Bézier's points (degree elevated)."""
    line, quad = (kind == LINE)[:, None], (kind == QUAD)[:, None]
    c1 = np.where(line, start + (end - start) / 3.0, np.where(quad, start + 2.0 / 3.0 * (ctrl - start), ctrl))
    c2 = np.where(line, end + (start - end) / 3.0, np.where(quad, end + 2.0 / 3.0 * (ctrl - end), ctrl2))
    return np.stack((start, c1, c2, end), axis=1)


def _chord_parameters(path: np.ndarray, owner: np.ndarray, n: int) -> np.ndarray:
    """Each sample's chord-length parameter along its run (0 at the first, 1 at the last),
    summed over the run from its own start."""
    step = np.zeros(owner.size)
    same = owner[1:] == owner[:-1]
    step[1:] = np.where(same, np.hypot(*(path[1:] - path[:-1]).T), 0.0)
    total = np.cumsum(step)
    start = np.concatenate(([0], np.flatnonzero(~same) + 1))
    run_start = total.take(start).repeat(np.diff(np.concatenate((start, [owner.size]))))
    along = total - run_start
    length = np.bincount(owner, weights=step, minlength=n)
    return along / np.maximum(length.take(owner), 1e-12)


def _least_squares(p0: np.ndarray, p3: np.ndarray, t0: np.ndarray, t3: np.ndarray, path: np.ndarray,
                   owner: np.ndarray, u: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The controls ``p0 + alpha t0`` and ``p3 - beta t3`` of the cubic nearest the samples
    ``path`` at parameters ``u`` (least squares); a third of the chord where that fails."""
    b0, b1, b2, b3 = cubic_weights(u)
    a1 = t0.take(owner, axis=0) * b1[:, None]
    a2 = -t3.take(owner, axis=0) * b2[:, None]
    r = path - p0.take(owner, axis=0) * (b0 + b1)[:, None] - p3.take(owner, axis=0) * (b2 + b3)[:, None]

    def total(x: np.ndarray) -> np.ndarray:
        return np.bincount(owner, weights=x, minlength=n)

    m11, m12, m22 = total((a1 * a1).sum(1)), total((a1 * a2).sum(1)), total((a2 * a2).sum(1))
    r1, r2 = total((a1 * r).sum(1)), total((a2 * r).sum(1))
    det = m11 * m22 - m12 * m12
    good = np.abs(det) > 1e-12
    alpha = np.where(good, (r1 * m22 - r2 * m12) / np.where(good, det, 1.0), -1.0)
    beta = np.where(good, (m11 * r2 - m12 * r1) / np.where(good, det, 1.0), -1.0)
    third = np.hypot(*(p3 - p0).T) / 3.0
    bad = (alpha <= 1e-6) | (beta <= 1e-6)
    alpha, beta = np.where(bad, third, alpha), np.where(bad, third, beta)
    return p0 + alpha[:, None] * t0, p3 - beta[:, None] * t3


def _close(curve: np.ndarray, path: np.ndarray, owner: np.ndarray, u: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """(n,) whether each cubic ``curve`` (n, 4, 2) and its range's samples ``path`` lie
    within ``tol`` of each other both ways (the curve sampled densely): every sample of each
    has one of the other within ``tol`` (``owner``: each sample's range, ascending, every
    range with samples; ``u``: its chord-length parameter along the range).

    Each path sample is measured first against the :data:`WINDOW` curve samples around its
    parameter, where it almost always has its near one; a path sample with none there is
    measured against all of its curve's, and a curve sample that no path sample found
    against all of its range's path: the answer is that of every pair measured (each pair's
    answer is :func:`_within`'s, whichever step measures it)."""
    n, t = curve.shape[0], CURVE_SAMPLES
    if n == 0:
        return np.zeros(0, bool)
    points = np.einsum("kt,nkd->dnt", _CURVE_WEIGHTS, curve)  # (2, n, CURVE_SAMPLES)
    px, py = points[0].reshape(-1), points[1].reshape(-1)
    x, y, reach = path[:, 0].copy(), path[:, 1].copy(), tol.take(owner)
    first = np.clip(np.rint(u * (t - 1)).astype(np.int64) - WINDOW // 2, 0, t - WINDOW)
    apart = np.zeros(n, bool)  # a path sample with no curve sample within tol
    measured: list[tuple[np.ndarray, np.ndarray]] = []  # the pairs measured and their answers
    # a few samples of every range first (most ranges tried do not fit, and a few samples
    # off the curve show it), then the other samples of the ranges still in
    probe = np.zeros(owner.size, bool)
    probe[::PROBE] = True
    for stage in range(2):
        rows = probe.nonzero()[0] if stage == 0 else (~probe & ~apart.take(owner)).nonzero()[0]
        window = (owner.take(rows) * t + first.take(rows))[:, None] + np.arange(WINDOW)
        near = _within(px, py, x, y, reach, window, rows[:, None])
        measured.append((window, near))
        lost = rows.compress(~np.logical_or.reduce(near, axis=1))
        if lost.size:  # against all of their curve's samples
            pairs = (owner.take(lost) * t)[:, None] + np.arange(t)
            near = _within(px, py, x, y, reach, pairs, lost[:, None])
            measured.append((pairs, near))
            apart[owner.take(lost.compress(~np.logical_or.reduce(near, axis=1)))] = True
    if np.logical_and.reduce(apart):
        return ~apart
    # the curve samples with a path sample within tol, of the ranges still in
    found = np.zeros(n * t, bool)
    for pairs, near in measured:
        keep = ~apart.take(pairs[:, 0] // t)
        found[pairs.compress(keep, axis=0)[near.compress(keep, axis=0)]] = True
    # those not found yet: against all of their range's path
    missing = (~found.reshape(n, t) & ~apart[:, None]).nonzero()
    if missing[0].size:
        starts = owner.searchsorted(np.arange(n + 1))
        counts = (starts[1:] - starts[:-1]).take(missing[0])
        sample = ranges(starts.take(missing[0]), counts)
        near = _within(px, py, x, y, reach, (missing[0] * t + missing[1]).repeat(counts), sample)
        hit = np.logical_or.reduceat(near, np.concatenate(([0], counts.cumsum()[:-1])))
        apart[missing[0].compress(~hit)] = True
    return ~apart


#: the curve samples around a path sample's parameter it is measured against first
WINDOW = 7
#: one path sample in this many is measured first
PROBE = 8


def _within(px: np.ndarray, py: np.ndarray, x: np.ndarray, y: np.ndarray, reach: np.ndarray, points: np.ndarray,
            rows: np.ndarray) -> np.ndarray:
    """Whether the curve samples ``points`` (indices into ``px``, ``py``) lie within ``reach``
    of the path samples ``rows`` (indices into ``x``, ``y``, ``reach``; broadcast against
    ``points``): where the ``hypot`` of their offsets is. The squared distance (twenty times
    cheaper than ``hypot`` a pair) decides every pair more than a billionth of ``reach`` from
    that boundary, ``hypot`` the rest, so the answer is ``hypot``'s (a NaN or infinite
    coordinate leaves its sample no pair within reach: the range does not fit, as where
    ``hypot``'s minimum is NaN)."""
    dx = px.take(points)
    dx -= x.take(rows)
    dy = py.take(points)
    dy -= y.take(rows)
    gap = np.multiply(dx, dx)
    gap += dy * dy
    limit = np.square(reach.take(rows))
    within = gap <= limit * (1.0 - 1e-9)
    unsure = ~(within | (gap > limit * (1.0 + 1e-9)))  # near the boundary, or NaN
    if np.logical_or.reduce(unsure, axis=None):
        at = unsure.nonzero()
        within[at] = np.hypot(dx[at], dy[at]) <= np.broadcast_to(reach.take(rows), unsure.shape)[at]
    return within
