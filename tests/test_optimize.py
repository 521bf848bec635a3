"""Stage 5 — paper §3.4 — curve optimization: energy goes down, nodes stay near home,
corners stay sharp, staircases round off, pixel centres stay in their cells, no dice."""
from __future__ import annotations

import re
from functools import cache

import numpy as np
import pytest
from conftest import FIXTURES, fixture_pngs
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from depixel.optimize.fidelity import _clearance, _clearances, centre_clearance
from depixel.params import Params
from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render.raster import render_rgba
from depixel.svg.writer import to_svg

FIXTURES_NAMES = [p.name for p in fixture_pngs()]


@cache
def fixture_run(name: str):
    return depixelize(load_image(FIXTURES / name), Params())


def square_image() -> np.ndarray:
    """12×12 white with an 8×8 black square at pixels 2..9."""
    img = np.full((12, 12, 4), 255, np.uint8)
    img[2:10, 2:10, :3] = 0
    return img


def disc_image(n: int = 16, radius: float = 6.0) -> np.ndarray:
    """A blue disc of pixels whose centres lie within ``radius`` of the image centre."""
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    img = np.full((n, n, 4), 255, np.uint8)
    img[(xx - n / 2) ** 2 + (yy - n / 2) ** 2 <= radius**2, :3] = (30, 60, 220)
    return img


def outline_points(vector, samples: int = 8) -> np.ndarray:
    """(K, 2) points sampled on every curved edge between two pixels of different colour."""
    cells = vector.cells
    rgba = vector.rgba.reshape(-1, 4)
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    inside = (left >= 0) & (right >= 0)
    differ = inside & (rgba[np.maximum(left, 0)] != rgba[np.maximum(right, 0)]).any(axis=1)
    assert vector.curved[differ].all()
    u, v = cells.edges[differ, 0], cells.edges[differ, 1]
    a, b = vector.points[u][:, None], vector.points[v][:, None]
    c0, c1, c2 = (vector.controls[differ, i][:, None] for i in range(3))
    t = np.linspace(0.0, 1.0, samples + 1)[None, :, None]
    first = (1 - t) ** 2 * a + 2 * t * (1 - t) * c0 + t**2 * c1
    second = (1 - t) ** 2 * c1 + 2 * t * (1 - t) * c2 + t**2 * b
    return np.concatenate([first, second], axis=1).reshape(-1, 2)


# --- the energy and its bounds ----------------------------------------------------------------

@pytest.mark.parametrize("name", FIXTURES_NAMES)
def test_relaxation_lowers_the_total_energy(name):
    opt = fixture_run(name).optimized
    assert opt.splines.n_curves > 0
    assert opt.energy_after < opt.energy_before


@pytest.mark.parametrize("name", FIXTURES_NAMES)
def test_nodes_stay_within_bounds(name):
    result = fixture_run(name)
    opt = result.optimized
    cells = opt.splines.cells
    h, w = cells.shape
    on_curve = np.zeros(len(cells.nodes), bool)
    on_curve[opt.splines.curve_nodes] = True
    move = np.linalg.norm(opt.positions - opt.initial, axis=1)
    # Curve nodes never leave the disc of radius Params().max_offset (0.5 px) around their
    # start; on the fixtures the largest move is about 0.46 px (mushroom.png).
    assert move[on_curve].max() <= Params().max_offset + 1e-12
    assert move[on_curve].max() > 0.05, "nothing moved"
    # Free nodes (harmonic map) stay strictly inside the image; border nodes stay put.
    q = cells.nodes
    border = (q[:, 0] == 0) | (q[:, 1] == 0) | (q[:, 0] == 4 * w) | (q[:, 1] == 4 * h)
    free = ~on_curve & ~border
    x, y = opt.positions[:, 0], opt.positions[:, 1]
    assert ((x[free] > 0) & (x[free] < w) & (y[free] > 0) & (y[free] < h)).all()
    assert np.array_equal(opt.positions[border & ~on_curve], q[border & ~on_curve] / 4.0)


# --- shape ------------------------------------------------------------------------------------

def test_square_keeps_its_four_corners():
    img = square_image()
    result = depixelize(img)
    opt = result.optimized
    corner_xy = opt.positions[opt.corners.nodes]
    assert sorted(map(tuple, corner_xy.tolist())) == [(2.0, 2.0), (2.0, 10.0), (10.0, 2.0), (10.0, 10.0)]
    s = 8
    rendered = render_rgba(to_svg(result.vector), width=12 * s, height=12 * s).astype(int)

    def colour_at(x: float, y: float) -> np.ndarray:
        return rendered[int(y * s), int(x * s), :3]

    for cx, cy in ((2, 2), (10, 2), (2, 10), (10, 10)):
        inward = np.array([np.sign(6 - cx), np.sign(6 - cy)])
        for depth in (0.5, 0.15):  # the corner pixel's centre, and a point near the corner
            x, y = np.array([cx, cy]) + depth * inward
            assert np.abs(colour_at(x, y)).max() <= 32, f"({x}, {y}) not black: {colour_at(x, y)}"
        x, y = np.array([cx, cy]) - 0.15 * inward  # just outside stays white
        assert (colour_at(x, y) >= 255 - 32).all(), f"({x}, {y}) not white: {colour_at(x, y)}"


