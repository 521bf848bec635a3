"""Sprite sheets: finding the sprites (depixel/prepare/sheet.py) and reading the Aseprite and
TexturePacker JSON beside a sheet (depixel/prepare/sheet_json.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from depixel.errors import InputError, ParameterError
from depixel.prepare.sheet import background_of, find_sprites, grid_sprites, parse_grid
from depixel.prepare.sheet_json import parse_sheet_json

CLEAR = (0, 0, 0, 0)


def make_sheet(columns, rows, cell, gap, draw, margin=(0, 0), background=CLEAR) -> np.ndarray:
    """A sheet of ``columns`` × ``rows`` cells of ``cell`` (w, h), ``gap`` between, ``margin``
    around; ``draw(view, row, col)`` paints each cell."""
    width = 2 * margin[0] + columns * cell[0] + (columns - 1) * gap
    height = 2 * margin[1] + rows * cell[1] + (rows - 1) * gap
    sheet = np.empty((height, width, 4), np.uint8)
    sheet[...] = background
    for row in range(rows):
        for col in range(columns):
            x, y = margin[0] + col * (cell[0] + gap), margin[1] + row * (cell[1] + gap)
            draw(sheet[y:y + cell[1], x:x + cell[0]], row, col)
    return sheet


def fill(view, row, col):
    view[...] = (200, 20 * row, 20 * col, 255)


def centred(view, row, col):
    """A sprite in the middle of its cell, a little smaller in some cells."""
    h, w = view.shape[:2]
    view[h // 4:h - h // 4 - row % 2, w // 4 + col % 2:w - w // 4] = (200, 20 * row, 20 * col, 255)


def rects(sheet):
    return [(s.name, s.x, s.y, s.width, s.height) for s in sheet.sprites]


# ---------------------------------------------------------------- grids found

def test_grid_with_transparent_gutters():
    found = find_sprites(make_sheet(3, 2, (32, 32), 2, fill))
    assert found.description == "6 sprites in 3 columns × 2 rows, 32×32 cells, 2-px gutters"
    assert rects(found)[:4] == [("r0c0", 0, 0, 32, 32), ("r0c1", 34, 0, 32, 32), ("r0c2", 68, 0, 32, 32),
                                ("r1c0", 0, 34, 32, 32)]
    assert found.background is None


def test_grid_with_a_background_colour():
    found = find_sprites(make_sheet(3, 2, (20, 16), 2, fill, margin=(1, 1), background=(255, 0, 255, 255)))
    assert found.background == (255, 0, 255, 255)
    assert found.description == ("6 sprites in 3 columns × 2 rows, 20×16 cells, 2-px gutters, offset 1,1, "
                                 "background #ff00ff")
    assert rects(found)[4] == ("r1c1", 23, 19, 20, 16)


def test_sprites_centred_in_cells_take_their_whole_cell():
    touching = find_sprites(make_sheet(3, 2, (32, 32), 0, centred))
    assert touching.description == "6 sprites in 3 columns × 2 rows, 32×32 cells, no gutters"
    apart = find_sprites(make_sheet(4, 3, (16, 24), 1, centred, margin=(3, 3)))
    assert apart.description == "12 sprites in 4 columns × 3 rows, 16×24 cells, 1-px gutters, offset 3,3"
    assert rects(apart)[1] == ("r0c1", 20, 3, 16, 24)


def test_empty_cells_are_skipped():
    def some(view, row, col):
        if (row + col) % 2 == 0:
            fill(view, row, col)
    found = find_sprites(make_sheet(3, 2, (10, 10), 2, some))
    assert [s.name for s in found.sprites] == ["r0c0", "r0c2", "r1c1"]
    assert found.description == "3 sprites in 3 columns × 2 rows, 10×10 cells, 2-px gutters, 3 empty cells skipped"


def test_the_sprites_found_cover_every_pixel_and_cut_no_sprite():
    rng = np.random.default_rng(7)
    for _ in range(25):
        columns, rows = rng.integers(1, 5, 2)
        cell = tuple(int(v) for v in rng.integers(4, 14, 2))
        gap = int(rng.integers(0, 4))

        def blobs(view, row, col):
            mask = rng.random(view.shape[:2]) < 0.3
            view[mask] = (255, 255, 255, 255)
        sheet = make_sheet(int(columns), int(rows), cell, gap, blobs, margin=tuple(rng.integers(0, 3, 2)))
        found = find_sprites(sheet)
        covered = np.zeros(sheet.shape[:2], int)
        for sprite in found.sprites:
            covered[sprite.box] += 1
        assert covered.max() <= 1, found.description  # no two rectangles overlap
        assert (covered[sheet[..., 3] > 0] == 1).all(), found.description  # every sprite pixel in one
        for sprite in found.sprites:  # no 8-connected sprite reaches out of its rectangle
            ring = np.zeros(sheet.shape[:2], bool)
            y0, y1 = max(sprite.y - 1, 0), min(sprite.y + sprite.height + 1, sheet.shape[0])
            x0, x1 = max(sprite.x - 1, 0), min(sprite.x + sprite.width + 1, sheet.shape[1])
            ring[y0:y1, x0:x1] = True
            ring[sprite.box] = False
            inside = np.zeros_like(ring)
            inside[sprite.box] = sheet[sprite.box][..., 3] > 0
            grown = inside.copy()
            grown[1:] |= inside[:-1]
            grown[:-1] |= inside[1:]
            grown[:, 1:] |= grown[:, :-1]
            grown[:, :-1] |= grown[:, 1:]
            assert not (grown & ring & (sheet[..., 3] > 0)).any(), found.description


# ---------------------------------------------------------------- irregular packing

def test_irregular_packing_falls_back_to_bounding_boxes():
    sheet = np.zeros((40, 60, 4), np.uint8)
    for i, (x, y, w, h) in enumerate([(1, 2, 10, 14), (13, 1, 20, 8), (13, 12, 6, 6), (36, 3, 22, 30),
                                      (2, 20, 9, 18), (14, 22, 18, 16)]):
        sheet[y:y + h, x:x + w] = (50 + 20 * i, 0, 0, 255)
    found = find_sprites(sheet)
    assert found.grid is None
    assert found.description == "6 sprites apart (no regular grid): the bounding boxes of connected pixels"
    assert rects(found) == [("sprite1", 13, 1, 20, 8), ("sprite2", 1, 2, 10, 14), ("sprite3", 36, 3, 22, 30),
                            ("sprite4", 13, 12, 6, 6), ("sprite5", 2, 20, 9, 18), ("sprite6", 14, 22, 18, 16)]


def test_diagonal_pixels_are_one_sprite_and_a_part_inside_a_box_joins_it():
    sheet = np.zeros((12, 30, 4), np.uint8)
    for i in range(5):
        sheet[i, i] = 255  # a diagonal line: 8-connected
    sheet[1:9, 12:20] = 255
    sheet[3:6, 14:17] = 0
    sheet[4, 15] = 255  # an eye apart inside the ring
    sheet[10, 2] = 255  # a dot under the line: the grid's first cell would hold two sprites
    found = find_sprites(sheet)
    assert found.grid is None
    assert rects(found) == [("sprite1", 0, 0, 5, 5), ("sprite2", 12, 1, 8, 8), ("sprite3", 2, 10, 1, 1)]


def test_a_strip_of_frames_is_a_grid_even_with_detached_parts():
    def spark(view, row, col):
        view[2:6, 2:6] = 255
        view[7, col % 3] = 255  # a spark apart from the frame's body
    found = find_sprites(make_sheet(4, 1, (8, 8), 1, spark))
    assert found.grid is not None and [s.name for s in found.sprites] == ["r0c0", "r0c1", "r0c2", "r0c3"]
    assert len(find_sprites(make_sheet(3, 1, (8, 8), 1, spark)).sprites) == 6  # under GRID_TRUSTED: apart


def test_background_is_transparency_or_the_colour_of_the_gutters():
    sheet = make_sheet(2, 2, (4, 4), 1, fill, background=(9, 9, 9, 255))
    assert background_of(sheet) == (9, 9, 9, 255)
    sheet[0, 0, 3] = 0
    assert background_of(sheet) is None


# ---------------------------------------------------------------- grids by size

def test_grid_by_size_gap_and_offset():
    sheet = make_sheet(3, 2, (8, 6), 2, fill, margin=(1, 2))
    found = grid_sprites(sheet, "8x6+2@1,2")
    assert rects(found)[:2] == [("r0c0", 1, 2, 8, 6), ("r0c1", 11, 2, 8, 6)] and len(found.sprites) == 6
    assert parse_grid("32x16") == ((32, 16), (0, 0), (0, 0))
    assert parse_grid("32X16+2,3@4,5") == ((32, 16), (2, 3), (4, 5))
    blank = np.zeros((16, 16, 4), np.uint8)
    blank[0:8, 8:16] = 255
    assert [s.name for s in grid_sprites(blank, "8x8").sprites] == ["r0c1"]


@pytest.mark.parametrize("spec", ["", "32", "0x8", "8x8+", "8x8+-1", "8x8@1", "axb", "8x8+1,2,3"])
def test_bad_grid_specs_are_one_line(spec):
    with pytest.raises(ParameterError, match="expected WxH") as info:
        parse_grid(spec)
    assert info.value.parameter == "sheet"


def test_a_grid_larger_than_the_sheet_is_refused():
    with pytest.raises(ParameterError, match="no whole 64x64 cell fits the 16x16 sheet"):
        grid_sprites(np.zeros((16, 16, 4), np.uint8), "64x64")


# ---------------------------------------------------------------- JSON

def frame(x, y, w, h, **extra):
    return {"frame": {"x": x, "y": y, "w": w, "h": h}, "rotated": False, "trimmed": False,
            "spriteSourceSize": {"x": 0, "y": 0, "w": w, "h": h}, "sourceSize": {"w": w, "h": h}, **extra}


def test_texturepacker_hash():
    document = {"frames": {"hero/idle.png": frame(0, 0, 16, 16), "hero/run.png": frame(16, 0, 16, 16)},
                "meta": {"app": "https://www.codeandweb.com/texturepacker", "size": {"w": 32, "h": 16}}}
    sheet = parse_sheet_json(json.dumps(document), (32, 16))
    assert rects(sheet) == [("hero/idle", 0, 0, 16, 16), ("hero/run", 16, 0, 16, 16)]
    assert sheet.description == "2 sprites from the TexturePacker hash"


def test_aseprite_array_with_durations_tags_and_slices():
    document = {"frames": [dict(frame(0, 0, 8, 8, duration=100), filename="walk 0.aseprite"),
                           dict(frame(8, 0, 8, 8, duration=150), filename="walk 1.aseprite"),
                           dict(frame(16, 0, 8, 8, duration=90), filename="walk 1.aseprite")],
                "meta": {"app": "https://www.aseprite.org/", "frameTags": [
                    {"name": "step", "from": 0, "to": 1, "direction": "pingpong", "color": "#000000ff"},
                    {"name": "back", "from": 2, "to": 2, "direction": "pingpong_reverse", "repeat": "3"}],
                    "slices": [{"name": "hit", "color": "#0000ffff",
                                "keys": [{"frame": 0, "bounds": {"x": 1, "y": 2, "w": 3, "h": 4}}]}]}}
    sheet = parse_sheet_json(json.dumps(document).encode(), (24, 8))
    assert [(s.name, s.duration) for s in sheet.sprites] == [("walk 0", 100), ("walk 1", 150), ("walk 1-2", 90)]
    assert [(t.name, t.first, t.last, t.direction, t.repeat) for t in sheet.tags] == [
        ("step", 0, 1, "pingpong", 0), ("back", 2, 2, "pingpong reverse", 3)]
    assert sheet.slices[0].name == "hit" and sheet.slices[0].keys[0].width == 3
    assert sheet.description == "3 sprites from the Aseprite array, 2 tags"


def test_aseprite_hash_with_trimmed_frames():
    trimmed = frame(0, 0, 5, 6, duration=100, trimmed=True)
    trimmed["spriteSourceSize"] = {"x": 2, "y": 1, "w": 5, "h": 6}
    trimmed["sourceSize"] = {"w": 16, "h": 16}
    sheet = parse_sheet_json({"frames": {"a.png": trimmed}, "meta": {"app": "http://www.aseprite.org/"}})
    assert sheet.sprites[0].trim == (2, 1, 16, 16) and sheet.description == "1 sprite from the Aseprite hash"


@pytest.mark.parametrize("document, message", [
    ("{not json", "not JSON"),
    ({"meta": {}}, "no \"frames\" hash or array"),
    ({"frames": {"a.png": frame(0, 0, 8, 8, rotated=True)}}, "frame 'a.png' is rotated on the sheet"),
    ({"frames": {"a.png": frame(20, 0, 8, 8)}}, r"frame 'a.png' at 20,0 8x8 runs past the 24x8 sheet"),
    ({"frames": {"a.png": {"frame": {"x": 0, "y": 0, "w": "8", "h": 8}}}}, "frame 'a.png' has no 'w'"),
    ({"frames": {"a.png": frame(0, 0, 0, 8)}}, "is empty"),
    ({"frames": [{"frame": {}}]}, "frame 0 has no 'filename'"),
    ({"frames": {"a.png": frame(0, 0, 8, 8)}, "meta": {"frameTags": [{"name": "t", "from": 0, "to": 3}]}},
     "tag 't' runs from frame 0 to 3"),
    ({"frames": {"a.png": frame(0, 0, 8, 8, duration=-5)}}, "duration of -5"),
])
def test_bad_json_is_one_line(document, message):
    text = document if isinstance(document, str) else json.dumps(document)
    with pytest.raises(InputError, match=message) as info:
        parse_sheet_json(text, (24, 8), name="hero.json")
    assert str(info.value).startswith("hero.json: ") and "\n" not in str(info.value)
