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


def _cubic(k: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points of the cubic Bézier with control points ``k`` (4, 2) at the parameters ``t``
    (any shape): ``t.shape + (2,)``."""
    t = t[..., None]
    s = 1 - t
    return s**3 * k[0] + 3 * s * s * t * k[1] + 3 * s * t * t * k[2] + t**3 * k[3]


def _nearest_distances(k: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Each point's distance to the cubic ``k``, by brute force: the nearest of 2,001 evenly
    spaced curve points, then three times the nearest of 201 points across the step on
    either side of the last one (each step a hundredth of the one before: 1e-9 at the end)."""
    t = np.linspace(0.0, 1.0, 2001)[None, :].repeat(len(points), axis=0)
    step = 1.0 / 2000
    for _ in range(3):
        d2 = ((_cubic(k, t) - points[:, None]) ** 2).sum(axis=2)
        best = t[np.arange(len(points)), d2.argmin(axis=1)]
        t = np.clip(best[:, None] + np.linspace(-step, step, 201), 0.0, 1.0)
        step /= 100
    return np.sqrt(((_cubic(k, t) - points[:, None]) ** 2).sum(axis=2).min(axis=1))


def test_distance_test_bounds_every_samples_distance_to_the_cubic():
    """The distance test of the fits (:meth:`_Samples.within`) measures each sample's
    distance to one point of the candidate cubic (from its chord-length parameter, two Newton
    steps), leaving out the range's start point: against the nearest point found by brute
    force over every sample of the range, its worst distance is an upper bound (a cubic it
    accepts lies within the tolerance of every sample), and the same distance on most of the
    fitted curves (the steps reach the nearest point); its verdict is that worst distance
    against the tolerance, exactly."""
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
    shape_ok, error, _ = samples.within(rows, c1, c2, np.full(rows.size, np.inf))
    assert rows.size > 100 and 0 < shape_ok.sum() < rows.size
    nearest = np.full(rows.size, np.nan)
    for i in shape_ok.nonzero()[0]:
        a, b = lo[rows[i]], hi[rows[i]]
        k = np.array([exact.start[a], c1[i], c2[i], exact.end[b - 1]])
        nearest[i] = _nearest_distances(k, exact.part_start[:, a:b].reshape(2, -1).T).max()
    assert (error[shape_ok] >= nearest[shape_ok] - 1e-6).all()  # an upper bound: the test is safe
    fitted = shape_ok & (np.arange(rows.size) < quads.size + lo.size)  # the quadratics and least-squares cubics
    assert (error[fitted] <= nearest[fitted] + 1e-6).mean() > 0.7  # 0.72; one step 0.57, none 0.21
    ok_at, _, _ = samples.within(rows, c1, c2, error)
    ok_below, _, _ = samples.within(rows, c1, c2, np.nextafter(error, -1.0))
    assert np.array_equal(ok_at, shape_ok)
    assert not ok_below.any()
