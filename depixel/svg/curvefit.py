"""One Bézier over each run of exact segments, and the checks it must pass — the fitting
half of the SVG writer's optional simplification (:mod:`depixel.svg.simplify` has the method
and drives it: which runs are tried, in which order).

For a batch of runs [lo, hi) of the exact segments of the boundary pieces, :func:`fit`
returns the quadratic through the meeting point of the end tangents where that one fits,
else the least-squares cubic, and whether the curve is kept: within the tolerance of the
exact run (:class:`~depixel.svg.reference.Exact`: the segments as cubics, sampled) and
keeping every protected point on its side (:class:`~depixel.svg.reference.Protected`: pixel
centres and the lattice corners of diagonal links). Its own module because these are the
numerics (samples, Newton steps, ray casting), apart from the bookkeeping of pieces and runs.
Curve formulas come from :mod:`depixel.curves.bspline`.
"""
from __future__ import annotations

import numpy as np

from ..arrays import ranges, set_rows
from ..curves.bspline import cubic_weights, elevate
from .boundaries import CUBIC, QUAD
from .reference import T_ORIG, Exact, Protected, parts, per_sample, planes, segment_distance

_T_FIT = np.linspace(0.0, 1.0, 17)  # samples of a fitted cubic (its polyline)
_W_FIT = cubic_weights(_T_FIT)  # their Bernstein weights, (T,) each
#: up to this many ranges, :func:`fit` tests the quadratic and the cubic of every range in
#: one pass; above it, the cubic only where the quadratic failed (the same results)
FUSED_RANGES = 128


