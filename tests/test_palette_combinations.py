"""Palettes with the rest (issue 43 beside issues 41, 42, 46): swatches over masked smooth
groups, in animated SVGs and on sprite sheets (one set of swatches a file); palette swaps of
animations and sheets; EPS of a sheet, not of an animation; ``depixel render`` to EPS."""
from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image
from test_animate_cli import walk_gif
from test_animation import DURATIONS, assert_frames_draw_alone, blinking
from test_eps import IMAGE_OPERATORS, POTION, page

import depixel
from depixel.api import load
from depixel.errors import ParameterError, RenderError
from depixel.prepare.animation import Animation
from depixel.prepare.gpl import Palette, PaletteEntry, PaletteMap, read_palette
from depixel.render.raster import render, render_rgba
from depixel.svg.hiding import KEEP_ID
from depixel.svg.swatches import SharedSwatches
from depixel_cli.main import main
from depixel_cli.options import Exit

resvg_py = pytest.importorskip("resvg_py")

SVG = "{http://www.w3.org/2000/svg}"
OUTLINE, GREEN = (24, 20, 37), (32, 192, 64)  # the orb's outline, and a colour it becomes
#: the orb's outline to green, the red of the blinking patch to blue
SWAP = PaletteMap(Palette((PaletteEntry((*OUTLINE, 255)), PaletteEntry((220, 30, 30, 255)))),
                  Palette((PaletteEntry((*GREEN, 255)), PaletteEntry((30, 30, 220, 255)))))
#: editing the outline's swatch does what this swap does
EDIT = PaletteMap(Palette((PaletteEntry((*OUTLINE, 255)),)), Palette((PaletteEntry((*GREEN, 255)),)))


def resvg(svg: str, width: int) -> np.ndarray:
    png = bytes(resvg_py.svg_to_bytes(svg_string=svg, width=width))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(int)


def swatches(svg: str) -> dict[str, str]:
    """Each swatch's id → its colour (``#rrggbb``)."""
    return dict(re.findall(r'<linearGradient id="([^"]*)" inkscape:swatch="solid"[^\n]*?stop-color:(#[0-9a-f]{6})',
                           svg))


def filled_from(svg: str) -> set[str]:
    return set(re.findall(r'fill="url\(#([^)]*)\)', svg))


def hexes(*images: np.ndarray) -> set[str]:
    pixels = np.concatenate([image.reshape(-1, 4) for image in images])
    return {"#" + bytes(p[:3]).hex() for p in np.unique(pixels[pixels[:, 3] > 0], axis=0)}


def assert_ids_unique(svg: str) -> None:
    ids = [e.get("id") for e in ET.fromstring(svg).iter() if e.get("id")]
    assert len(ids) == len(set(ids))


# --- smooth groups masked by the shapes over them (issue 46) ---------------------------------

@pytest.mark.parametrize("name", ["orb", "leaf_la"])
def test_masked_smooth_groups_render_the_same_with_swatches(name):
    image = load(FIXTURES / f"{name}.png")
    plain, svg = depixel.convert(image), depixel.convert(image, swatches=True)
    covering = [ident for ident in re.findall(r'<use xlink:href="#([^"]*)"/>', svg)
                if ident != KEEP_ID]  # what the masks hide: shapes on swatches
    assert covering and all(re.search(rf'<path id="{c}"[^>]* fill="url\(#', svg) for c in covering)
    width = image.shape[1] * 8
    for draw in (lambda s: resvg(s, width), lambda s: render_rgba(s, width=width).astype(int)):
        np.testing.assert_array_equal(draw(svg), draw(plain))
    unmasked = re.sub(r' mask="url\(#[^)]*\)"', "", svg)
    assert not np.array_equal(resvg(unmasked, width), resvg(svg, width))  # the masks hide their part


# --- animations (issue 41) --------------------------------------------------------------------

@pytest.fixture(scope="module")
def orb_blink() -> tuple[Animation, str, str]:
    """The orb blinking (masked smooth groups in every frame): its animated SVG, with swatches too."""
    animation = Animation(blinking("orb"), DURATIONS, 0)
    return animation, depixel.convert(animation, animate=True), depixel.convert(animation, animate=True,
                                                                                   swatches=True)


def test_an_animation_has_one_swatch_per_colour_of_all_its_frames(orb_blink):
    animation, plain, svg = orb_blink
    assert_ids_unique(svg)
    found = swatches(svg)
    assert sorted(found.values()) == sorted(hexes(*animation.frames))  # each colour once, red and yellow too
    assert list(found) == [f"pal-{n:02d}-{colour[1:]}" for n, colour in enumerate(found.values())]  # the file's order
    assert filled_from(svg) == set(found)
    assert svg.count("<use ") == plain.count("<use ")  # the frames still share their shapes


