"""Palettes (issue 43, docs/palettes.md): GIMP palette files in and out, Inkscape swatches,
palette swaps that keep the shapes, an Aseprite input's names."""
from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from aseprite_writer import one_layer, palette_chunk
from conftest import FIXTURES, art
from PIL import Image

import depixel
from depixel.errors import ParameterError
from depixel.files.palette import export_palette, palette_of
from depixel.options import ConvertOptions
from depixel.prepare.gpl import Palette, PaletteEntry, PaletteMap, as_palette_map, format_gpl, parse_gpl, read_palette
from depixel.render.raster import render_rgba
from depixel_cli.main import main
from depixel_cli.options import Exit

resvg_py = pytest.importorskip("resvg_py")

SVG = "{http://www.w3.org/2000/svg}"
INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"
#: a sprite with a shaded region (r, a lighter red s, y) inside a black outline, on white;
#: r and s cross in a checker, which the similarity of their colours resolves
SPRITE = art("""
    ........
    .######.
    .#rsss#.
    .#sryy#.
    .#ssyy#.
    .######.
    ........
""", {"s": (235, 70, 60, 255)})
RED, LIGHT, YELLOW, BLACK, WHITE = (220, 30, 30), (235, 70, 60), (240, 220, 40), (0, 0, 0), (255, 255, 255)


def fills(svg: str) -> list[tuple[str, str]]:
    """(fill, d) of every path."""
    return [(p.get("fill"), p.get("d")) for p in ET.fromstring(svg).iter(f"{SVG}path")]


def resvg(svg: str, width: int, height: int) -> np.ndarray:
    png = resvg_py.svg_to_bytes(svg_string=svg, width=width, height=height)
    return np.asarray(Image.open(io.BytesIO(bytes(png))).convert("RGBA")).astype(np.int64)


def renders(svg: str, scale: int = 8) -> dict[str, np.ndarray]:
    h, w = SPRITE.shape[:2]
    return {"cairosvg": render_rgba(svg, width=w * scale, height=h * scale).astype(np.int64),
            "resvg": resvg(svg, w * scale, h * scale)}


def palette(*colours: tuple[int, ...], alpha: bool = False) -> Palette:
    return Palette(tuple(PaletteEntry(tuple(c) if len(c) == 4 else (*c, 255)) for c in colours), alpha=alpha)


# --- GIMP palette files ---------------------------------------------------------------------

GPL = """GIMP Palette
Name: Sunset
Columns: 4
# made by hand
# with two comments

255   0   0\tRed
  0 128 255\tSky blue
 10  20  30\tUntitled
  1   2   3   4 AM
"""


def test_a_gimp_palette_is_read_with_its_names_and_comments_left_out():
    read = parse_gpl(GPL)
    assert read.name == "Sunset" and read.columns == 4 and not read.alpha
    assert [e.rgba for e in read.entries] == [(255, 0, 0, 255), (0, 128, 255, 255), (10, 20, 30, 255),
                                              (1, 2, 3, 255)]
    assert [e.name for e in read.entries] == ["Red", "Sky blue", None, "4 AM"]  # GIMP's "Untitled": none


def test_gpl_round_trip_with_names_comments_and_aseprite_rgba(tmp_path):
    rgba = Palette((PaletteEntry((255, 0, 0, 128), "half red"), PaletteEntry((0, 0, 0, 255)),
                    PaletteEntry((9, 8, 7, 0), "clear")), "with alpha", 2, alpha=True)
    text = format_gpl(rgba)
    assert "Channels: RGBA" in text and text.startswith("GIMP Palette\n")
    assert parse_gpl(text) == rgba
    (tmp_path / "p.gpl").write_text(text)
    assert read_palette(tmp_path / "p.gpl") == rgba
    commented = parse_gpl(GPL)
    assert parse_gpl(format_gpl(commented)) == commented
    assert format_gpl(parse_gpl(format_gpl(commented))) == format_gpl(commented)  # a fixed point


