"""The input preparation through the API, the CLI and ``depixel inspect``: outputs laid
over the input, the options, the notes and the JSON report."""
from __future__ import annotations

import io
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES, drop_summary
from PIL import Image

import depixel
from depixel import api, load_image
from depixel.errors import ParameterError
from depixel.files import convert as files
from depixel.render import figure
from depixel.render.raster import render_rgba
from depixel_cli.main import main
from depixel_cli.options import Exit

GHOST = load_image(FIXTURES / "ghost.png")  # 18×16 on an opaque blue backdrop (92, 148, 252)
HEART = load_image(FIXTURES / "heart.png")  # 10×10 on white


def upscale(rgba: np.ndarray, kx: int, ky: int, left: int = 0, top: int = 0) -> np.ndarray:
    return rgba.repeat(ky, axis=0).repeat(kx, axis=1)[top:, left:]


def root_of(svg: str) -> ET.Element:
    return ET.fromstring(svg)


def fills(svg: str) -> set[str]:
    return {e.get("fill") for e in root_of(svg).iter() if e.tag.endswith("path")}


# --- API ----------------------------------------------------------------------------------------

def test_upscaled_input_gives_the_1x_conversion_at_the_input_size():
    """4× upscaled art converts exactly like the 1× art written 4× as large."""
    assert depixel.convert(upscale(HEART, 4, 4)) == depixel.convert(HEART, scale=4)
    assert depixel.convert(upscale(HEART, 4, 4), scale=0.5) == depixel.convert(HEART, scale=2)


def test_pixel_size_1_takes_the_pixels_as_they_are():
    root = root_of(depixel.convert(upscale(HEART, 3, 3), pixel_size=1))
    assert root.get("viewBox") == "0 0 30 30"


def test_a_crop_of_an_upscaled_image_is_overlaid_exactly():
    big = upscale(HEART, 4, 4)
    crop = big[3:38, 2:39]  # 37×35, partial blocks at every edge
    svg = depixel.convert(crop)
    root = root_of(svg)
    assert (root.get("width"), root.get("height"), root.get("viewBox")) == ("37", "35", "0.5 0.75 9.25 8.75")
    # the same drawing as the full conversion, only its view cropped; drawn at the input's
    # size it is the same picture, cropped the same way (up to cairo's anti-aliasing of a
    # curve that crosses the clipped edge: a few levels inside, 11 on the edge where the
    # heart's 45-degree side, a line, crosses it)
    full = depixel.convert(HEART, scale=4)
    assert svg[svg.index("<path"):] == full[full.index("<path"):]
    whole = render_rgba(full)
    part = render_rgba(svg)
    assert part.shape == (35, 37, 4)
    difference = np.abs(part.astype(int) - whole[3:38, 2:39]).max(axis=-1)
    assert difference[1:-1, 1:-1].max() <= 4
    assert difference.max() <= 16


def test_non_square_pixels_stretch_the_art():
    svg = depixel.convert(upscale(HEART, 4, 2))
    root = root_of(svg)
    assert (root.get("width"), root.get("height"), root.get("viewBox")) == ("40", "20", "0 0 10 10")
    assert root.get("preserveAspectRatio") == "none"
    assert render_rgba(svg).shape == (20, 40, 4)
    # drawn square, it is the square conversion
    square = render_rgba(depixel.convert(HEART, scale=4))
    assert np.abs(render_rgba(svg, width=40, height=40).astype(int) - square).max() <= 2


@pytest.mark.parametrize("shading", ["smooth", "flat"])
def test_png_output_has_the_input_size_times_scale(shading):
    crop = upscale(GHOST, 3, 3, left=1, top=2)  # 53×46
    png = api.convert_bytes(crop, "png", scale=2, shading=shading)
    with Image.open(io.BytesIO(png)) as img:
        assert img.size == (106, 92)


def test_transparent_auto_leaves_no_backdrop_shape():
    plain, keyed = depixel.convert(GHOST), depixel.convert(GHOST, transparent="auto")
    assert "#5c94fc" in fills(plain) and "#5c94fc" not in fills(keyed)
    alpha = render_rgba(keyed, width=18 * 9, height=16 * 9)[4::9, 4::9, 3]
    backdrop = (GHOST[..., :3] == [92, 148, 252]).all(axis=2)
    assert (alpha[backdrop] == 0).mean() > 0.9 and (alpha[~backdrop] == 255).mean() > 0.9


def test_api_options_are_validated():
    with pytest.raises(ParameterError, match="pixel_size") as info:
        depixel.convert(HEART, pixel_size="big")
    assert isinstance(info.value, ValueError) and info.value.parameter == "pixel_size"
    with pytest.raises(ParameterError, match="transparent"):
        depixel.convert(HEART, transparent="no-such-colour")


def test_convert_file_denoises_jpeg_by_default_and_reports(tmp_path):
    source = tmp_path / "ghost_x4.jpg"
    Image.fromarray(upscale(GHOST, 4, 4)[..., :3]).save(source, quality=90)
    seen = []
    out = files.convert_file(source, tmp_path / "g.svg", on_prepared=seen.append)
    assert seen[0].lossy == "JPEG" and seen[0].denoised and seen[0].pixel_size == (4, 4)
    assert root_of(out.read_text()).get("width") == "72"
    files.convert_file(source, tmp_path / "h.svg", denoise=False, on_prepared=seen.append)
    assert not seen[1].denoised
    png = tmp_path / "ghost.png"
    Image.fromarray(GHOST).save(png)
    files.convert_file(png, tmp_path / "i.svg", on_prepared=seen.append)
    assert not seen[2].changed