def fit(exact: Exact, prot: Protected, lo: np.ndarray, hi: np.ndarray, tolerance: float | np.ndarray,
        clearance: float,
        grid: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One curve per range [lo, hi) of exact segments: a quadratic through the meeting point
    of the end tangents where that one fits (4 numbers in the file), else the least-squares
    cubic. Returns ``(kind, c1, c2, ok, error)``: QUAD rows hold the quadratic's control in
    ``c1``; ``error`` is the kept curve's largest distance to the run's samples (pixels)."""
    # Each test is per candidate curve. A pass costs a few hundred numpy calls whatever its
    # size, so few ranges test both candidates in one pass (the cubic's verdict is not used
    # where the quadratic fits); many test the cubic only where no quadratic fits. The side
    # test (the costly one) runs only on the candidates within the distance.
    samples = _Samples(exact, lo, hi)
    p0, p3 = samples.p0.T, samples.p3.T
    q, has_q = _quadratic_control(exact, p0, p3, lo, hi, grid)
    q1, q2 = elevate(p0, q, p3)  # the same curve as a cubic
    limit = np.minimum(tolerance, exact.tolerance[lo])  # the run's piece's own limit

    def passes(rows: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ok, worst, curves = samples.within(rows, c1, c2, limit[rows])
        ok[ok] = _keeps_sides(exact, prot, lo[rows[ok]], hi[rows[ok]], curves.compress(ok, axis=1), clearance)
        return ok, worst

    quads = has_q.nonzero()[0]
    quad_ok, quad_err = np.zeros(lo.size, bool), np.full(lo.size, np.inf)
    cubic_ok, cubic_err = np.zeros(lo.size, bool), np.full(lo.size, np.inf)
    if lo.size <= FUSED_RANGES:
        r1, r2 = _cubic_controls(exact, samples, None, lo, hi, grid)
        passed, err = passes(np.concatenate([quads, np.arange(lo.size)]),
                             np.concatenate([q1.take(quads, axis=0), r1]), np.concatenate([q2.take(quads, axis=0), r2]))
        quad_ok[quads], cubic_ok = passed[: quads.size], passed[quads.size :]
        quad_err[quads], cubic_err = err[: quads.size], err[quads.size :]
    else:
        quad_ok[quads], quad_err[quads] = passes(quads, q1.take(quads, axis=0), q2.take(quads, axis=0))
        rest = (~quad_ok).nonzero()[0]
        c1, c2 = _cubic_controls(exact, samples, rest, lo[rest], hi[rest], grid)
        cubic_ok[rest], cubic_err[rest] = passes(rest, c1, c2)
        r1, r2 = np.full_like(q, np.nan), np.full_like(q, np.nan)
        set_rows(r1, rest, c1)
        set_rows(r2, rest, c2)
    kind = np.where(quad_ok, QUAD, CUBIC).astype(np.uint8)
    first = np.where(quad_ok[:, None], q, r1)
    second = np.where(quad_ok[:, None], np.nan, r2)
    return kind, first, second, quad_ok | cubic_ok, np.where(quad_ok, quad_err, cubic_err)


class _Samples:
    """The sample points of the exact runs [lo, hi), with their chord-length parameters.

    Points are ``(2, S)`` x and y planes, the ranges' end points ``(2, R)`` too (:func:`planes`)."""

    def __init__(self, exact: Exact, lo: np.ndarray, hi: np.ndarray) -> None:
        # every sample of a range but its first, the range's start point (parameter 0): a
        # candidate starts there, so that sample's distance to it is 0 (its Newton steps stay
        # at 0) and its least-squares terms are 0, whatever the candidate; without it the
        # verdicts and the cubics are the same, with a sample fewer a range to compute
        self.count = (hi - lo) * T_ORIG.size - 1  # samples of each range, which start at first
        self.first = self.count.cumsum() - self.count
        sample = ranges(lo * T_ORIG.size + 1, self.count)  # flat (segment, sample) of Exact's
        # the arc length before each segment of a range, summed from the range's start, a row
        # of a table per range: a range's parameters are its own numbers, the same bits
        # whatever the other segments of the image (a running sum over all of them, less its
        # value at the range's start, would move their last bits with any edit anywhere)
        n_seg = hi - lo
        width = int(n_seg.max()) if n_seg.size else 0
        lengths = np.zeros((lo.size, width))
        inside = np.arange(width) < n_seg[:, None]
        lengths[inside] = exact.length.take(ranges(lo, n_seg))
        summed = lengths.cumsum(axis=1)  # (row by row, in order)
        self.total = summed[:, -1] if width else np.zeros(0)
        before = (summed - lengths)[inside]  # (each range's segments in turn)
        del lengths, summed, inside
        at = sample // T_ORIG.size - lo.repeat(self.count)  # each sample's segment's place in its range
        at += (n_seg.cumsum() - n_seg).repeat(self.count)
        arc = before.take(at) + exact.arc.ravel().take(sample)
        #: (5, S) every range's samples: x, y, their parameters u, (1 - u)³ and u³ (every
        #: candidate's first Newton step uses the cubes); one table, so one gather picks them
        self.table = np.empty((5, sample.size))
        exact.part_start.reshape(2, -1).take(sample, axis=1, out=self.table[:2])
        u = np.divide(arc, np.maximum(self.total, 1e-300).repeat(self.count), out=self.table[2])
        self.table[3], self.table[4] = _cube(1 - u), _cube(u)
        self.p0, self.p3 = planes(exact.start.take(lo, axis=0)), planes(exact.end.take(hi - 1, axis=0))

    def of(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The samples of the ranges ``rows`` (in turn): their number for each row, where each
        row's begin among them, and the index of each in :attr:`table`."""
        count = self.count.take(rows)
        start = count.cumsum() - count
        return count, start, ranges(self.first.take(rows), count)

    def within(self, rows: np.ndarray, c1: np.ndarray, c2: np.ndarray, tolerance: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For candidate cubics (p0, c1, c2, p3) of the ranges ``rows`` (``c1``, ``c2``: (M, 2)):
        every sample of the range lies within ``tolerance`` of the cubic, and the cubic is not
        more than 10 % longer than the run (no loop or bulge between samples); each
        candidate's largest distance to a sample (inf where the shape test fails); and the
        candidates' polylines (2, M, T) (:func:`_flatten`), which the side test uses too."""
        # the shape test first (one polyline per candidate), then the samples of the
        # candidates that pass it: the costly part, each sample on its own
        k = np.empty((4, 2, rows.size))  # the control points p0, c1, c2, p3 of every candidate
        self.p0.take(rows, axis=1, out=k[0])
        k[1], k[2] = c1.T, c2.T
        self.p3.take(rows, axis=1, out=k[3])
        curve = _flatten(*k)  # (2, M, T)
        step = curve[:, :, 1:] - curve[:, :, :-1]
        length = np.sqrt(step[0] ** 2 + step[1] ** 2).sum(axis=1)
        chord = np.sqrt((k[3, 0] - k[0, 0]) ** 2 + (k[3, 1] - k[0, 1]) ** 2)
        ok = (length <= 1.1 * self.total[rows] + 1e-9) & (chord > 0)
        cand = ok.nonzero()[0]
        count, start, at = self.of(rows.take(cand))  # the samples of each candidate tested (consecutive)
        sample = self.table.take(at, axis=1)
        points, u, cubes = sample[:2], sample[2], sample[3:]
        # the control points and their differences of each candidate, then per sample (the
        # point and its first and second derivatives below: the Bernstein forms of the cubic),
        # all nine (2, S) planes from one repeat
        k = k.take(cand, axis=2)
        forms = np.concatenate([k, k[1:] - k[:-1], k[2:] - 2 * k[1:3] + k[:2]])  # k, k1 - k0…, k2 - 2 k1 + k0…
        q0, q1, q2, q3, d10, d21, d32, e1, e2 = per_sample(forms, count, axis=2)
        # from its chord-length parameter, two Newton steps towards the nearest point: an
        # upper bound of the distance, so the test is safe
        for newton in range(2):
            s = 1 - u
            s2, t2 = s**2, u**2
            s3, t3 = cubes if newton == 0 else (s2 * s, t2 * u)
            point = s3 * q0 + 3 * u * s2 * q1 + 3 * t2 * s * q2 + t3 * q3
            d1 = 3 * (s2 * d10 + 2 * u * s * d21 + t2 * d32)
            d2 = 6 * (s * e1 + u * e2)
            off = point - points
            num = off[0] * d1[0] + off[1] * d1[1]
            den = (d1[0] * d1[0] + d1[1] * d1[1]) + (off[0] * d2[0] + off[1] * d2[1])
            u = np.minimum(np.maximum(u - num / np.where(np.abs(den) > 1e-12, den, 1e-12), 0.0), 1.0)
        s = 1 - u
        off = _cube(s) * q0 + 3 * u * s**2 * q1 + 3 * u**2 * s * q2 + _cube(u) * q3 - points  # evaluate_cubic
        d = np.sqrt(off[0] ** 2 + off[1] ** 2)
        worst = np.full(rows.size, np.inf)
        if cand.size:  # at least 7 samples a candidate (2 segments and more, less the first)
            worst[cand] = np.maximum.reduceat(d, start)
        return ok & (worst <= tolerance), worst, curve


def _quadratic_control(exact: Exact, p0: np.ndarray, p3: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                       grid: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The control point of the quadratic with the run's end points ``p0``, ``p3`` (R, 2) and
    end tangents (where the tangent lines meet, in front of both ends), and whether there is one."""
    t0, t1 = exact.tan_start.take(lo, axis=0), exact.tan_end.take(hi - 1, axis=0)
    chord = p3 - p0
    det = _cross(t0, t1)
    safe = np.where(np.abs(det) > 1e-9, det, 1.0)
    s, r = _cross(chord, t1) / safe, _cross(t0, chord) / safe
    length = np.sqrt((chord**2).sum(axis=1))
    valid = (np.abs(det) > 1e-9) & (s > 0) & (r > 0) & (s < 2 * length) & (r < 2 * length)
    q = p0 + s[:, None] * t0
    if grid is not None:
        q = (q / grid).round() * grid
    return q, valid


def _cubic_controls(exact: Exact, samples: _Samples, rows: np.ndarray | None, lo: np.ndarray, hi: np.ndarray,
                    grid: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The cubic with the end points and end tangents of the ranges ``rows`` ([lo, hi) of
    exact segments; None: all of them) whose two leg lengths fit the samples best (least
    squares at their chord-length parameters)."""
    if rows is None:  # the samples' own tables, without a gather
        p0, p3, count, sample = samples.p0, samples.p3, samples.count, samples.table
    else:
        p0, p3 = samples.p0.take(rows, axis=1), samples.p3.take(rows, axis=1)
        count, _, at = samples.of(rows)
        sample = samples.table.take(at, axis=1)
    t0, t1 = exact.tan_start.take(lo, axis=0), exact.tan_end.take(hi - 1, axis=0)
    n = count.size
    u = sample[2]
    # P(u) = B0 p0 + B1 (p0 + a t0) + B2 (p3 - b t1) + B3 p3 (cubic_weights, the cubes
    # from the samples: np.power is slow)
    s = 1 - u
    b0, b1, b2, b3 = sample[3], 3 * u * s**2, 3 * u**2 * s, sample[4]
    r = sample[:2] - (b0 + b1) * per_sample(p0, count) - (b2 + b3) * per_sample(p3, count)
    va, vb = b1 * per_sample(planes(t0), count), -b2 * per_sample(planes(t1), count)
    # the five sums of each range by one bincount, each sum in bins of its own (the same
    # additions in the same order as a bincount apiece)
    terms = np.empty((5, u.size))
    for row, (x, y) in enumerate(((va, va), (va, vb), (vb, vb), (va, r), (vb, r))):
        np.add(x[0] * y[0], x[1] * y[1], out=terms[row])
    bins = (np.arange(n).repeat(count) + n * np.arange(5)[:, None]).ravel()
    m11, m12, m22, r1, r2 = np.bincount(bins, terms.ravel(), 5 * n).reshape(5, n)
    det = m11 * m22 - m12 * m12
    safe = np.where(np.abs(det) > 1e-12, det, 1.0)
    a = (r1 * m22 - r2 * m12) / safe
    b = (m11 * r2 - m12 * r1) / safe
    chord = np.sqrt((p3[0] - p0[0]) ** 2 + (p3[1] - p0[1]) ** 2)
    fallback = ~(np.abs(det) > 1e-12) | (a <= 0) | (b <= 0)
    a = np.where(fallback, chord / 3.0, a)
    b = np.where(fallback, chord / 3.0, b)
    c1 = p0.T + a[:, None] * t0
    c2 = p3.T - b[:, None] * t1
    if grid is not None:
        c1, c2 = (c1 / grid).round() * grid, (c2 / grid).round() * grid
    return c1, c2


def _keeps_sides(exact: Exact, prot: Protected, lo, hi, curves: np.ndarray, clearance: float) -> np.ndarray:
    """No protected point nearest to the exact segments lo-1 .. hi changes side or comes
    nearer to the new curve (``curves``: its polyline (2, R, T)) than min(its distance to
    the exact curve, clearance)."""
    first = prot.seg.searchsorted(lo - 1)
    last = prot.seg.searchsorted(hi + 1)
    count = last - first
    ok = np.ones(lo.size, bool)
    if count.sum() == 0:
        return ok
    owner = np.arange(lo.size).repeat(count)
    idx = ranges(first, count)
    xy = prot.xy.take(idx, axis=1)
    # every point against every part of its candidate's polyline: (4, N, parts) starts and
    # ends, which the distance and the side test share (segment_distance leaves its
    # operands as they are)
    ab = per_sample(parts(curves), count)
    q = xy.repeat(ab.shape[2], axis=1).reshape(2, *ab.shape[1:])
    d_new = segment_distance(q, ab[:2], ab[2:]).min(axis=1)
    too_near = d_new < np.minimum(np.abs(prot.dist[idx]), clearance) - 1e-9
    crossed = _between(xy, q[1], owner, ab, lo, hi, exact)
    ok[owner[too_near | crossed]] = False
    return ok


def _between(xy: np.ndarray, heights: np.ndarray, owner: np.ndarray, ab: np.ndarray, lo: np.ndarray,
             hi: np.ndarray, exact: Exact) -> np.ndarray:
    """Whether each point (``xy``: (2, N) planes) lies between its candidate curve and the
    exact run it replaces (inside the closed polygon of the two, which share their end
    points): the curve has passed over the point, which changes side. ``ab``: (4, N, V) the
    starts and the ends (x, y, x, y) of the V parts of each point's candidate's polyline,
    ``heights`` (N, V) each point's y beside them: the same shape, so no broadcast (numpy 2
    runs an operation that broadcasts over a 2-d operand through its buffered iterator, which
    copies the broadcast operand into buffers first: several times the cost on these pairs).
    Even-odd ray casting towards +x."""
    n_points, n_curve = xy.shape[1], ab.shape[2]
    qy = xy[1]
    # pairs (point, edge of its polygon): the parts of its candidate's polyline, then those of
    # the exact run, consecutive in Exact's part table from the run's first one. Only the
    # pairs whose edge straddles the point's height can count: found on the heights alone,
    # the rest of the test runs on those
    curve_pair = np.flatnonzero((ab[1] > heights) != (ab[3] > heights))  # flat (point, part)
    n_exact = (hi - lo).take(owner) * T_ORIG.size
    exact_part = ranges(lo.take(owner) * T_ORIG.size, n_exact)
    table = exact.parts.reshape(4, -1)
    exact_qy = qy.repeat(n_exact)
    straddle = ((table[1].take(exact_part) > exact_qy) != (table[3].take(exact_part) > exact_qy)).nonzero()[0]
    p_idx = np.concatenate([curve_pair // n_curve, np.arange(n_points).repeat(n_exact).take(straddle)])
    ax, ay, bx, by = np.concatenate([ab.reshape(4, -1).take(curve_pair, axis=1),
                                     table.take(exact_part.take(straddle), axis=1)], axis=1)
    qy = qy.take(p_idx)
    x_at = ax + (qy - ay) * (bx - ax) / (by - ay)  # by != ay where the edge straddles
    hits = np.bincount(p_idx, weights=x_at > xy[0].take(p_idx), minlength=n_points)
    return hits.astype(np.int64) % 2 == 1


# --- geometry helpers -----------------------------------------------------------------------


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _cube(x: np.ndarray) -> np.ndarray:
    """``x * x * x``: within an ulp of ``x ** 3``, which numpy computes with ``pow``, ~30 times
    slower than a multiplication (the cubes were the costliest part of the distance test)."""
    return x * x * x


def _flatten(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> np.ndarray:
    """``(2, R, T)``: the points of cubics with ``(2, R)`` control planes at the parameters
    ``_T_FIT`` (:func:`depixel.curves.bspline.evaluate_cubic`, its weights computed once)."""
    b0, b1, b2, b3 = _W_FIT
    return b0 * p0[..., None] + b1 * p1[..., None] + b2 * p2[..., None] + b3 * p3[..., None]