@pytest.mark.parametrize("text, message", [
    ("JASC-PAL\n0100\n", "not a GIMP palette (the first line must be 'GIMP Palette')"),
    ("GIMP Palette\n255 0 0 red\n300 0 0 bad\n", "line 3: expected 'R G B name' with numbers from 0 to 255"),
    ("GIMP Palette\n255 0\n", "line 2: expected 'R G B name'"),
    ("GIMP Palette\nChannels: RGBA\n255 0 0 red\n", "line 3: expected 'R G B A name'"),
    ("GIMP Palette\nChannels: CMYK\n", "line 2: Channels must be RGB or RGBA, not 'CMYK'"),
    ("GIMP Palette\nColumns: four\n", "line 2: Columns must be a number"),
])
def test_a_malformed_palette_is_one_line_naming_the_file_and_line(text, message):
    with pytest.raises(ParameterError) as caught:
        parse_gpl(text, "p.gpl")
    assert str(caught.value).startswith(f"p.gpl: {message}"), str(caught.value)
    assert "\n" not in str(caught.value)


def test_the_command_line_says_a_bad_palette_in_one_line_and_writes_nothing(tmp_path, capsys):
    (tmp_path / "bad.gpl").write_text("GIMP Palette\n1 2 three\n")
    out = tmp_path / "out.svg"
    code = main(["convert", str(FIXTURES / "heart.png"), "-o", str(out), "--swatches", "--palette",
                 str(tmp_path / "bad.gpl")])
    err = capsys.readouterr().err
    assert code != Exit.OK and not out.exists()
    assert [line for line in err.splitlines() if line] == [
        f"depixel: error: {tmp_path / 'bad.gpl'}: line 2: expected 'R G B name' with numbers from 0 to 255, "
        "not '1 2 three'"], err


# --- swatches --------------------------------------------------------------------------------

def test_every_colour_is_one_inkscape_swatch_and_every_shape_fills_from_it():
    plain = depixel.convert(SPRITE)
    svg = depixel.convert(SPRITE, swatches=True)
    root = ET.fromstring(svg)
    swatches = {g.get("id"): g for g in root.iter(f"{SVG}linearGradient")}
    assert all(g.get(f"{INKSCAPE}swatch") == "solid" for g in swatches.values())
    stops = {ident: g.find(f"{SVG}stop").get("style") for ident, g in swatches.items()}
    assert sorted(stops.values()) == sorted(f"stop-color:#{bytes(c).hex()};stop-opacity:1"
                                            for c in (RED, LIGHT, YELLOW, BLACK, WHITE))
    assert list(swatches) == ["pal-00-ffffff", "pal-01-000000", "pal-02-dc1e1e", "pal-03-eb463c", "pal-04-f0dc28"]
    for (fill, d), (plain_fill, plain_d) in zip(fills(svg), fills(plain), strict=True):
        ident, colour = re.fullmatch(r"url\(#([^)]+)\) (#[0-9a-f]{6})", fill).groups()
        assert colour == plain_fill and stops[ident].startswith(f"stop-color:{colour};")
        assert d == plain_d
    assert svg.count("<defs>") == 1  # the swatches share the smooth shading's <defs>


@pytest.mark.parametrize("shading", ["smooth", "flat"])
def test_swatches_render_as_the_plain_colours(shading):
    plain = renders(depixel.convert(SPRITE, shading=shading))
    swatched = renders(depixel.convert(SPRITE, shading=shading, swatches=True))
    for renderer in plain:
        assert np.array_equal(plain[renderer], swatched[renderer]), renderer


def test_a_semi_transparent_colour_is_its_swatch_s_opacity():
    image = np.asarray(Image.open(FIXTURES / "potion_rgba.png").convert("RGBA"))
    plain, svg = depixel.convert(image, shading="flat"), depixel.convert(image, shading="flat", swatches=True)
    assert 'stop-opacity:0.502"' in svg and "fill-opacity" not in svg  # the swatch holds it, once
    h, w = image.shape[:2]
    for name, draw in (("cairosvg", lambda s: render_rgba(s, width=w * 8).astype(int)),
                       ("resvg", lambda s: resvg(s, w * 8, h * 8))):
        assert np.array_equal(draw(plain), draw(svg)), name


@pytest.mark.parametrize("shading", ["smooth", "flat"])
def test_editing_one_swatch_recolours_exactly_its_shapes_and_tones(shading):
    svg = depixel.convert(SPRITE, shading=shading, swatches=True)
    edited = svg.replace("stop-color:#eb463c;", "stop-color:#3c46eb;")  # the lighter red, a tone of the shading
    assert edited != svg
    # the same as converting with that one colour swapped: every shape of the colour and its
    # tone in the smooth shading, and nothing else
    swapped = depixel.convert(SPRITE, shading=shading, palette_map=([(*LIGHT, 255)], [(60, 70, 235, 255)]))
    before, after, expected = renders(svg), renders(edited), renders(swapped)
    for renderer in before:
        assert np.array_equal(after[renderer], expected[renderer]), renderer
    # flat: the pixel centres of that colour changed, no other did
    if shading == "flat":
        light = (SPRITE[..., :3] == LIGHT).all(axis=-1)
        for renderer, image in after.items():
            centres, old = image[4::8, 4::8], before[renderer][4::8, 4::8]
            assert (np.abs(centres[light][:, :3] - (60, 70, 235)) <= 8).all(), renderer
            assert np.array_equal(centres[~light], old[~light]), renderer


