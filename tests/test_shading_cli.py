"""--shading through the command line: PNG output is the paper's smooth renderer by default,
the flat SVG rendered with --shading flat; SVG output has the smooth-shading filter by
default and none with --shading flat."""
from __future__ import annotations

import io
import re

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image

from depixel import Params, depixelize, load_image
from depixel.render.shading import render_smooth
from depixel_cli.main import main


def test_png_defaults_to_smooth_shading(tmp_path):
    source = FIXTURES / "chip.png"
    smooth, flat = tmp_path / "smooth.png", tmp_path / "flat.png"
    assert main(["convert", str(source), "-o", str(smooth), "--scale", "4"]) == 0
    assert main(["convert", str(source), "-o", str(flat), "--scale", "4", "--shading", "flat"]) == 0
    expected = render_smooth(depixelize(load_image(source), Params()).vector, 4)
    got = np.asarray(Image.open(smooth).convert("RGBA"))
    assert got.shape == expected.shape == (15 * 4, 17 * 4, 4)
    assert np.array_equal(got, expected)
    other = np.asarray(Image.open(flat).convert("RGBA"))
    assert other.shape == got.shape and not np.array_equal(other, got)


def test_shading_flag_is_validated(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["convert", str(FIXTURES / "chip.png"), "-o", "x.png", "--shading", "blurry"])
    assert stop.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_svg_shading(tmp_path):
    """A shaded image gets the filter unless --shading flat; an image without shaded
    regions is the same either way (but for the options stamp, which names the shading)."""
    for name, shaded in (("orb.png", True), ("heart.png", False)):
        a, b = tmp_path / f"a-{name}.svg", tmp_path / f"b-{name}.svg"
        assert main(["convert", str(FIXTURES / name), "-o", str(a)]) == 0
        assert main(["convert", str(FIXTURES / name), "-o", str(b), "--shading", "flat"]) == 0
        smooth, flat = a.read_text(), b.read_text()
        assert ('filter="url(#smooth)"' in smooth) == shaded and "filter" not in flat
        unstamped = [re.sub(r"<!-- depixel-options:.*?-->", "", text) for text in (smooth, flat)]
        assert (unstamped[0] == unstamped[1]) != shaded


def test_stdout_png_uses_the_same_renderer(tmp_path, capsysbinary):
    source = FIXTURES / "heart.png"
    assert main(["convert", str(source), "-o", "-", "--format", "png", "--scale", "3"]) == 0
    png = capsysbinary.readouterr().out
    expected = render_smooth(depixelize(load_image(source), Params()).vector, 3)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")), expected)