def test_each_frame_of_a_swatched_animation_draws_as_its_own_conversion(orb_blink):
    animation, _, svg = orb_blink
    assert "<mask " in svg
    assert_frames_draw_alone(svg, animation.frames)


def test_editing_a_swatch_of_an_animation_recolours_that_colour_in_every_frame(orb_blink):
    animation, _, svg = orb_blink
    edited = svg.replace(f"stop-color:#{bytes(OUTLINE).hex()};", f"stop-color:#{bytes(GREEN).hex()};")
    assert edited.count("stop-color:#20c040;") == 1
    assert_frames_draw_alone(edited, animation.frames, palette_map=EDIT)


def test_a_palette_map_recolours_every_frame_and_keeps_the_shapes(orb_blink):
    animation, plain, _ = orb_blink
    svg = depixel.convert(animation, animate=True, palette_map=SWAP)
    assert re.findall(r' d="[^"]*"', svg) == re.findall(r' d="[^"]*"', plain)
    assert_frames_draw_alone(svg, animation.frames, palette_map=SWAP)
    named = depixel.convert(animation, animate=True, palette_map=SWAP, swatches=True)
    assert "#20c040" in swatches(named).values() and "#181425" not in swatches(named).values()
    assert_frames_draw_alone(named, animation.frames, palette_map=SWAP)
    apng = depixel.read_animation(depixel.convert_bytes(animation, "png", animate=True, palette_map=SWAP, scale=3))
    for got, frame in zip(apng.frames, animation.frames, strict=True):
        alone = depixel.convert_bytes(frame, "png", scale=3, palette_map=SWAP)
        np.testing.assert_array_equal(got, np.asarray(Image.open(io.BytesIO(alone)).convert("RGBA")))


def test_an_animation_is_no_eps(orb_blink, tmp_path, capsys, monkeypatch):
    with pytest.raises(ParameterError, match="an EPS cannot play frames: convert one frame to EPS"):
        depixel.convert_bytes(orb_blink[0], "eps", animate=True)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stopped:
        main(["convert", str(FIXTURES / "heart_beat.gif"), "--animate", "-o", "beat.eps"])
    assert stopped.value.code == Exit.USAGE and "an EPS cannot play frames" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# --- sprite sheets (issue 42) -----------------------------------------------------------------

def orb_sheet() -> np.ndarray:
    """The orb, with a red patch in its middle, with a yellow patch above that: 2 transparent
    pixels apart (row by row, the sheet has the yellow first; sprite by sprite, the red)."""
    orb, red, _ = blinking("orb")
    yellow = orb.copy()
    yellow[4:6, 7:9] = (240, 220, 40, 255)
    sheet = np.zeros((16, 52, 4), np.uint8)
    sheet[:, :16], sheet[:, 18:34], sheet[:, 36:] = orb, red, yellow
    return sheet


def test_a_sheet_has_one_set_of_swatches_that_every_layer_fills_from():
    sheet = orb_sheet()
    plain, svg = depixel.convert(sheet, sheet="auto"), depixel.convert(sheet, sheet="auto", swatches=True)
    root = ET.fromstring(svg)
    assert_ids_unique(svg)
    defs = root.find(f"{SVG}defs")
    assert defs is not None and len(list(root.iter(f"{SVG}linearGradient"))) == len(defs) > 0  # in the file's defs
    found = swatches(svg)
    assert sorted(found.values()) == sorted(hexes(sheet))
    assert list(found) == [f"pal-{n:02d}-{colour[1:]}" for n, colour in enumerate(found.values())]  # the file's order
    layers = [g for g in root if g.tag == f"{SVG}g"]
    assert len(layers) == 3
    for layer in layers:  # both sprites fill from the shared swatches
        used = filled_from(ET.tostring(layer, encoding="unicode"))
        assert used and used <= set(found)
    for draw in (lambda s: resvg(s, 52 * 6), lambda s: render_rgba(s, width=52 * 6).astype(int)):
        np.testing.assert_array_equal(draw(svg), draw(plain))
    edited = svg.replace("stop-color:#181425;", "stop-color:#20c040;")
    swapped = depixel.convert(sheet, sheet="auto", palette_map=EDIT)  # both sprites' outlines
    np.testing.assert_array_equal(resvg(edited, 52 * 6), resvg(swapped, 52 * 6))
    for fmt in ("pdf", "eps", "png"):  # drawn without swatches
        assert depixel.convert_bytes(sheet, fmt, sheet="auto", swatches=True) == \
            depixel.convert_bytes(sheet, fmt, sheet="auto"), fmt


