"""Pulled-back runs drawn with fewer segments (depixel/svg/runfit.py).

A run of a stacked outline pulled back under an upper face is hidden under it: one curve
replaces the run and the lines to and from its nodes where it stays within a part of the
margin of them, keeping its ends and its directions there."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CORPUS, needs_corpus
from test_insets import ABUTTING, art, threads

from depixel import depixelize, load_image, to_svg
from depixel.svg import outlines, runfit
from depixel.svg.boundaries import CUBIC, LINE, QUAD
from depixel.svg.insets import Segments
from depixel.svg.outlines import build_outlines

NAN = [np.nan, np.nan]


def _loop(points: list[tuple[float, float]]) -> Segments:
    """One closed loop of lines through ``points`` (the last back to the first)."""
    ends = np.array(points[1:] + points[:1], float)
    n = len(ends)
    return Segments(np.full(n, LINE, np.uint8), np.full((n, 2), np.nan), np.full((n, 2), np.nan), ends,
                    np.array([0, n]))


def test_a_run_and_its_lines_become_one_curve_with_their_ends_and_directions():
    # the loop starts at (0, 0); a line in to (0.25, 0.25), the run to (1.75, 0.25), a line
    # back to the node (2, 0), then the shape's own edges round
    seg = _loop([(0, 0), (0.25, 0.25), (1.75, 0.25), (2, 0), (2, 3), (0, 3)])
    run = np.array([0, 0, 0, -1, -1, -1])  # segment k ends at point k + 1
    out = runfit.fit_runs(seg, run, np.array([0.25]), None)
    assert out.kind.size == 4 and out.loop_ptr.tolist() == [0, 4]
    assert out.kind[0] in (QUAD, CUBIC)
    np.testing.assert_allclose(out.end[0], [2, 0])
    c1 = out.ctrl[0]
    c2 = out.ctrl[0] if out.kind[0] == QUAD else out.ctrl2[0]
    # it leaves (0, 0) along the line in and reaches (2, 0) along the line out
    assert np.isclose(c1[0], c1[1]) and c1[0] > 0
    assert np.isclose(2 - c2[0], c2[1]) and c2[1] > 0
    # and lies within a part of the margin of the path it replaces, there in the middle
    t = 0.5
    start, end = np.array([0.0, 0.0]), out.end[0]
    mid = ((1 - t) ** 3 * start + 3 * t * (1 - t) ** 2 * c1 + 3 * t * t * (1 - t) * c2 + t ** 3 * end
           if out.kind[0] == CUBIC else (1 - t) ** 2 * start + 2 * t * (1 - t) * c1 + t * t * end)
    assert abs(mid[1] - 0.25) <= runfit.FIT * 0.25


def test_a_run_round_a_corner_stays_as_it_is():
    # up the side, a right angle, along the top: no one curve with those end directions fits
    seg = _loop([(0, 0), (0.25, 0.25), (0.25, 3), (3, 3), (3, 0)])
    run = np.array([0, 0, 0, -1, -1])
    out = runfit.fit_runs(seg, run, np.array([0.25]), None)
    assert out.kind.tolist() == seg.kind.tolist()
    np.testing.assert_array_equal(out.end, seg.end)


def _commands(image: np.ndarray) -> int:
    o = build_outlines(depixelize(image).vector, grid=0.01, simplify=0.25)
    return int(o.kind.size)


@needs_corpus
@pytest.mark.parametrize("name", ["sma_toad", "smw_mario"])
def test_fewer_segments_and_still_no_threads(name, monkeypatch):
    """Seen red with the fit turned off (the same segments as before)."""
    image = load_image(CORPUS / f"{name}.png")
    fitted = _commands(image)
    assert threads(image, to_svg(depixelize(image).vector)) <= 4
    monkeypatch.setattr(outlines, "fit_runs", lambda segments, run, margin, grid: segments)
    assert fitted < 0.97 * _commands(image)


def test_the_abutting_shapes_keep_no_thread_with_the_fit():
    image = art(ABUTTING)
    assert threads(image, to_svg(depixelize(image).vector)) == 0


def _close_by_hypot(curve, path, owner, tol):
    """The definition: every sample of each within ``tol`` of one of the other, ``hypot`` a pair."""
    points = np.einsum("kt,nkd->ntd", runfit._CURVE_WEIGHTS, curve)
    gap = np.hypot(*(points[owner] - path[:, None, :]).transpose(2, 0, 1))
    n = curve.shape[0]
    path_worst, curve_near = np.zeros(n), np.full((n, runfit.CURVE_SAMPLES), np.inf)
    with np.errstate(invalid="ignore"):  # a NaN distance: its range does not fit
        np.maximum.at(path_worst, owner, gap.min(axis=1))
        np.minimum.at(curve_near, owner, gap)
    return (path_worst <= tol) & (curve_near.max(axis=1) <= tol)


def test_the_closeness_test_answers_as_hypot_does_on_its_boundary():
    """Each range: a curve at one point (the origin, exactly), its path that point and one
    more sample at tol·(1 ± a few ulps) in a random direction, where the squared distance and
    ``hypot`` round either way (and a NaN in one range): the answer is the definition's."""
    rng = np.random.default_rng(7)
    n = 2000
    curve = np.zeros((n, 4, 2))
    tol = rng.uniform(0.05, 0.5, n)
    angle = rng.uniform(0, 2 * np.pi, n)
    reach = tol * (1 + rng.integers(-2, 3, n) * 2.0 ** -52)
    extra = reach[:, None] * np.stack((np.cos(angle), np.sin(angle)), 1)
    path = np.stack((np.zeros((n, 2)), extra), axis=1).reshape(-1, 2)
    path[3, 0] = np.nan
    owner = np.arange(n).repeat(2)
    expected = _close_by_hypot(curve, path, owner, tol)
    squared = (extra ** 2).sum(axis=1) <= tol ** 2
    assert (squared != expected).sum() > 10  # the boundary cases: the squared distance would answer otherwise
    assert np.array_equal(runfit._close(curve, path, owner, np.tile([0.0, 1.0], n), tol), expected)
    assert not expected[1]