def test_a_palette_names_the_swatches_and_odd_names_become_ids():
    names = Palette((PaletteEntry((*RED, 255), "Dark Red"), PaletteEntry((*YELLOW, 255), "outline"),
                     PaletteEntry((*BLACK, 255), "9 lives"), PaletteEntry((*WHITE, 255), "Dark Red"),
                     PaletteEntry((1, 2, 3, 255), "unused")))
    root = ET.fromstring(depixel.convert(SPRITE, swatches=True, palette=names))
    swatches = [(g.get("id"), g.get(f"{INKSCAPE}label")) for g in root.iter(f"{SVG}linearGradient")]
    # the palette's colours first, in its order; an id the document uses or one that starts
    # with a digit gets "swatch-"; a name twice gets -2
    assert swatches == [("Dark-Red", "Dark Red"), ("swatch-outline", "outline"), ("swatch-9-lives", "9 lives"),
                        ("Dark-Red-2", "Dark Red"), ("pal-04-eb463c", None)]
    ids = [e.get("id") for e in root.iter() if e.get("id")]
    assert len(ids) == len(set(ids))


def test_an_aseprite_input_names_its_swatches(tmp_path):
    colours = np.array([[0, 0, 0, 0], [*BLACK, 255], [*RED, 255], [*WHITE, 255]], np.uint8)
    source = tmp_path / "sprite.aseprite"
    source.write_bytes(one_layer(SPRITE, first_chunks=[palette_chunk(colours, {1: "Ink", 2: "Blood"})]))
    depixel.convert_file(source, tmp_path / "sprite.svg", swatches=True)
    ids = [g.get("id") for g in ET.parse(tmp_path / "sprite.svg").getroot().iter(f"{SVG}linearGradient")]
    assert ids == ["Ink", "Blood", "pal-02-ffffff", "pal-03-eb463c", "pal-04-f0dc28"]


# --- palette swaps ---------------------------------------------------------------------------

FROM = palette(RED, LIGHT, YELLOW, (9, 9, 9))
#: the lighter red becomes a green, which is not similar to the blue the red becomes: shapes
#: drawn from the swapped colours would differ
TO = palette((30, 60, 220), (40, 200, 90), (130, 240, 250), (1, 1, 1))


@pytest.mark.parametrize("shading", ["smooth", "flat"])
@pytest.mark.parametrize("layout", ["stacked", "cutout"])
def test_a_palette_map_keeps_the_path_data_and_swaps_every_fill(shading, layout):
    plain = fills(depixel.convert(SPRITE, shading=shading, layout=layout))
    swapped = fills(depixel.convert(SPRITE, shading=shading, layout=layout, palette_map=PaletteMap(FROM, TO)))
    assert [d for _, d in swapped] == [d for _, d in plain]  # the shapes of the art's own colours
    table = {f"#{bytes(a.rgba[:3]).hex()}": f"#{bytes(b.rgba[:3]).hex()}" for a, b in zip(FROM.entries, TO.entries)}
    assert [f for f, _ in swapped] == [table.get(f, f) for f, _ in plain]  # black and white stay
    assert {f for f, _ in plain} - set(table) == {"#000000", "#ffffff"}


def test_a_palette_map_onto_one_colour_keeps_the_shapes_apart():
    merge = PaletteMap(palette(RED, LIGHT), palette(YELLOW, YELLOW))
    plain, swapped = fills(depixel.convert(SPRITE)), fills(depixel.convert(SPRITE, palette_map=merge))
    assert [d for _, d in swapped] == [d for _, d in plain]
    assert [f for f, _ in swapped].count("#f0dc28") == sum(f in ("#dc1e1e", "#eb463c", "#f0dc28") for f, _ in plain) > 3