def test_splines_stage_rounds_the_square_corners_off():
    """The control case of the test above: without corner handling the corner is cut."""
    result = depixelize(square_image(), stage="splines")
    s = 8
    rendered = render_rgba(to_svg(result.vector), width=12 * s, height=12 * s).astype(int)
    assert (rendered[int(2.15 * s), int(2.15 * s), :3] > 128).all()


def test_staircase_disc_gets_rounder():
    img = disc_image()
    centre = np.array([8.0, 8.0])
    spread = {}
    for stage in ("splines", "optimized"):
        result = depixelize(img, stage=stage)
        distance = np.linalg.norm(outline_points(result.vector) - centre, axis=1)
        spread[stage] = distance.std()
    assert depixelize(img).optimized.corners.nodes.sum() == 0, "a disc has no corners"
    assert spread["optimized"] < 0.9 * spread["splines"], spread


# --- no randomness ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["heart.png", "mushroom.png"])
def test_the_same_input_gives_byte_identical_svg(name):
    rgba = load_image(FIXTURES / name)
    first = to_svg(depixelize(rgba.copy()).vector)
    second = to_svg(depixelize(rgba.copy()).vector)
    assert first.encode() == second.encode()


# --- pixel centres ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", FIXTURES_NAMES)
def test_every_cell_keeps_its_pixel_centre(name):
    clearance = centre_clearance(fixture_run(name).vector)
    assert clearance.min() > 0, f"pixel {int(clearance.argmin())} lost its centre ({clearance.min():.3f})"


LEVELS = [0, 40, 60, 128, 200, 255]
colour = st.tuples(*[st.sampled_from(LEVELS)] * 3, st.just(255))


@st.composite
def images(draw) -> np.ndarray:
    palette = np.array(draw(st.lists(colour, min_size=2, max_size=4)), np.uint8)
    shape = (draw(st.integers(3, 8)), draw(st.integers(3, 8)))
    index = draw(arrays(np.uint8, shape, elements=st.integers(0, len(palette) - 1)))
    return palette[index]


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(images())
def test_random_images_keep_every_pixel_centre(rgba):
    clearance = centre_clearance(depixelize(rgba).vector)
    assert clearance.min() > 0, f"rgba = np.array({rgba.tolist()}, np.uint8)"



@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(images(), st.integers(0, 2**32 - 1))
def test_the_clearance_bounded_below_is_exact_under_the_bound(rgba, seed):
    """The revert measures with ``below=margin``: edges far from a centre are not
    flattened. Below the bound it must give the exact clearance (also for centres pushed
    out of their cells), above it anything at least the bound."""
    optimized = depixelize(rgba).optimized
    shaken = optimized.positions + np.random.default_rng(seed).normal(0.0, 0.3, optimized.positions.shape)
    drawing = optimized.splines.drawing(shaken)
    exact = _clearance(optimized.splines.cells, drawing, None)
    for below in (0.075, 0.3):
        bounded = _clearance(optimized.splines.cells, drawing, None, below=below)
        low = exact < below
        assert np.array_equal(bounded[low], exact[low])
        assert (bounded[~low] >= below).all()


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(images(), st.integers(0, 2**32 - 1))
def test_clearances_of_several_drawings_are_each_drawings_own(rgba, seed):
    """The revert's first round measures the current and the initial drawing in one pass
    (``_clearances``): each row must be that drawing's own clearance to the bit, at the
    same wanted pixels, bounded or not (centres pushed out of their cells included)."""
    optimized = depixelize(rgba).optimized
    splines, rng = optimized.splines, np.random.default_rng(seed)
    drawings = tuple(splines.drawing(optimized.positions + rng.normal(0.0, scale, optimized.positions.shape))
                     for scale in (0.0, 0.3))
    wanted = rng.random(splines.cells.shape[0] * splines.cells.shape[1]) < 0.7
    for below in (np.inf, 0.075):
        together = _clearances(splines.cells, drawings, wanted, below=below)
        for row, drawing in zip(together, drawings):
            assert np.array_equal(row, _clearance(splines.cells, drawing, wanted, below=below))


# --- switching it off ---------------------------------------------------------------------------

def test_depixelize_stops_at_the_requested_stage():
    rgba = load_image(FIXTURES / "heart.png")
    splines = depixelize(rgba, stage="splines")
    assert splines.optimized is None and splines.vector.stage == "splines"
    assert to_svg(fixture_run("heart.png").vector) != to_svg(splines.vector)


def test_cli_no_optimize_gives_the_splines_stage(tmp_path):
    from depixel_cli.main import main

    src = str(FIXTURES / "heart.png")
    off, stage = tmp_path / "off.svg", tmp_path / "stage.svg"
    assert main(["convert", src, "-o", str(off), "--no-optimize"]) == 0
    assert main(["convert", src, "-o", str(stage), "--stage", "splines"]) == 0
    assert off.read_bytes() == stage.read_bytes()
    assert re.search(rb' d="[^"]*[QqTtCc]', off.read_bytes())  # curves
