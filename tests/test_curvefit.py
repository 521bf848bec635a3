"""depixel/svg/curvefit.py's and reference.py's numerics that the speed work reshaped: they must give the very
numbers of the plain formulas (the output is compared byte for byte)."""
from __future__ import annotations

import numpy as np

from depixel.curves.bspline import evaluate_cubic
from depixel.svg.curvefit import _T_FIT, _cube, _flatten
from depixel.svg.reference import per_sample


def test_flatten_is_evaluate_cubic_at_the_fit_parameters_to_the_bit():
    rng = np.random.default_rng(3)
    p0, p1, p2, p3 = (rng.uniform(-50, 300, (2, 40)) for _ in range(4))
    plain = evaluate_cubic(p0[..., None], p1[..., None], p2[..., None], p3[..., None], _T_FIT)
    assert plain.shape == (2, 40, _T_FIT.size)
    assert np.array_equal(_flatten(p0, p1, p2, p3), plain)


def test_per_sample_repeats_each_item_like_a_gather():
    planes = np.arange(2 * 3 * 5, dtype=float).reshape(2, 3, 5)
    count = np.array([2, 0, 3])
    out = per_sample(planes, count)
    assert out.shape == (2, 5, 5)
    assert np.array_equal(out, planes.take([0, 0, 2, 2, 2], axis=1))


def test_cube_is_the_product_within_two_ulps_of_numpys_power():
    x = np.random.default_rng(5).uniform(0.0, 1.0, 10_000)  # chord-length parameters and 1 - them
    assert np.array_equal(_cube(x), x * x * x)
    np.testing.assert_array_max_ulp(_cube(x), x**3, maxulp=2)


def test_exact_samples_are_flatten_cubics_to_the_bit():
    """Exact computes the samples of the exact segments on planes, segments innermost: the
    same numbers as bspline.flatten_cubic's (K, 4, 2) layout."""
    from conftest import FIXTURES

    from depixel import depixelize, load_image
    from depixel.curves.bspline import flatten_cubic
    from depixel.svg.outlines import OutlineShapes
    from depixel.svg.reference import T_ORIG, Exact, _as_cubic

    vector = depixelize(load_image(FIXTURES / "mushroom.png")).vector
    pieces = OutlineShapes(vector, "stacked", grid=0.01, simplify=0.0).pieces
    exact = Exact(pieces, 0.25)
    c1, c2 = _as_cubic(exact.start, pieces.kind, pieces.ctrl, pieces.ctrl2, exact.end)
    samples = flatten_cubic(exact.start, c1, c2, exact.end, T_ORIG).transpose(2, 0, 1)  # (2, K, 4)
    assert samples.shape[1] > 50
    assert np.array_equal(exact.part_start, samples)
    assert np.array_equal(exact.part_end[:, :, :-1], samples[:, :, 1:])
    assert np.array_equal(exact.part_end[:, :, -1], exact.end.T)


def test_segments_of_edges_are_the_segments_of_each_span_in_the_edges_piece():
    """Protected's look-up: for every curved edge, the segments of its two spans (its slot and
    the next) that lie in the edge's piece, in index order, -1 for the rest (a span has at
    most two, its halves; a span cut between two pieces has one in each)."""
    from conftest import FIXTURES

    from depixel import depixelize, load_image
    from depixel.svg.outlines import OutlineShapes
    from depixel.svg.reference import _SegmentsOfEdges

    vector = depixelize(load_image(FIXTURES / "mushroom.png")).vector
    pieces = OutlineShapes(vector, "stacked", grid=0.01, simplify=0.0).pieces
    curves = vector.curves
    seg_piece = np.repeat(np.arange(len(pieces)), np.diff(pieces.ptr))
    edges = np.flatnonzero(pieces.edge_piece >= 0)
    found = _SegmentsOfEdges(pieces, vector)(edges)
    assert found.shape == (edges.size, 4)
    for row, edge in zip(found.tolist(), edges):
        expected = []
        for slot in (curves.edge_slot[edge], curves.next[curves.edge_slot[edge]]):
            segments = [] if slot < 0 else [j for j in np.flatnonzero(pieces.span_slot == slot)
                                             if seg_piece[j] == pieces.edge_piece[edge]]
            expected += segments + [-1] * (2 - len(segments))
        assert row == expected
    # the fixture has spans cut between two pieces (a half in each)
    pieces_of_slot: dict[int, list[int]] = {}
    for j, slot in enumerate(pieces.span_slot.tolist()):
        pieces_of_slot.setdefault(slot, []).append(seg_piece[j])
    assert any(len(p) == 2 and p[0] != p[1] for p in pieces_of_slot.values())


def test_tangent_is_the_unit_leg_or_chord_of_the_plain_formula_to_the_bit():
    from depixel.svg.reference import _tangent

    rng = np.random.default_rng(7)
    leg, chord = rng.uniform(-3, 3, (200, 2)), rng.uniform(-3, 3, (200, 2))
    leg[:50] = 0.0  # no leg: the chord's direction
    leg[50:60, 0] = 0.0  # a leg along an axis
    chord[:10] = 0.0  # neither: zero, not NaN
    v = np.where((np.abs(leg) > 0).any(axis=1)[:, None], leg, chord)
    plain = v / np.maximum(np.linalg.norm(v, axis=-1)[:, None], 1e-300)
    assert np.array_equal(_tangent(leg, chord), plain)
    assert np.array_equal(_tangent(leg, chord)[:10], np.zeros((10, 2)))