def test_background_is_flattened_before_keying():
    half = GHOST.copy()
    half[..., 3] = np.where((GHOST[..., :3] == [92, 148, 252]).all(axis=2), 0, 255)
    svg = depixel.convert(half, background="white", transparent="white")
    assert "#ffffff" not in fills(svg)


# --- CLI ------------------------------------------------------------------------------------------

@pytest.fixture()
def upscaled_png(tmp_path):
    path = tmp_path / "ghost_x4.png"
    Image.fromarray(upscale(GHOST, 4, 4)).save(path)
    return path


def test_cli_says_what_it_detected_in_one_line(upscaled_png, tmp_path, capsys):
    assert main(["convert", str(upscaled_png), "-o", str(tmp_path / "g.svg")]) == Exit.OK
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"depixel: note: {upscaled_png} is 4× upscaled pixel art; converted its 18×16 pixels"]
    root = root_of((tmp_path / "g.svg").read_text())
    assert (root.get("width"), root.get("viewBox")) == ("72", "0 0 18 16")


def test_cli_quiet_and_pixel_size_1(upscaled_png, tmp_path, capsys):
    assert main(["convert", str(upscaled_png), "-o", str(tmp_path / "g.svg"), "-q"]) == Exit.OK
    assert capsys.readouterr().err == ""
    assert main(["convert", str(upscaled_png), "-o", str(tmp_path / "h.svg"), "--pixel-size", "1"]) == Exit.OK
    assert capsys.readouterr().err == ""
    assert root_of((tmp_path / "h.svg").read_text()).get("viewBox") == "0 0 72 64"


def test_cli_json_reports_the_preparation(upscaled_png, tmp_path, capsys):
    code = main(["convert", str(upscaled_png), str(FIXTURES / "heart.png"), "--out-dir", str(tmp_path / "out"),
                 "--json", "-j", "1", "--transparent", "auto"])
    assert code == Exit.OK
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    entries = {e["input"].rsplit("/", 1)[-1]: e for e in report["prepared"]}
    assert entries["ghost_x4.png"]["pixel_size"] == [4, 4] and entries["ghost_x4.png"]["transparent"] == "#5c94fc"
    assert entries["heart.png"]["pixel_size"] == [1, 1] and entries["heart.png"]["transparent"] == "#ffffff"
    assert len(drop_summary(captured.err).splitlines()) == 2


def test_cli_stdin_is_prepared_too(upscaled_png, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(upscaled_png.read_bytes())))
    assert main(["convert", "-", "-o", "-"]) == Exit.OK
    captured = capsys.readouterr()
    assert 'width="72"' in captured.out and "<stdin> is 4× upscaled" in captured.err


@pytest.mark.parametrize("args, message", [
    (["--pixel-size", "0"], "between 1 and 32"),
    (["--pixel-size", "4y3"], "auto, N or NxM"),
    (["--transparent", "#12"], "unknown colour"),
])
def test_cli_rejects_bad_values_in_one_line(args, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["convert", str(FIXTURES / "heart.png"), "-o", str(tmp_path / "h.svg"), *args])
    assert exit_info.value.code == Exit.USAGE
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_cli_corners_that_differ_are_a_note(tmp_path, capsys):
    assert main(["convert", str(FIXTURES / "leaf.png"), "-o", str(tmp_path / "l.svg"), "--transparent", "auto"]) == 0
    assert "corners differ" in capsys.readouterr().err


# --- inspect ----------------------------------------------------------------------------------------

def test_inspect_shows_the_input_beside_the_prepared_image(upscaled_png, tmp_path):
    out = tmp_path / "stages.png"
    assert main(["inspect", str(upscaled_png), "-o", str(out), "--stage", "cells", "--zoom", "4"]) == Exit.OK
    prepared = api.prepare_input(load_image(upscaled_png))
    result = depixel.depixelize(prepared.rgba, stage="cells")
    titles = [t for t, _ in figure.stage_panels(result, 4, prepared, load_image(upscaled_png))]
    assert titles[:2] == ["input as given", "prepared 1x"]
    plain = [t for t, _ in figure.stage_panels(depixel.depixelize(GHOST, stage="cells"), 4)]
    assert plain[0] == "input" and len(titles) == len(plain) + 1
    with Image.open(out) as img:
        rows, cols = figure.grid_shape(len(titles))
        assert img.size == (cols * 72 + (cols + 1) * figure.GAP,
                            rows * (64 + figure.TITLE_HEIGHT) + (rows + 1) * figure.GAP)


def test_the_input_panel_lies_over_the_art_grid():
    crop = upscale(GHOST, 4, 4, left=1, top=3)
    prepared = api.prepare_input(crop)
    result = depixel.depixelize(prepared.rgba, stage="cells")
    (_, given), (_, art) = figure.stage_panels(result, 8, prepared, crop)[:2]
    given, art = np.asarray(given), np.asarray(art)
    assert given.shape == art.shape
    # away from the cut-off partial blocks (blank), the input as given looks like the art
    assert np.array_equal(given[8:-8, 8:-8], art[8:-8, 8:-8])
