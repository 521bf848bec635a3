"""Fuzzing (hypothesis, derandomized so CI never flakes): random small images with random
palettes and alpha go through the whole pipeline; random and mangled bytes go through the
loader. Invariants: the cells tile the image, the SVG parses and references nothing, the
output is deterministic, and every pixel centre keeps its colour and opacity."""
from __future__ import annotations

import numpy as np
from conftest import FIXTURES
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from robust import STAGE, centre_errors, parse

import depixel
from depixel.errors import InputError
from depixel.prepare.image import load_image

# Channel levels close together (hqx-similar) and far apart, so random palettes produce
# similar pairs, shading edges and crossings, not only all-different colours.
LEVELS = [0, 6, 12, 60, 128, 134, 200, 250, 255]
ALPHAS = [0, 0, 128, 200, 255, 255, 255]
colour = st.tuples(*[st.sampled_from(LEVELS)] * 3, st.sampled_from(ALPHAS))


@st.composite
def images(draw, max_side: int = 8) -> np.ndarray:
    """``(H, W, 4) uint8``: 1-6 palette colours laid out at random, H, W in 1..max_side."""
    palette = np.array(draw(st.lists(colour, min_size=1, max_size=6)), np.uint8)
    shape = (draw(st.integers(1, max_side)), draw(st.integers(1, max_side)))
    index = draw(arrays(np.uint8, shape, elements=st.integers(0, len(palette) - 1)))
    return palette[index]


def describe(rgba: np.ndarray) -> str:
    return f"rgba = np.array({rgba.tolist()}, np.uint8)"


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(images())
def test_random_images_keep_the_invariants(rgba):
    h, w = rgba.shape[:2]
    result = depixel.depixelize(rgba, stage=STAGE)
    areas = result.cells.cell_areas()
    assert areas.min() > 0 and abs(areas.sum() - w * h) < 1e-9, describe(rgba)
    svg = depixel.to_svg(result.vector)
    parse(svg)
    again = depixel.to_svg(depixel.depixelize(rgba.copy(), stage=STAGE).vector)
    assert svg == again, "not deterministic: " + describe(rgba)
    bad = centre_errors(rgba, svg)
    assert not bad.any(), f"pixel centres {np.argwhere(bad).tolist()} off: " + describe(rgba)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.binary(max_size=512))
def test_random_bytes_are_rejected_cleanly(data):
    try:
        rgba = load_image(data)
    except InputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("<bytes>: ")
    else:  # a few byte strings are valid images in some format (e.g. a tiny PCX or TGA)
        assert rgba.ndim == 3 and rgba.shape[2] == 4 and rgba.dtype == np.uint8


SEED_PNG = (FIXTURES / "potion_rgba.png").read_bytes()


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.integers(0, len(SEED_PNG) - 1), st.integers(0, 255)), max_size=6),
       st.integers(1, len(SEED_PNG)))
def test_mangled_png_is_rejected_or_converted(edits, keep):
    data = bytearray(SEED_PNG[:keep])
    for at, value in edits:
        if at < len(data):
            data[at] = value
    try:
        rgba = load_image(bytes(data))
    except InputError as exc:
        assert "\n" not in str(exc)
        return
    parse(depixel.to_svg(depixel.depixelize(rgba, stage=STAGE).vector))

