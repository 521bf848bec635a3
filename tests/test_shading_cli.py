"""PNG output through the command line: the paper's smooth renderer by default, the flat
SVG render with --shading flat; SVG output is unaffected."""
from __future__ import annotations

import io

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


def test_svg_ignores_shading(tmp_path):
    a, b = tmp_path / "a.svg", tmp_path / "b.svg"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(a)]) == 0
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(b), "--shading", "flat"]) == 0
    assert a.read_bytes() == b.read_bytes()


def test_stdout_png_uses_the_same_renderer(tmp_path, capsysbinary):
    source = FIXTURES / "heart.png"
    assert main(["convert", str(source), "-o", "-", "--format", "png", "--scale", "3"]) == 0
    png = capsysbinary.readouterr().out
    expected = render_smooth(depixelize(load_image(source), Params()).vector, 3)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")), expected)