def test_a_palette_map_recolours_a_sheet_and_keeps_its_shapes():
    sheet = orb_sheet()
    plain, svg = depixel.convert(sheet, sheet="auto"), depixel.convert(sheet, sheet="auto", palette_map=SWAP)
    assert re.findall(r' d="[^"]*"', svg) == re.findall(r' d="[^"]*"', plain)
    assert "#181425" in plain and "#181425" not in svg and "#20c040" in svg


def test_a_sheet_is_an_eps_drawn_flat_and_its_translucent_sprite_is_named(tmp_path, capsys):
    sheet = orb_sheet()
    eps = depixel.convert_bytes(sheet, "eps", sheet="auto", scale=4)
    assert eps.startswith(b"%!PS-Adobe-3.0 EPSF-3.0\n") and b"%%BoundingBox: 0 0 156 48\n" in eps  # 208 x 64 px
    assert IMAGE_OPERATORS.search(page(eps)) is None
    assert eps == depixel.convert_bytes(sheet, "eps", sheet="auto", scale=4, shading="flat")
    mixed = np.zeros((16, 30, 4), np.uint8)
    mixed[:, :16], mixed[2:14, 18:] = sheet[:, :16], POTION  # the potion is half transparent inside
    source = tmp_path / "mixed.png"
    Image.fromarray(mixed).save(source)
    with pytest.raises(RenderError, match="sprite sprite2: EPS cannot hold the .* semi-transparent pixels"):
        depixel.convert_bytes(mixed, "eps", sheet="auto")
    assert main(["convert", str(source), "--sheet", "auto", "-o", str(tmp_path / "m.eps")]) == Exit.FAILED
    assert "sprite sprite2: EPS cannot hold" in capsys.readouterr().err and not (tmp_path / "m.eps").exists()
    assert main(["convert", str(source), "--sheet", "auto", "-o", str(tmp_path / "m.eps"), "-q",
                 "--background", "white"]) == Exit.OK


# --- palettes written out, one set of swatches per file ----------------------------------------

@pytest.mark.parametrize("kind", ["animate", "sheet"])
def test_the_exported_palette_is_the_file_s_swatches(kind, tmp_path):
    if kind == "animate":  # the first frame has yellow, the others red and blue
        source, extra = tmp_path / "walk.gif", ["--animate"]
        source.write_bytes(walk_gif())
    else:
        source, extra = tmp_path / "sheet.png", ["--sheet", "auto"]
        Image.fromarray(orb_sheet()).save(source)
    out = tmp_path / "out.svg"
    assert main(["convert", str(source), "-o", str(out), "--swatches", "--export-palette", str(tmp_path / "p.gpl"),
                 "-q", *extra]) == Exit.OK
    exported = read_palette(tmp_path / "p.gpl")
    assert [(e.name, "#" + bytes(e.rgba[:3]).hex()) for e in exported.entries] == \
        list(swatches(out.read_text()).items())


def test_shared_swatches_keep_one_of_each_and_rename_a_clash():
    def document(*pairs: tuple[str, str]) -> str:
        defs = "".join(f'<linearGradient id="{i}" inkscape:swatch="solid"><stop offset="0" '
                       f'style="stop-color:{c};stop-opacity:1"/></linearGradient>\n' for i, c in pairs)
        paths = "".join(f'<path fill="url(#{i}) {c}" d="M0 0h1v1z"/>\n' for i, c in pairs)
        return f"<svg>\n<defs>\n{defs}</defs>\n{paths}</svg>\n"

    shared = SharedSwatches()
    first = shared.take(document(("red", "#ff0000"), ("ink", "#000000")))
    second = shared.take(document(("ink", "#000000"), ("red", "#ff0001")))  # the same ink; another red
    assert "<defs>" not in first + second and len(shared.lines) == 3
    assert swatches("".join(shared.lines)) == {"red": "#ff0000", "ink": "#000000", "red-2": "#ff0001"}
    assert 'fill="url(#red) #ff0000"' in first and 'fill="url(#red-2) #ff0001"' in second
    assert 'fill="url(#ink) #000000"' in second


# --- depixel render ----------------------------------------------------------------------------

def test_render_writes_eps(tmp_path):
    svg = tmp_path / "heart.svg"
    svg.write_text(depixel.convert(load(FIXTURES / "heart.png"), shading="flat"))
    assert main(["render", str(svg), "-o", str(tmp_path / "heart.eps"), "--width", "80"]) == Exit.OK
    eps = (tmp_path / "heart.eps").read_bytes()
    assert eps == render(svg.read_text(), "eps", size=(80, None), name=str(svg))
    assert eps.startswith(b"%!PS-Adobe-3.0 EPSF-3.0\n") and b"%%BoundingBox: 0 0 60 60\n" in eps
