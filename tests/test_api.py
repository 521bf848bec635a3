"""The Python API (depixel.api) and SVG rasterizing (depixel.render.raster)."""
from __future__ import annotations

import io
import re
import shutil
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES, art
from PIL import Image

import depixel
from depixel.colour import parse_colour
from depixel.errors import InputError, OutputError, RenderError
from depixel.files import convert as files
from depixel.render import raster

SPRITE = art("""
    .##.
    #rr#
    #rr#
    .##.
""")


def test_array_and_pil_image_give_the_same_svg():
    from_array = depixel.convert(SPRITE)
    from_pil = depixel.convert(Image.fromarray(SPRITE, "RGBA"))
    from_rgb = depixel.convert(SPRITE[..., :3])
    assert from_array == from_pil == from_rgb
    root = ET.fromstring(from_array)
    assert root.get("viewBox") == "0 0 4 4" and root.get("width") == "4"


def test_scale_sets_width_and_height_only():
    svg = depixel.convert(SPRITE, scale=2.5, title="sprite")
    root = ET.fromstring(svg)
    assert (root.get("width"), root.get("height"), root.get("viewBox")) == ("10", "10", "0 0 4 4")
    assert root.find("{http://www.w3.org/2000/svg}title").text == "sprite"


def test_params_and_stage_are_used():
    optimized = depixel.convert(SPRITE)
    cells = depixel.convert(SPRITE, stage="cells")
    curve = re.compile(r' d="[^"]*[QqTtCc]')
    assert not curve.search(cells) and curve.search(optimized)  # straight cell edges vs curves
    coarse = depixel.convert(SPRITE, precision=0)
    assert not re.search(r"\d\.\d", " ".join(re.findall(r' d="([^"]*)"', coarse)))


@pytest.mark.parametrize("fmt, magic", [("svg", b"<?xml"), ("png", b"\x89PNG"), ("pdf", b"%PDF-")])
def test_convert_bytes_formats(fmt, magic):
    data = depixel.convert_bytes(SPRITE, fmt, scale=8)
    assert data.startswith(magic)
    if fmt == "png":
        with Image.open(io.BytesIO(data)) as img:
            assert img.size == (32, 32)


def test_unknown_format_is_refused():
    with pytest.raises(ValueError, match="jpg"):
        depixel.convert_bytes(SPRITE, "jpg")
    with pytest.raises(OutputError, match="extension"):
        files.output_format("x.jpg")
    assert files.output_format("x.JPG", "pdf") == "pdf" and files.output_format("a/b.PNG") == "png"


def test_parse_colour_and_flatten():
    assert parse_colour("#f00") == (255, 0, 0)
    assert parse_colour("white") == (255, 255, 255)
    assert parse_colour(" #102030 ") == (16, 32, 48)
    with pytest.raises(ValueError, match="unknown colour"):
        parse_colour("not-a-colour")
    img = np.array([[[200, 100, 0, 128], [10, 20, 30, 0], [1, 2, 3, 255]]], np.uint8)
    flat = depixel.flatten(img, "#0000ff")
    assert flat[..., 3].tolist() == [[255, 255, 255]]
    assert flat[0, 0, :3].tolist() == [100, 50, 127]  # 200·128/255, 100·128/255, 255·127/255
    assert flat[0, 1, :3].tolist() == [0, 0, 255]  # fully transparent → the background
    assert flat[0, 2, :3].tolist() == [1, 2, 3]  # opaque → unchanged


def test_convert_file_writes_atomically_and_protects_the_input(tmp_path):
    src = tmp_path / "heart.png"
    shutil.copy(FIXTURES / "heart.png", src)
    out = depixel.convert_file(src, tmp_path / "heart.svg", stage="cells")
    assert ET.parse(out).getroot().find("{http://www.w3.org/2000/svg}title").text == "heart.png"
    before = src.read_bytes()
    with pytest.raises(OutputError, match="input"):
        depixel.convert_file(src, src, fmt="png", stage="cells")
    assert src.read_bytes() == before
    with pytest.raises(OutputError):
        depixel.convert_file(src, tmp_path / "no" / "such" / "folder.svg", stage="cells")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["heart.png", "heart.svg"]  # no temp files


def test_frames_of_an_animation(tmp_path):
    names = files.frame_outputs(tmp_path / "beat.svg", 2)
    assert [p.name for p in names] == ["beat-000.svg", "beat-001.svg"]
    assert files.frame_outputs("x.png", 1234)[-1].name == "x-1233.png"
    for i, out in enumerate(names):
        depixel.convert_file(FIXTURES / "heart_beat.gif", out, frame=i, stage="cells")
    assert names[0].read_bytes() != names[1].read_bytes()
    with pytest.raises(InputError, match="frame"):
        depixel.convert_file(FIXTURES / "heart_beat.gif", tmp_path / "x.svg", frame=2, stage="cells")


def test_render_file_sizes(tmp_path):
    svg = tmp_path / "s.svg"
    svg.write_text(depixel.convert(art("_##_\n#rr#\n#rr#\n_##_", {"_": (0, 0, 0, 0)}), stage="cells"))  # transparent corners
    depixel.render_file(svg, tmp_path / "w.png", width=40)
    depixel.render_file(svg, tmp_path / "s.png", scale=3, background="#ff0")
    with Image.open(tmp_path / "w.png") as w, Image.open(tmp_path / "s.png") as s:
        assert w.size == (40, 40) and s.size == (12, 12)
        assert w.convert("RGBA").getpixel((0, 0))[3] == 0
        assert s.convert("RGBA").getpixel((0, 0)) == (255, 255, 0, 255)
    assert depixel.render_file(svg, tmp_path / "s.pdf").read_bytes().startswith(b"%PDF-")
    with pytest.raises(OutputError):
        depixel.render_file(svg, tmp_path / "again.svg")
    with pytest.raises(InputError, match="no such file"):
        depixel.render_file(tmp_path / "missing.svg", tmp_path / "m.png")


def test_invalid_svg_is_a_render_error():
    with pytest.raises(RenderError, match="cannot render"):
        raster.render(b"<svg", "png", name="bad.svg")
    with pytest.raises(RenderError, match="width"):
        raster.svg_size(b'<svg xmlns="http://www.w3.org/2000/svg"/>')
    assert raster.svg_size(b'<svg xmlns="http://www.w3.org/2000/svg" width="2in" height="10"/>') == (192.0, 10.0)
    assert raster.svg_size(b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 7 5"/>') == (7.0, 5.0)


def test_missing_cairo_library_is_a_render_error(tmp_path, monkeypatch):
    """Importing cairosvg raises OSError when libcairo is missing: it must become a RenderError."""
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / "cairosvg.py").write_text("raise OSError(\"no library called 'cairo-2' was found\")\n")
    monkeypatch.syspath_prepend(str(fake))
    monkeypatch.delitem(sys.modules, "cairosvg", raising=False)
    with pytest.raises(RenderError, match="cairo library"):
        depixel.convert_bytes(SPRITE, "png", shading="flat")
    assert depixel.convert_bytes(SPRITE, "svg").startswith(b"<?xml")  # SVG never needs cairo
    assert depixel.convert_bytes(SPRITE, "png").startswith(b"\x89PNG")  # nor smooth-shaded PNG
    monkeypatch.setitem(sys.modules, "cairosvg", None)
    with pytest.raises(RenderError, match="pip install cairosvg"):
        raster.render("<svg/>", "pdf")


def test_cairosvg_version_from_metadata():
    version = raster.cairosvg_version()
    assert version and version[0].isdigit()