def test_piece_tolerance_is_the_tolerance_or_a_sixteenth_of_the_pieces_sample_box():
    """The box holds every sample of the piece, both its ends included: so a piece walked
    the other way (a mirrored image's) gets the same tolerance."""
    from conftest import FIXTURES

    from depixel import depixelize, load_image
    from depixel.svg.outlines import OutlineShapes
    from depixel.svg.reference import _RELATIVE_TOLERANCE, Exact

    vector = depixelize(load_image(FIXTURES / "mushroom.png")).vector
    pieces = OutlineShapes(vector, "stacked", grid=0.01, simplify=0.0).pieces
    for tolerance in (0.25, 2.0):
        exact = Exact(pieces, tolerance)
        expected = []
        for a, b in zip(pieces.ptr[:-1].tolist(), pieces.ptr[1:].tolist()):
            x = np.concatenate([exact.part_start[0, a:b].ravel(), exact.part_end[0, a:b].ravel()])
            y = np.concatenate([exact.part_start[1, a:b].ravel(), exact.part_end[1, a:b].ravel()])
            size = np.hypot(x.max() - x.min(), y.max() - y.min())
            expected += [min(tolerance, _RELATIVE_TOLERANCE * size)] * (b - a)
        np.testing.assert_allclose(exact.tolerance, expected, rtol=1e-15)
        assert (exact.tolerance < tolerance).any()  # the small pieces


def _plain_worst_distances(exact, lo, hi, c1, c2):
    """Each candidate cubic's largest distance to the samples of its range [lo, hi), every
    sample (the range's start point too), by the distance test's formulas one candidate at
    a time: the chord-length parameter, two Newton steps, the distance to the point there."""
    worst = []
    for a, b, k1, k2 in zip(lo.tolist(), hi.tolist(), c1, c2):
        points = exact.part_start[:, a:b].reshape(2, -1)
        lengths = exact.length[a:b]
        summed = lengths.cumsum()  # (the range's own running sum)
        arc = ((summed - lengths)[:, None] + exact.arc[a:b]).ravel()
        u = arc / max(summed[-1], 1e-300)
        q0, q1, q2, q3 = exact.start[a][:, None], k1[:, None], k2[:, None], exact.end[b - 1][:, None]
        d10, d21, d32, e1, e2 = q1 - q0, q2 - q1, q3 - q2, q2 - 2 * q1 + q0, q3 - 2 * q2 + q1
        for _ in range(2):
            s = 1 - u
            s2, t2 = s**2, u**2
            point = s2 * s * q0 + 3 * u * s2 * q1 + 3 * t2 * s * q2 + t2 * u * q3
            d1 = 3 * (s2 * d10 + 2 * u * s * d21 + t2 * d32)
            d2 = 6 * (s * e1 + u * e2)
            off = point - points
            num = off[0] * d1[0] + off[1] * d1[1]
            den = (d1[0] * d1[0] + d1[1] * d1[1]) + (off[0] * d2[0] + off[1] * d2[1])
            u = np.minimum(np.maximum(u - num / np.where(np.abs(den) > 1e-12, den, 1e-12), 0.0), 1.0)
        s = 1 - u
        off = s * s * s * q0 + 3 * u * s**2 * q1 + 3 * u**2 * s * q2 + u * u * u * q3 - points
        d = np.sqrt(off[0] ** 2 + off[1] ** 2)
        assert d[0] == 0.0  # the start point: what the distance test leaves out
        worst.append(d.max())
    return np.array(worst)


def test_distance_test_is_every_samples_distance_within_the_tolerance_to_the_bit():
    """The distance test of the fits (:meth:`_Samples.within`) leaves out each range's start
    point and computes every candidate's samples at once: its verdicts are those of the plain
    formulas over every sample of the range, at each candidate's worst distance exactly and
    just below it."""
    from conftest import FIXTURES

    from depixel import depixelize, load_image
    from depixel.curves.bspline import elevate
    from depixel.svg.curvefit import _cubic_controls, _quadratic_control, _Samples
    from depixel.svg.outlines import OutlineShapes
    from depixel.svg.reference import Exact

    vector = depixelize(load_image(FIXTURES / "mushroom.png")).vector
    pieces = OutlineShapes(vector, "stacked", grid=0.01, simplify=0.0).pieces
    exact = Exact(pieces, 0.25)
    # runs of 2, 4 and 8 segments along every piece
    lo, hi = map(np.array, zip(*[(a, a + size) for p in range(len(pieces)) for size in (2, 4, 8)
                                 for a in range(int(pieces.ptr[p]), int(pieces.ptr[p + 1]) - size + 1, size)]))
    samples = _Samples(exact, lo, hi)
    q, has_q = _quadratic_control(exact, samples.p0.T, samples.p3.T, lo, hi, None)
    q1, q2 = elevate(samples.p0.T, q, samples.p3.T)
    r1, r2 = _cubic_controls(exact, samples, None, lo, hi, None)
    quads = has_q.nonzero()[0]
    # the quadratics, the least-squares cubics and those cubics with their controls moved
    # (their worst samples anywhere along the range)
    rng = np.random.default_rng(11)
    rows = np.concatenate([quads, np.arange(lo.size), np.arange(lo.size)])
    c1 = np.concatenate([q1[quads], r1, r1 + rng.normal(0.0, 0.5, r1.shape)])
    c2 = np.concatenate([q2[quads], r2, r2 + rng.normal(0.0, 0.5, r2.shape)])
    worst = _plain_worst_distances(exact, lo[rows], hi[rows], c1, c2)
    shape_ok, _, _ = samples.within(rows, c1, c2, np.full(rows.size, np.inf))
    assert rows.size > 100 and 0 < shape_ok.sum() < rows.size
    ok_at, error, _ = samples.within(rows, c1, c2, worst)
    ok_below, _, _ = samples.within(rows, c1, c2, np.nextafter(worst, -1.0))
    assert np.array_equal(error[shape_ok], worst[shape_ok])
    assert np.array_equal(ok_at, shape_ok)
    assert not ok_below.any()
