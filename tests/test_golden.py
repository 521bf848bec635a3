"""Golden renders: every fixture, converted with the default (optimized) stage and rendered
by cairosvg at 4×, must look like its reference PNG in ``tests/golden/``.

Renders are compared with a tolerance, not byte for byte (anti-aliasing differs slightly
between cairo versions): at most ``MAX_DIFFERENT`` of the pixels may differ by more than
``CHANNEL_TOLERANCE`` in any RGBA channel. On failure the actual, expected and a difference
image are written to the test's tmp directory, named in the message.

To regenerate the references after an intended change of the output (look at them!)::

    DEPIXEL_UPDATE_GOLDEN=1 .venv/bin/python -m pytest -q tests/test_golden.py

which rewrites ``tests/golden/<fixture stem>.png`` and skips the comparisons.
"""
from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import fixture_pngs
from PIL import Image

from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render.raster import render_rgba
from depixel.svg.writer import to_svg

GOLDEN = Path(__file__).resolve().parent / "golden"
SCALE = 4
CHANNEL_TOLERANCE = 32  # per channel, on 0-255
MAX_DIFFERENT = 0.01  # fraction of the pixels allowed over the tolerance
UPDATE = os.environ.get("DEPIXEL_UPDATE_GOLDEN") == "1"


def golden_path(source: Path) -> Path:
    return GOLDEN / f"{source.stem}.png"


def render_fixture(source: Path) -> np.ndarray:
    """``(H*4, W*4, 4) uint8``: the fixture's default conversion rendered at 4×."""
    svg = to_svg(depixelize(load_image(source)).vector)
    return render_rgba(svg, scale=SCALE, name=source.name)


def png(rgba: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(out, format="PNG", optimize=True)
    return out.getvalue()


def test_fixture_stems_are_unique():
    stems = [p.stem for p in fixture_pngs()]
    assert len(stems) == len(set(stems)), "two fixtures would share a golden file"


@pytest.mark.parametrize("source", fixture_pngs(), ids=lambda p: p.name)
def test_render_matches_golden(source, tmp_path):
    actual = render_fixture(source)
    reference = golden_path(source)
    if UPDATE:
        GOLDEN.mkdir(exist_ok=True)
        reference.write_bytes(png(actual))
        pytest.skip(f"golden updated: {reference}")
    assert reference.exists(), f"no golden render {reference}; create it with DEPIXEL_UPDATE_GOLDEN=1"
    with Image.open(reference) as img:
        expected = np.asarray(img.convert("RGBA"), dtype=np.uint8)
    assert actual.shape == expected.shape, f"size {actual.shape[:2]} != golden {expected.shape[:2]}"
    over = (np.abs(actual.astype(np.int16) - expected.astype(np.int16)) > CHANNEL_TOLERANCE).any(axis=2)
    ratio = over.mean()
    if ratio > MAX_DIFFERENT:
        (tmp_path / "actual.png").write_bytes(png(actual))
        (tmp_path / "expected.png").write_bytes(png(expected))
        diff = np.where(over[..., None], np.array([255, 0, 0, 255], np.uint8), expected // 4 + 191)
        (tmp_path / "diff.png").write_bytes(png(diff.astype(np.uint8)))
        pytest.fail(f"{source.name}: {ratio:.2%} of pixels differ by more than {CHANNEL_TOLERANCE} "
                    f"(allowed {MAX_DIFFERENT:.0%}); actual/expected/diff PNGs in {tmp_path}. "
                    f"If the change is intended, regenerate with DEPIXEL_UPDATE_GOLDEN=1.")