def test_the_smooth_png_swaps_its_colours_on_the_same_cells():
    scale = 9
    plain = depixel.convert_bytes(SPRITE, "png", scale=scale)
    swapped = depixel.convert_bytes(SPRITE, "png", scale=scale, palette_map=PaletteMap(FROM, TO))
    a, b = (np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(int) for png in (plain, swapped))
    # where the art is flat (a pixel and its 8 neighbours of one colour) the centre is the swapped colour
    h, w = SPRITE.shape[:2]
    for y in range(1, h - 1):
        for x in range(1, w - 1):
            block = SPRITE[y - 1 : y + 2, x - 1 : x + 2, :3].reshape(-1, 3)
            if (block == block[0]).all():
                own = tuple(int(v) for v in SPRITE[y, x, :3])
                sources = [e.rgba[:3] for e in FROM.entries]
                want = TO.entries[sources.index(own)].rgba[:3] if own in sources else own
                assert tuple(b[y * scale + 4, x * scale + 4, :3]) == want
    assert not np.array_equal(a, b)


@pytest.mark.parametrize("fmt", ["svg", "png", "pdf", "eps"])
def test_a_palette_map_of_a_palette_onto_itself_changes_no_byte(fmt):
    same = PaletteMap(FROM, FROM)
    assert depixel.convert_bytes(SPRITE, fmt, palette_map=same) == depixel.convert_bytes(SPRITE, fmt)
    assert depixel.convert_bytes(SPRITE, fmt, palette_map=PaletteMap(FROM, TO)) != depixel.convert_bytes(SPRITE, fmt)


def test_palettes_of_different_sizes_are_one_clear_error(tmp_path, capsys):
    with pytest.raises(ParameterError, match=r"the palettes differ in size \(4 colours to 3\)"):
        PaletteMap(FROM, palette(RED, RED, RED))
    (tmp_path / "a.gpl").write_text(format_gpl(FROM))
    (tmp_path / "b.gpl").write_text(format_gpl(palette(RED)))
    code = main(["convert", str(FIXTURES / "heart.png"), "-o", str(tmp_path / "h.svg"), "--palette-map",
                 f"{tmp_path / 'a.gpl'}:{tmp_path / 'b.gpl'}"])
    err = capsys.readouterr().err
    assert code != Exit.OK and not (tmp_path / "h.svg").exists()
    assert err == ("depixel: error: --palette-map: the palettes differ in size (4 colours to 1); a swap maps each "
                   "colour to the one at its place\n")


def test_an_rgba_target_sets_the_opacity_and_an_rgb_one_keeps_it():
    rgba = np.array([[[*RED, 128], [*RED, 255], [*BLACK, 0]]], np.uint8)
    assert PaletteMap(palette(RED), palette(YELLOW)).apply(rgba).tolist() == [[[*YELLOW, 128], [*YELLOW, 255],
                                                                              [*BLACK, 0]]]
    assert PaletteMap(palette(RED), palette((*YELLOW, 40), alpha=True)).apply(rgba)[0, :2, 3].tolist() == [40, 40]
    exact = PaletteMap(palette((*RED, 128), alpha=True), palette((*YELLOW, 128), alpha=True))
    assert exact.apply(rgba)[0, :2, :3].tolist() == [list(YELLOW), list(RED)]  # RGBA palettes match the opacity


def test_the_map_argument_splits_after_a_palette_name(tmp_path):
    (tmp_path / "C:a.gpl").write_text(format_gpl(FROM))
    (tmp_path / "b.gpl").write_text(format_gpl(TO))
    assert as_palette_map(f"{tmp_path / 'C:a.gpl'}:{tmp_path / 'b.gpl'}") == PaletteMap(FROM, TO)
    with pytest.raises(ParameterError, match="palette_map must be FROM.gpl:TO.gpl"):
        as_palette_map("nocolon")


def test_a_batch_recolours_a_whole_set(tmp_path):
    (tmp_path / "in").mkdir()
    for name in ("a.png", "b.png"):
        Image.fromarray(SPRITE if name == "a.png" else SPRITE[::-1].copy()).save(tmp_path / "in" / name)
    (tmp_path / "from.gpl").write_text(format_gpl(FROM))
    (tmp_path / "to.gpl").write_text(format_gpl(TO))
    assert main(["convert", str(tmp_path / "in"), "--out-dir", str(tmp_path / "out"), "-q", "--palette-map",
                 f"{tmp_path / 'from.gpl'}:{tmp_path / 'to.gpl'}", "--format", "svg,png"]) == Exit.OK
    for name in ("a", "b"):
        text = (tmp_path / "out" / f"{name}.svg").read_text()
        assert "#dc1e1e" not in text and 'fill="#1e3cdc"' in text
        assert (tmp_path / "out" / f"{name}.png").exists()
    # up to date on the next run; another TO palette makes them stale
    assert main(["convert", str(tmp_path / "in"), "--out-dir", str(tmp_path / "out"), "--json", "-q",
                 "--palette-map", f"{tmp_path / 'from.gpl'}:{tmp_path / 'to.gpl'}", "--format", "svg,png"]) == 0
    (tmp_path / "to.gpl").write_text(format_gpl(FROM))
    before = (tmp_path / "out" / "a.svg").read_text()
    assert main(["convert", str(tmp_path / "in"), "--out-dir", str(tmp_path / "out"), "-q", "--palette-map",
                 f"{tmp_path / 'from.gpl'}:{tmp_path / 'to.gpl'}"]) == 0
    assert (tmp_path / "out" / "a.svg").read_text() != before