@pytest.mark.parametrize("seed", range(4))
def test_the_closeness_test_answers_as_every_pair_measured_whatever_the_parameters(seed):
    """Random curves and paths along them (a few samples pushed off, some ranges folded back
    on themselves), the path samples' parameters true, shuffled or constant: the samples
    measured against the curve samples around their parameter first, the answer is still that
    of every pair."""
    rng = np.random.default_rng(seed)
    n, per = 300, 20
    curve = rng.uniform(0, 6, (n, 4, 2))
    along = np.sort(rng.uniform(0, 1, (n, per)), axis=1)
    along[:, 0], along[:, -1] = 0.0, 1.0
    weights = np.stack(runfit.cubic_weights(along.reshape(-1)))  # (4, n * per)
    path = np.einsum("kn,nkd->nd", weights, curve.repeat(per, axis=0))
    path += rng.normal(0, 0.02, path.shape) * (rng.uniform(size=(path.shape[0], 1)) < 0.1)
    folded = rng.uniform(size=n) < 0.2  # these ranges' paths run back over their first half
    path.reshape(n, per, 2)[folded, per // 2:] = path.reshape(n, per, 2)[folded, per // 2 - 1::-1]
    owner = np.arange(n).repeat(per)
    tol = rng.uniform(0.05, 0.4, n)
    expected = _close_by_hypot(curve, path, owner, tol)
    assert 0 < expected.sum() < n
    for u in (along.reshape(-1), rng.permutation(along.reshape(-1)), np.full(n * per, 0.5)):
        assert np.array_equal(runfit._close(curve, path, owner, u, tol), expected)
