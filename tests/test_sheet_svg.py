"""A sheet converted sprite by sprite (depixel/files/sheet.py) into one SVG of layers
(depixel/svg/layers.py): each layer is its sprite's lone conversion moved to its place."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES

from depixel import convert, load_image
from depixel.errors import InputError, ParameterError
from depixel.files.sheet import convert_sheet
from depixel.prepare.sheet import Sprite, find_sprites
from depixel.svg.layers import Placed, compose_layers, layer_ids

SVG = "{http://www.w3.org/2000/svg}"
INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"


def sheet_of(*names: str, gap: int = 2) -> np.ndarray:
    """The fixtures side by side on a transparent sheet, ``gap`` pixels apart, tops aligned."""
    images = [load_image(FIXTURES / name) for name in names]
    height = max(image.shape[0] for image in images)
    width = sum(image.shape[1] for image in images) + gap * (len(images) - 1)
    sheet = np.zeros((height, width, 4), np.uint8)
    x = 0
    for image in images:
        sheet[:image.shape[0], x:x + image.shape[1]] = image
        x += image.shape[1] + gap
    return sheet


def layers_of(svg: str) -> list[ET.Element]:
    return [g for g in ET.fromstring(svg) if g.get(f"{INKSCAPE}groupmode") == "layer"]


def alone(svg: str, keep: int) -> str:
    """The document with every layer but the ``keep``-th removed."""
    root = ET.fromstring(svg)
    layers = [g for g in root if g.get(f"{INKSCAPE}groupmode") == "layer"]
    for i, layer in enumerate(layers):
        if i != keep:
            root.remove(layer)
    return ET.tostring(root, encoding="unicode")


@pytest.fixture(scope="module")
def converted():
    sheet = sheet_of("ghost_rgba.png", "potion_rgba.png", "orb.png")
    found = find_sprites(sheet)
    return sheet, found, convert_sheet(sheet, found.sprites, title="sheet")


def test_one_layer_per_sprite_named_and_placed(converted):
    sheet, found, svg = converted
    assert found.description == "3 sprites apart (no regular grid): the bounding boxes of connected pixels" or \
        found.grid is not None
    layers = layers_of(svg)
    assert [g.get(f"{INKSCAPE}label") for g in layers] == [s.name for s in found.sprites]
    assert [g.get("transform") for g in layers] == [f"translate({s.x},{s.y})" for s in found.sprites]
    root = ET.fromstring(svg)
    assert root.get("viewBox") == f"0 0 {sheet.shape[1]} {sheet.shape[0]}"


def test_each_layers_path_data_is_its_lone_conversion(converted):
    sheet, found, svg = converted
    for sprite, layer in zip(found.sprites, layers_of(svg)):
        lone = convert(sheet[sprite.box])
        assert [p.get("d") for p in layer.iter(f"{SVG}path")] == re.findall(r' d="([^"]*)"', lone)


def test_ids_are_unique_and_every_reference_resolves(converted):
    _, _, svg = converted
    ids = re.findall(r'\sid="([^"]*)"', svg)
    assert len(ids) == len(set(ids))
    assert "smooth" in svg  # the smooth-shading filter is there, once a sprite
    for target in re.findall(r"url\(#([^)]*)\)", svg):
        assert target in ids


def test_a_layer_drawn_alone_renders_as_its_lone_conversion_at_its_place(converted):
    from depixel.render.raster import render_rgba  # noqa: PLC0415

    sheet, found, svg = converted
    zoom = 4
    for i, sprite in enumerate(found.sprites):
        drawn = render_rgba(alone(svg, i), scale=zoom).astype(int)
        lone = render_rgba(convert(sheet[sprite.box]), scale=zoom).astype(int)
        expected = np.zeros_like(drawn)
        y, x = sprite.y * zoom, sprite.x * zoom
        expected[y:y + lone.shape[0], x:x + lone.shape[1]] = lone
        difference = np.abs(drawn - expected)
        assert difference.max() <= 2, (sprite.name, difference.max())  # rounding of anti-aliasing alone


def test_upscaled_sprites_are_scaled_onto_their_rectangle():
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="8" height="8" viewBox="1 1 2 2">'
           '<path id="a" d="M1 1h2v2H1z"/></svg>')
    out = compose_layers([Placed("big", svg, 4, 0, 8, 8)], 12, 8)
    assert 'transform="translate(4,0) scale(4,4) translate(-1,-1)"' in out
    assert 'id="big-a"' in out


def test_layer_ids_are_xml_names_and_unique():
    assert layer_ids(["walk 0", "walk 0", "1", "é", "a-2", "a"]) == ["walk_0", "walk_0-2", "s1", "s_", "a-2", "a-3"]


def test_sprites_off_the_sheet_and_limits_are_refused():
    sheet = np.zeros((8, 8, 4), np.uint8)
    sheet[2:6, 2:6] = 255
    with pytest.raises(ParameterError, match="sprite 'x' at 6,0 4x4 is not within the 8x8 sheet"):
        convert_sheet(sheet, [Sprite("x", 6, 0, 4, 4)])
    with pytest.raises(InputError, match="2 sprites are 128 pixels in all, over the limit of 100") as info:
        convert_sheet(sheet, [Sprite("a", 0, 0, 8, 8), Sprite("b", 0, 0, 8, 8)], max_pixels=100)
    assert info.value.parameter == "max_pixels"
    with pytest.raises(ParameterError, match="sizes the whole sheet: no sheet_json"):
        convert_sheet(sheet, [Sprite("a", 0, 0, 8, 8)], sheet_json={"frames": {}})
    with pytest.raises(InputError, match="2 sprites, over the limit of 1 .a sprite counts as a frame") as info:
        convert_sheet(sheet, [Sprite("a", 0, 0, 4, 4), Sprite("b", 4, 4, 4, 4)], max_frames=1)
    assert info.value.parameter == "max_frames"
    assert 'width="100"' in convert_sheet(sheet, [Sprite("a", 0, 0, 8, 8)], width=100)  # the sheet's width


def test_with_resvg_the_smooth_shading_filter_too_renders_the_same(converted):
    resvg = pytest.importorskip("resvg_py")
    import io  # noqa: PLC0415

    from PIL import Image  # noqa: PLC0415

    def render(svg: str) -> np.ndarray:
        png = bytes(resvg.svg_to_bytes(svg_string=svg, zoom=8))
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(int)

    sheet, found, svg = converted
    for i, sprite in enumerate(found.sprites):
        drawn, lone = render(alone(svg, i)), render(convert(sheet[sprite.box]))
        expected = np.zeros_like(drawn)
        expected[sprite.y * 8:sprite.y * 8 + lone.shape[0], sprite.x * 8:sprite.x * 8 + lone.shape[1]] = lone
        assert np.abs(drawn - expected).max() <= 2, sprite.name