# --- export -----------------------------------------------------------------------------------

def test_the_exported_palette_is_the_picture_s_colours_named_like_its_swatches(tmp_path):
    source = tmp_path / "sprite.png"
    Image.fromarray(SPRITE).save(source)
    assert main(["convert", str(source), "-o", str(tmp_path / "s.svg"), "--swatches", "--export-palette",
                 str(tmp_path / "s.gpl")]) == Exit.OK
    exported = read_palette(tmp_path / "s.gpl")
    ids = [g.get("id") for g in ET.parse(tmp_path / "s.svg").getroot().iter(f"{SVG}linearGradient")]
    assert [e.name for e in exported.entries] == ids and exported.name == "sprite"
    assert [e.rgba[:3] for e in exported.entries] == [WHITE, BLACK, RED, LIGHT, YELLOW]
    # named again with it, the swatches keep their ids; swapped, the palette is the TO colours
    # (the map's palette first, in its order: it names them)
    assert depixel.convert(SPRITE, swatches=True, palette=exported) == depixel.convert(SPRITE, swatches=True)
    swapped = palette_of(SPRITE, ConvertOptions.build(palette_map=PaletteMap(FROM, TO)))
    assert [e.rgba[:3] for e in swapped.entries] == [(30, 60, 220), (40, 200, 90), (130, 240, 250), WHITE, BLACK]
    export_palette(source, tmp_path / "again.gpl")
    assert (tmp_path / "again.gpl").read_text() == (tmp_path / "s.gpl").read_text()


def test_export_palette_takes_one_input(tmp_path, capsys):
    for name in ("a.png", "b.png"):
        Image.fromarray(SPRITE).save(tmp_path / name)
    code = main(["convert", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "--out-dir", str(tmp_path / "o"),
                 "-q", "--export-palette", str(tmp_path / "p.gpl")])
    assert code == Exit.FAILED and not (tmp_path / "p.gpl").exists()
    assert "--export-palette writes the palette of one input, not of 2" in capsys.readouterr().err


def test_the_command_line_builds_the_palette_options(tmp_path):
    from depixel_cli.main import build_parser
    from depixel_cli.options import convert_options

    (tmp_path / "a.gpl").write_text(format_gpl(FROM))
    (tmp_path / "b.gpl").write_text(format_gpl(TO))
    args = build_parser("convert").parse_args(["convert", "a.png", "--swatches", "--palette", str(tmp_path / "b.gpl"),
                                               "--palette-map", f"{tmp_path / 'a.gpl'}:{tmp_path / 'b.gpl'}"])
    assert convert_options(args) == ConvertOptions.build(swatches=True, palette=TO, palette_map=PaletteMap(FROM, TO))


def test_the_swatched_svg_passes_the_svg11_full_validator():
    from svgwrite.validator2 import get_validator

    image = np.asarray(Image.open(FIXTURES / "potion_rgba.png").convert("RGBA"))
    root = ET.fromstring(depixel.convert(image, swatches=True, palette=[(0, 0, 0)]))
    validator = get_validator("full", debug=True)
    ids = {element.get("id") for element in root.iter()}
    for element in root.iter():
        name = element.tag.removeprefix(SVG)
        for child in element:
            assert validator.is_valid_children(name, child.tag.removeprefix(SVG)), (name, child.tag)
        for attribute, value in element.attrib.items():
            if not attribute.startswith("{") and not (name == "path" and attribute == "d"):
                validator.check_svg_attribute_value(name, attribute, value)  # raises on a bad value
            if "url(" in value:
                assert re.fullmatch(r"url\(#([^)]+)\)( #[0-9a-f]{6})?", value).group(1) in ids
