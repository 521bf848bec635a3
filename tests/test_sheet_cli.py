"""Sprite sheets through the command (issue 42): ``--sheet auto``, ``--sheet WxH+GAP@X,Y`` and
``--sheet-json FILE`` write one SVG with a layer per sprite (``-o``) or a file per sprite
(``--out-dir``, ``--name {sprite}``); each sprite is its crop's own conversion, moved to its
place. The sheets are made here from the project's fixtures."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image

import depixel
from depixel import load_image
from depixel.render.raster import render_rgba
from depixel_cli.main import main
from depixel_cli.options import Exit

SVG = "{http://www.w3.org/2000/svg}"
INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"
MAGENTA = (255, 0, 255, 255)
#: a 3 × 2 grid of 18 × 16 cells, one left empty
GRID = ["ghost_rgba.png", "potion_rgba.png", "orb.png", "leaf_la.png", None, "heart_trns.png"]


def grid_sheet(names=GRID, cell=(18, 16), gap=2, margin=0, background=(0, 0, 0, 0)) -> np.ndarray:
    """The fixtures ``names`` centred in a grid of 3 columns (None: an empty cell)."""
    rows = -(-len(names) // 3)
    sheet = np.empty((2 * margin + rows * cell[1] + (rows - 1) * gap, 2 * margin + 3 * cell[0] + 2 * gap, 4),
                     np.uint8)
    sheet[...] = background
    for i, name in enumerate(names):
        if name is not None:
            sprite = load_image(FIXTURES / name)
            if background[3]:
                sprite = depixel.flatten(sprite, background[:3])
            x = margin + (i % 3) * (cell[0] + gap) + (cell[0] - sprite.shape[1]) // 2
            y = margin + (i // 3) * (cell[1] + gap) + (cell[1] - sprite.shape[0]) // 2
            sheet[y:y + sprite.shape[0], x:x + sprite.shape[1]] = sprite
    return sheet


@pytest.fixture
def run(tmp_path, monkeypatch, capsys):
    """``run(*args)`` → (exit code, stderr) of ``depixel convert ARGS`` in a scratch folder."""
    monkeypatch.chdir(tmp_path)

    def convert(*args: str) -> tuple[int, str]:
        try:
            code = main(["convert", *map(str, args)])
        except SystemExit as exc:  # a usage error
            code = int(exc.code or 0)
        return code, capsys.readouterr().err

    return convert


def save(rgba: np.ndarray, path: str | Path) -> Path:
    Image.fromarray(rgba, "RGBA").save(path)
    return Path(path)


def unstamped(text: str) -> str:
    """An SVG without its stamp and title (which name the file)."""
    return re.sub(r"<!--.*?-->\n?|<title>.*?</title>\n?", "", text)


def layers_of(svg: str) -> list[ET.Element]:
    return [g for g in ET.fromstring(svg) if g.get(f"{INKSCAPE}groupmode") == "layer"]


def alone(svg: str, keep: int) -> str:
    """The document with every layer but the ``keep``-th removed."""
    root = ET.fromstring(svg)
    for i, layer in enumerate(layers_of(svg)):
        if i != keep:
            root.remove(next(g for g in root if g.get("id") == layer.get("id")))
    return ET.tostring(root, encoding="unicode")


def lone(run, rgba: np.ndarray, name: str, *args: str) -> str:
    """The SVG the command makes of ``rgba`` saved alone as a PNG."""
    assert run(save(rgba, f"{name}.png"), "-o", f"{name}.svg", *args)[0] == Exit.OK
    return Path(f"{name}.svg").read_text()


def assert_layers_are_lone_conversions(run, sheet: np.ndarray, svg: str, boxes) -> None:
    """Each layer: its sprite's lone conversion, the same path data, at its place, and drawn
    alone the same picture there (within the rounding of anti-aliasing)."""
    layers = layers_of(svg)
    assert [g.get(f"{INKSCAPE}label") for g in layers] == [name for name, *_ in boxes]
    zoom = 3
    for i, (name, x, y, w, h) in enumerate(boxes):
        assert layers[i].get("transform") == f"translate({x},{y})"
        own = lone(run, sheet[y:y + h, x:x + w], f"lone-{i}")
        assert [p.get("d") for p in layers[i].iter(f"{SVG}path")] == re.findall(r' d="([^"]*)"', own)
        drawn = render_rgba(alone(svg, i), scale=zoom).astype(int)
        expected = np.zeros_like(drawn)
        expected[y * zoom:(y + h) * zoom, x * zoom:(x + w) * zoom] = render_rgba(own, scale=zoom)
        assert np.abs(drawn - expected).max() <= 2, name


# --- found on the sheet ---------------------------------------------------------------------

def test_sheet_auto_with_transparent_gutters_a_layer_per_sprite(run):
    sheet = grid_sheet()
    save(sheet, "sheet.png")
    code, err = run("sheet.png", "--sheet", "auto", "-o", "sheet.svg")
    assert code == Exit.OK
    assert err == ("depixel: note: sheet.png: 5 sprites in 3 columns × 2 rows, 18×16 cells, 2-px gutters, "
                   "1 empty cell skipped\n")
    svg = Path("sheet.svg").read_text()
    assert ET.fromstring(svg).get("viewBox") == "0 0 58 34"
    boxes = [("r0c0", 0, 0, 18, 16), ("r0c1", 20, 0, 18, 16), ("r0c2", 40, 0, 18, 16), ("r1c0", 0, 18, 18, 16),
             ("r1c2", 40, 18, 18, 16)]
    assert_layers_are_lone_conversions(run, sheet, svg, boxes)
    ids = re.findall(r'\sid="([^"]*)"', svg)
    assert len(ids) == len(set(ids)) and all(ref in ids for ref in re.findall(r"url\(#([^)]*)\)", svg))


def test_sheet_auto_with_a_background_colour(run):
    sheet = grid_sheet(GRID[:3], background=MAGENTA, margin=1)
    save(sheet, "sheet.png")
    code, err = run("sheet.png", "--sheet", "auto", "-o", "sheet.svg")
    assert code == Exit.OK
    # sprites centred in cells that tile the sheet's width get the whole cells
    assert "3 sprites in 3 columns × 1 row, 20×16 cells, no gutters, offset 0,1, background #ff00ff" in err
    boxes = [("r0c0", 0, 1, 20, 16), ("r0c1", 20, 1, 20, 16), ("r0c2", 40, 1, 20, 16)]
    assert_layers_are_lone_conversions(run, sheet, Path("sheet.svg").read_text(), boxes)


def test_irregular_packing_gives_the_boxes_of_connected_sprites(run):
    sheet = np.zeros((30, 40, 4), np.uint8)
    ghost, heart, leaf = (load_image(FIXTURES / n) for n in ("ghost_rgba.png", "heart_trns.png", "leaf_la.png"))
    sheet[0:16, 0:18], sheet[3:13, 25:35], sheet[18:30, 8:20] = ghost, heart, leaf
    save(sheet, "packed.png")
    code, err = run("packed.png", "--sheet", "auto", "-o", "packed.svg")
    assert code == Exit.OK and "3 sprites apart (no regular grid)" in err
    expected = []
    for n, (image, x, y) in enumerate([(ghost, 0, 0), (heart, 25, 3), (leaf, 8, 18)], 1):
        rows, cols = np.nonzero(image[..., 3])  # the box of its pixels
        expected.append((f"sprite{n}", x + cols.min(), y + rows.min(), np.ptp(cols) + 1, np.ptp(rows) + 1))
    assert_layers_are_lone_conversions(run, sheet, Path("packed.svg").read_text(), expected)


# --- a grid by size, a file per sprite ------------------------------------------------------

def test_a_grid_by_size_writes_a_file_per_sprite_each_its_lone_conversion(run):
    sheet = grid_sheet(margin=1)
    save(sheet, "sheet.png")
    code, err = run("sheet.png", "--sheet", "18x16+2@1,1", "--out-dir", "out", "--format", "svg,png")
    assert code == Exit.OK and "1 empty cell skipped" in err
    names = ["r0c0", "r0c1", "r0c2", "r1c0", "r1c2"]  # r1c1 is empty: no file
    assert sorted(p.name for p in Path("out").iterdir()) == sorted(f"sheet-{n}.{f}" for n in names
                                                                   for f in ("svg", "png"))
    for n in names:
        row, col = int(n[1]), int(n[3])
        x, y = 1 + col * 20, 1 + row * 18
        crop = sheet[y:y + 16, x:x + 18]
        assert unstamped(Path(f"out/sheet-{n}.svg").read_text()) == unstamped(lone(run, crop, n))
        assert run(f"{n}.png", "-o", f"{n}-lone.png")[0] == Exit.OK
        assert np.array_equal(load_image(f"out/sheet-{n}.png"), load_image(f"{n}-lone.png"))
    # a second run finds them up to date
    code, err = run("sheet.png", "--sheet", "18x16+2@1,1", "--out-dir", "out", "--format", "svg,png")
    assert code == Exit.OK and "0 converted, 1 up to date" in err


def test_name_places_the_sprite_and_without_it_writes_the_layered_file(run):
    save(grid_sheet(), "sheet.png")
    assert run("sheet.png", "--sheet", "auto", "--out-dir", "a", "--name", "{sprite}-{stem}")[0] == Exit.OK
    assert sorted(p.name for p in Path("a").iterdir()) == [f"{n}-sheet.svg" for n in
                                                           ("r0c0", "r0c1", "r0c2", "r1c0", "r1c2")]
    assert run("sheet.png", "--sheet", "auto", "--out-dir", "b", "--name", "{stem}-all")[0] == Exit.OK
    assert [p.name for p in Path("b").iterdir()] == ["sheet-all.svg"]
    assert len(layers_of(Path("b/sheet-all.svg").read_text())) == 5
    assert run("sheet.png", "--sheet", "auto")[0] == Exit.OK  # beside the input: a file per sprite too
    assert Path("sheet-r1c2.svg").exists() and not Path("sheet.svg").exists()
    code, err = run("sheet.png", "--out-dir", "c", "--name", "{sprite}")
    assert code == Exit.USAGE and "{sprite} names the sprites of --sheet or --sheet-json" in err
    code, err = run("sheet.png", "--sheet", "auto", "--out-dir", "c", "--dry-run")
    assert code == Exit.OK and not Path("c").exists()


def test_the_layered_png_is_each_sprites_png_at_its_place(run):
    sheet = grid_sheet()
    save(sheet, "sheet.png")
    assert run("sheet.png", "--sheet", "auto", "-o", "sheet-2x.png", "--scale", "2")[0] == Exit.OK
    assert run("sheet.png", "--sheet", "auto", "--out-dir", "out", "--format", "png", "--scale", "2")[0] == Exit.OK
    whole = load_image("sheet-2x.png")
    assert whole.shape == (68, 116, 4)
    for n, x, y in [("r0c0", 0, 0), ("r0c2", 40, 0), ("r1c2", 40, 18)]:
        assert np.array_equal(whole[2 * y:2 * y + 32, 2 * x:2 * x + 36], load_image(f"out/sheet-{n}.png"))
    assert not whole[32:36].any()  # the gutter and the empty cell stay transparent
    assert run("sheet.png", "--sheet", "auto", "-o", "sheet.pdf")[0] == Exit.OK
    assert Path("sheet.pdf").read_bytes()[:5] == b"%PDF-"


def test_stdout_takes_the_layered_sheet():
    import subprocess  # noqa: PLC0415
    import sys  # noqa: PLC0415

    png = Image.fromarray(grid_sheet(), "RGBA")
    import io  # noqa: PLC0415

    buffer = io.BytesIO()
    png.save(buffer, format="PNG")
    done = subprocess.run([sys.executable, "-m", "depixel", "convert", "-", "-o", "-", "--sheet", "18x16+2"],
                          input=buffer.getvalue(), capture_output=True, check=False)
    assert done.returncode == 0, done.stderr
    assert len(layers_of(done.stdout.decode())) == 5
    assert b"5 sprites in 3 columns" in done.stderr


# --- the JSON beside the sheet --------------------------------------------------------------

def frame(x, y, w, h, **extra) -> dict:
    return {"frame": {"x": x, "y": y, "w": w, "h": h}, "rotated": False, "trimmed": False,
            "spriteSourceSize": {"x": 0, "y": 0, "w": w, "h": h}, "sourceSize": {"w": w, "h": h}, **extra}


BOXES = [(0, 0), (20, 0), (40, 0)]


@pytest.mark.parametrize("variant", ["aseprite hash", "aseprite array", "texturepacker hash"])
def test_sheet_json_names_the_sprites_after_their_frames(run, variant):
    sheet = grid_sheet(GRID[:3])
    save(sheet, "sheet.png")
    labels = ["walk 0", "walk 1", "walk 2"] if variant.startswith("aseprite") else ["hero/a", "hero/b", "c"]
    frames = [(f"{label}.png", frame(x, y, 18, 16, duration=100)) for label, (x, y) in zip(labels, BOXES)]
    meta = {"app": "http://www.aseprite.org/" if variant.startswith("aseprite") else "https://www.codeandweb.com/"
                   "texturepacker", "size": {"w": 58, "h": 16}}
    if variant == "aseprite array":
        document = {"frames": [{"filename": name, **entry} for name, entry in frames],
                    "meta": {**meta, "frameTags": [{"name": "walk", "from": 0, "to": 2, "direction": "pingpong"}]}}
    else:
        document = {"frames": dict(frames), "meta": meta}
    Path("sheet.json").write_text(json.dumps(document))
    code, err = run("sheet.png", "--sheet-json", "sheet.json", "-o", "sheet.svg")
    assert code == Exit.OK, err
    maker = "Aseprite" if variant.startswith("aseprite") else "TexturePacker"
    assert f"3 sprites from the {maker} {variant.split()[1]}" in err
    svg = Path("sheet.svg").read_text()
    assert_layers_are_lone_conversions(run, sheet, svg, [(label, x, y, 18, 16) for label, (x, y) in zip(labels, BOXES)])
    assert run("sheet.png", "--sheet-json", "sheet.json", "--out-dir", "out")[0] == Exit.OK
    files = [f"sheet-{label.replace('/', '_')}.svg" for label in labels]  # a folder separator is not a folder
    assert sorted(p.name for p in Path("out").iterdir()) == sorted(files)


def test_a_trimmed_frame_sits_at_its_place_on_the_sheet(run):
    sheet = grid_sheet(GRID[:3])
    save(sheet, "sheet.png")
    document = {"frames": {"orb.png": {**frame(41, 0, 16, 16), "trimmed": True,
                                       "spriteSourceSize": {"x": 1, "y": 0, "w": 16, "h": 16},
                                       "sourceSize": {"w": 18, "h": 16}}}}
    Path("sheet.json").write_text(json.dumps(document))
    assert run("sheet.png", "--sheet-json", "sheet.json", "-o", "sheet.svg")[0] == Exit.OK
    assert_layers_are_lone_conversions(run, sheet, Path("sheet.svg").read_text(), [("orb", 41, 0, 16, 16)])


def test_the_stamp_digests_the_jsons_content_not_its_name(run):
    save(grid_sheet(GRID[:3]), "sheet.png")
    Path("a.json").write_text(json.dumps({"frames": {"x.png": frame(0, 0, 18, 16)}}))
    assert run("sheet.png", "--sheet-json", "a.json", "--out-dir", "out")[0] == Exit.OK
    Path("b.json").write_text(Path("a.json").read_text())  # the same content, another name: up to date
    code, err = run("sheet.png", "--sheet-json", "b.json", "--out-dir", "out")
    assert code == Exit.OK and "0 converted, 1 up to date" in err
    Path("a.json").write_text(json.dumps({"frames": {"x.png": frame(20, 0, 18, 16)}}))  # moved: stale
    code, err = run("sheet.png", "--sheet-json", "a.json", "--out-dir", "out")
    assert code == Exit.OK and "1 converted, 0 up to date" in err


def test_two_sprites_never_write_one_file(run):
    save(grid_sheet(GRID[:3]), "sheet.png")
    Path("a.json").write_text(json.dumps({"frames": {"hero/a.png": frame(0, 0, 18, 16),
                                                     "hero_a.png": frame(20, 0, 18, 16)}}))
    code, err = run("sheet.png", "--sheet-json", "a.json", "--out-dir", "out", "--format", "svg,pdf")
    assert code == Exit.FAILED
    assert ("depixel: error: sheet.png: sprites 'hero/a' and 'hero_a' would both be written to "
            "out/sheet-hero_a.svg; name them apart with --name") in err
    assert not list(Path(".").glob("out/*"))
    assert run("sheet.png", "--sheet-json", "a.json", "-o", "sheet.pdf")[0] == Exit.OK  # one file: both layers
    Path("a.json").write_text(json.dumps({"frames": {"hero/a.png": frame(0, 0, 18, 16)}}))
    assert run("sheet.png", "--sheet-json", "a.json", "--out-dir", "out", "--format", "pdf")[0] == Exit.OK
    assert Path("out/sheet-hero_a.pdf").read_bytes()[:5] == b"%PDF-"


@pytest.mark.parametrize("document, message", [
    ('{"frames": ', "a.json: not JSON"),
    ({"frames": {"x.png": {**frame(0, 0, 18, 16), "rotated": True}}}, "a.json: frame 'x.png' is rotated"),
    ({"frames": {"x.png": frame(50, 0, 18, 16)}}, "a.json: frame 'x.png' at 50,0 18x16 runs past the 58x16 sheet"),
    ({"sprites": []}, 'a.json: no "frames" hash or array'),
])
def test_a_malformed_json_is_one_line_and_no_output(run, document, message):
    save(grid_sheet(GRID[:3]), "sheet.png")
    Path("a.json").write_text(document if isinstance(document, str) else json.dumps(document))
    code, err = run("sheet.png", "--sheet-json", "a.json", "-o", "sheet.svg")
    assert code == Exit.FAILED and err.startswith(f"depixel: error: {message}") and err.count("\n") == 1
    assert not Path("sheet.svg").exists()


# --- limits ---------------------------------------------------------------------------------

def test_a_sheets_sprites_count_against_max_frames_and_max_pixels(run):
    save(grid_sheet(), "sheet.png")
    code, err = run("sheet.png", "--sheet", "auto", "-o", "sheet.svg", "--max-frames", "4")
    assert code == Exit.FAILED
    assert err == ("depixel: error: sheet.png: 5 sprites, over the limit of 4 (a sprite counts as a frame; "
                   "raise it with --max-frames)\n")
    # Aseprite's JSON lists a duplicated frame at one place: each counts, in all
    Path("a.json").write_text(json.dumps({"frames": {f"f{i}.png": frame(0, 0, 18, 16) for i in range(8)}}))
    code, err = run("sheet.png", "--sheet-json", "a.json", "--out-dir", "out", "--max-pixels", "2000")
    assert code == Exit.FAILED and "8 sprites are 2304 pixels in all, over the limit of 2000" in err
    assert "--max-pixels" in err and not list(Path(".").glob("out/*"))


# --- Aseprite files: batches, tags, damage --------------------------------------------------

def hero_frames() -> list[np.ndarray]:
    """Four frames that differ: a fixture moved one pixel right each frame."""
    ghost = load_image(FIXTURES / "ghost_rgba.png")
    frames = []
    for i in range(4):
        canvas = np.zeros((16, 22, 4), np.uint8)
        canvas[:, i:i + 18] = ghost
        frames.append(canvas)
    return frames


def hero_file() -> bytes:
    """An Aseprite file of :func:`hero_frames` with three tags (forward, reverse, ping-pong)."""
    from aseprite_writer import FrameSpec, LayerSpec, aseprite_bytes, rgba_cel, tags_chunk  # noqa: PLC0415

    tags = tags_chunk([("walk", 0, 1, 0, 0), ("back", 1, 3, 1, 0), ("bounce", 0, 2, 2, 0)])
    return aseprite_bytes(22, 16, [LayerSpec("body")], [FrameSpec([rgba_cel(0, f)]) for f in hero_frames()],
                          first_chunks=[tags])


def test_tag_frames_follow_the_tags_direction():
    from depixel.prepare.aseprite import Tag, tag_frames  # noqa: PLC0415

    tags = [Tag("f", 2, 4, "forward", 0), Tag("r", 2, 4, "reverse", 0), Tag("p", 2, 4, "pingpong", 0),
            Tag("pr", 2, 4, "pingpong reverse", 0), Tag("one", 3, 3, "pingpong", 0)]
    assert [tag_frames(tags, t.name) for t in tags] == [[2, 3, 4], [4, 3, 2], [2, 3, 4, 3], [4, 3, 2, 3], [3]]
    ase = depixel.read_aseprite(hero_file())
    assert depixel.tag_frames(ase, "bounce") == [0, 1, 2, 1]
    with pytest.raises(depixel.InputError, match=r"^<aseprite>: no tag 'run'; its tags: 'walk', 'back', 'bounce'$"):
        depixel.tag_frames(ase, "run")


def test_a_tags_frames_each_the_same_as_that_frame_alone(run):
    Path("hero.aseprite").write_bytes(hero_file())
    code, err = run("hero.aseprite", "--tag", "back", "--frames", "all", "--out-dir", "out")
    assert code == Exit.OK and "note" not in err
    assert sorted(p.name for p in Path("out").iterdir()) == ["hero-001.svg", "hero-002.svg", "hero-003.svg"]
    for n in (1, 2, 3):  # the same file --frames N writes: same stamp, same bytes
        assert run("hero.aseprite", "--frames", str(n), "-o", f"frame{n}.svg")[0] == Exit.OK
        assert Path(f"out/hero-00{n}.svg").read_bytes() == Path(f"frame{n}.svg").read_bytes()
    # without --frames all, the first frame the tag plays: the last of a reversed tag
    assert run("hero.aseprite", "--tag", "back", "-o", "back.svg")[0] == Exit.OK
    assert Path("back.svg").read_bytes() == Path("frame3.svg").read_bytes()
    # a ping-pong tag plays frame 1 twice: written once
    assert run("hero.aseprite", "--tag", "bounce", "--frames", "all", "--out-dir", "b", "--name", "bounce")[0] == 0
    assert sorted(p.name for p in Path("b").iterdir()) == ["bounce-000.svg", "bounce-001.svg", "bounce-002.svg"]


def test_an_unknown_tag_lists_the_tags_and_writes_nothing(run):
    Path("hero.aseprite").write_bytes(hero_file())
    code, err = run("hero.aseprite", "--tag", "run", "--frames", "all", "--out-dir", "out")
    assert code == Exit.FAILED
    assert "depixel: error: hero.aseprite: no tag 'run'; its tags: 'walk', 'back', 'bounce'\n" in err
    assert not list(Path(".").glob("out/*"))
    code, err = run("hero.aseprite", "--tag", "run", "-o", "run.svg")
    assert code == Exit.FAILED and err.startswith("depixel: error: hero.aseprite: no tag 'run'")
    assert not Path("run.svg").exists()
    code, err = run("hero.aseprite", "--tag", "walk", "--frames", "2", "-o", "x.svg")
    assert code == Exit.USAGE and "--frames N numbers the file's frames and --tag picks a tag's" in err


def test_aseprite_files_in_a_folder_batch_frame_0_as_the_same_png(run):
    Path("art").mkdir()
    Path("art/hero.aseprite").write_bytes(hero_file())
    Path("art/copy.ase").write_bytes(hero_file())
    save(hero_frames()[0], "art/first.png")
    Path("art/broken.aseprite").write_bytes(hero_file()[:200])  # cut short in its first frame
    code, err = run("art", "--out-dir", "out")
    assert code == Exit.FAILED  # the broken file, and only it
    assert "depixel: error: art/broken.aseprite: " in err and "4 files: 3 converted" in err
    assert sorted(p.name for p in Path("out").iterdir()) == ["copy.svg", "first.svg", "hero.svg"]
    assert unstamped(Path("out/hero.svg").read_text()) == unstamped(Path("out/first.svg").read_text())
    assert "art/hero.aseprite: has 4 frames, converted the first" in err
    code, err = run("art/hero.aseprite", "--frames", "all", "--out-dir", "all")
    assert code == Exit.OK and len(list(Path("all").iterdir())) == 4


def test_an_aseprite_files_frames_count_against_the_limits(run):
    Path("hero.aseprite").write_bytes(hero_file())
    code, err = run("hero.aseprite", "--frames", "all", "--out-dir", "out", "--max-frames", "3")
    assert code == Exit.FAILED and "hero.aseprite: declares 4 frames, over the limit of 3" in err
    code, err = run("hero.aseprite", "--frames", "all", "--out-dir", "out", "--max-pixels", "1000")
    assert code == Exit.FAILED and "frames are" in err and "pixels in all, over the limit of 1000" in err
    code, err = run("hero.aseprite", "--tag", "back", "--frames", "all", "--out-dir", "out", "--max-frames", "3")
    assert code == Exit.FAILED and "declares 4 frames, over the limit of 3" in err  # the file's, not the tag's
    assert not list(Path(".").glob("out/*"))


def test_a_real_files_tags(run):
    """tags3.aseprite, from Aseprite's own tests (fixtures/aseprite/LICENSE.txt): 12 frames,
    tags forward 0-3, reverse 4-7, pingpong 8-11."""
    source = FIXTURES / "aseprite" / "tags3.aseprite"
    assert run(source, "--tag", "reverse", "--frames", "all", "-o", "t.svg")[0] == Exit.OK
    assert sorted(p.name for p in Path(".").glob("t*.svg")) == [f"t-00{n}.svg" for n in (4, 5, 6, 7)]
    assert run(source, "--frames", "5", "-o", "five.svg")[0] == Exit.OK
    assert Path("t-005.svg").read_bytes() == Path("five.svg").read_bytes()
    code, err = run(source, "--tag", "idle", "-o", "idle.svg")
    assert err == ("depixel: error: " + str(source) + ": no tag 'idle'; its tags: 'forward', 'reverse', "
                   "'pingpong'\n") and code == Exit.FAILED
