"""``depixel convert --animate`` end to end: a GIF, an APNG, an animated WebP and an Aseprite
file (each written by the tests) → one animated SVG or one animated PNG, in the file's timing;
batches write one file per input, the stamps cover the option, the limits count every frame,
and the options that cannot go with it are refused in one line."""
from __future__ import annotations

import io
import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from animfiles import GifImage, PngFrame, apng, gif
from aseprite_writer import FrameSpec, LayerSpec, aseprite_bytes, rgba_cel
from conftest import FIXTURES, drop_summary
from PIL import Image

import depixel
from depixel.render.raster import render_rgba
from depixel_cli.main import main
from depixel_cli.options import Exit

SVG = "{http://www.w3.org/2000/svg}"
INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"
PALETTE = [(20, 20, 30), (230, 200, 60), (200, 40, 40), (40, 90, 200)]
#: a 6 × 6 sprite: a yellow block with a dark frame; frames change the 2 × 2 middle
BASE = [[0] * 6, [0, 1, 1, 1, 1, 0], [0, 1, 1, 1, 1, 0], [0, 1, 1, 1, 1, 0], [0, 1, 1, 1, 1, 0], [0] * 6]


def frame_indices(colour: int) -> list[list[int]]:
    rows = [list(row) for row in BASE]
    rows[2][2:4] = rows[3][2:4] = [colour, colour]
    return rows


def walk_gif(loop: int | None = 0, delays: tuple[int, ...] = (12, 4, 25)) -> bytes:
    """Three full 6 × 6 frames (hundredths ``delays``), the middle yellow, red, blue."""
    return gif((6, 6), PALETTE, [GifImage(frame_indices(c), delay=d) for c, d in zip((1, 2, 3), delays)], loop=loop)


def rgba(colour: int) -> np.ndarray:
    table = np.array([(*c, 255) for c in PALETTE], np.uint8)
    return table[np.array(frame_indices(colour))]


def layers(path: Path) -> list[ET.Element]:
    root = ET.parse(path).getroot()
    return [g for g in root if g.tag == f"{SVG}g"]


def timing(path: Path) -> list[dict[str, str]]:
    """Each layer's label and the attributes of its <animate>."""
    return [{"label": g.get(f"{INKSCAPE}label"), **g.find(f"{SVG}animate").attrib} for g in layers(path)]


@pytest.fixture
def walk(tmp_path) -> Path:
    path = tmp_path / "walk.gif"
    path.write_bytes(walk_gif())
    return path


def test_a_gif_becomes_one_svg_in_its_timing_whose_first_frame_is_its_own_conversion(walk, tmp_path, capsys):
    assert main(["convert", str(walk), "-o", str(tmp_path / "walk.svg"), "--animate", "--scale", "8"]) == Exit.OK
    assert capsys.readouterr().err == ""
    got = timing(tmp_path / "walk.svg")
    assert [g["label"] for g in got] == ["frame 1 (120 ms)", "frame 2 (40 ms)", "frame 3 (250 ms)"]
    assert [g.get("display") for g in layers(tmp_path / "walk.svg")] == [None, "none", "none"]
    assert {(g["dur"], g["repeatCount"], g.get("fill")) for g in got} == {("410ms", "indefinite", None)}
    assert [g["keyTimes"] for g in got] == ["0;0.2927", "0;0.2927;0.3902", "0;0.3902"]
    # what a renderer without animation draws: frame 1, as --frames 0 converts it
    assert main(["convert", str(walk), "-o", str(tmp_path / "first.svg"), "--frames", "0", "--scale", "8"]) == 0
    np.testing.assert_array_equal(render_rgba((tmp_path / "walk.svg").read_bytes()),
                                  render_rgba((tmp_path / "first.svg").read_bytes()))
    # the yellow block is drawn once, in <defs>, for all three frames
    svg = (tmp_path / "walk.svg").read_text()
    assert svg.count('fill="#e6c83c"') == 1 and svg.count("<use ") >= 3


@pytest.mark.parametrize(("loop", "repeat"), [(None, ("1", "freeze")), (0, ("indefinite", None)),
                                              (2, ("3", "freeze"))])
def test_a_gif_loop_block_counts_repeats(tmp_path, loop, repeat):
    (tmp_path / "walk.gif").write_bytes(walk_gif(loop=loop, delays=(1, 30, 30)))
    assert main(["convert", str(tmp_path / "walk.gif"), "-o", str(tmp_path / "walk.svg"), "--animate", "-q"]) == 0
    got = timing(tmp_path / "walk.svg")
    assert {(g["repeatCount"], g.get("fill")) for g in got} == {repeat}
    assert got[0]["label"] == "frame 1 (100 ms)"  # 10 ms plays as 100 ms, as in browsers


def test_an_apng_a_webp_and_an_aseprite_file_animate_in_their_timing(tmp_path):
    from PIL import features

    frames = [rgba(c) for c in (1, 2, 3)]
    inputs = {"walk.png": apng((6, 6), [PngFrame(f, delay=(d, 100)) for f, d in zip(frames, (12, 4, 25))], plays=2),
              "walk.aseprite": aseprite_bytes(6, 6, [LayerSpec("Layer 1")],
                                              [FrameSpec([rgba_cel(0, f)], duration=d)
                                               for f, d in zip(frames, (120, 40, 250))])}
    if features.check("webp"):
        buffer = io.BytesIO()
        first, *rest = (Image.fromarray(f, "RGBA") for f in frames)
        first.save(buffer, format="WEBP", save_all=True, append_images=rest, duration=[120, 40, 250], loop=2,
                   lossless=True)
        inputs["walk.webp"] = buffer.getvalue()
    plays = {"walk.png": ("2", "freeze"), "walk.webp": ("2", "freeze"), "walk.aseprite": ("indefinite", None)}
    for name, data in inputs.items():
        (tmp_path / name).write_bytes(data)
        out = tmp_path / f"{name}.svg"
        assert main(["convert", str(tmp_path / name), "-o", str(out), "--animate", "-q"]) == 0, name
        got = timing(out)
        assert [g["label"] for g in got] == ["frame 1 (120 ms)", "frame 2 (40 ms)", "frame 3 (250 ms)"], name
        assert {(g["repeatCount"], g.get("fill")) for g in got} == {plays[name]}, name


def test_a_png_output_is_an_apng_of_the_smooth_renders(walk, tmp_path):
    out = tmp_path / "walk.png"
    assert main(["convert", str(walk), "-o", str(out), "--animate", "--scale", "4", "-q"]) == Exit.OK
    with Image.open(out) as image:
        assert image.n_frames == 3 and image.info["loop"] == 0
    again = depixel.read_animation(out)
    assert again.durations == (120.0, 40.0, 250.0) and again.plays == 0
    for got, colour in zip(again.frames, (1, 2, 3)):
        own = depixel.convert_bytes(rgba(colour), "png", scale=4)
        np.testing.assert_array_equal(got, np.asarray(Image.open(io.BytesIO(own)).convert("RGBA")))


def test_a_still_image_is_written_as_its_one_frame_with_a_note(tmp_path, capsys):
    shutil.copy(FIXTURES / "heart.png", tmp_path / "heart.png")
    assert main(["convert", str(tmp_path / "heart.png"), "-o", str(tmp_path / "a.svg"), "--animate"]) == 0
    assert "heart.png: a still image, written as its one frame (--animate)" in capsys.readouterr().err
    assert main(["convert", str(tmp_path / "heart.png"), "-o", str(tmp_path / "b.svg"), "-q"]) == 0
    body = [(tmp_path / n).read_text().split("\n", 2)[2] for n in ("a.svg", "b.svg")]  # after the stamp
    assert body[0] == body[1]


def test_without_animate_an_animation_says_so(walk, tmp_path, capsys):
    assert main(["convert", str(walk), "-o", str(tmp_path / "walk.svg")]) == 0
    assert "has 3 frames, converted the first (--frames all converts each, --animate plays them in one file)" \
        in capsys.readouterr().err


def test_a_batch_writes_one_file_per_input_and_the_stamps_cover_animate(walk, tmp_path, capsys):
    shutil.copy(FIXTURES / "heart.png", tmp_path / "heart.png")
    out = tmp_path / "out"
    argv = ["convert", str(walk), str(tmp_path / "heart.png"), "--out-dir", str(out), "--animate", "--json",
            "--format", "svg,png", "-j", "2"]
    assert main(argv) == Exit.OK
    report = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in out.iterdir()) == ["heart.png", "heart.svg", "walk.png", "walk.svg"]
    assert report["ok"] == 2 and {o["status"] for o in report["outputs"]} == {"converted"}
    assert len(layers(out / "walk.svg")) == 3 and Image.open(out / "walk.png").n_frames == 3
    # a second run: up to date
    assert main(argv) == Exit.OK
    assert {o["status"] for o in json.loads(capsys.readouterr().out)["outputs"]} == {"up-to-date"}
    # without --animate the outputs are stale and made again, one frame each
    assert main([a for a in argv if a != "--animate"]) == Exit.OK
    assert {o["status"] for o in json.loads(capsys.readouterr().out)["outputs"]} == {"converted"}
    assert layers(out / "walk.svg") == [] and Image.open(out / "walk.png").n_frames == 1
    # and with it again, animated again
    assert main(argv) == Exit.OK
    assert json.loads(capsys.readouterr().out)["ok"] == 2 and len(layers(out / "walk.svg")) == 3


def test_a_dry_run_plans_one_output_per_input(walk, tmp_path, capsys):
    assert main(["convert", str(walk), "--out-dir", str(tmp_path / "out"), "--animate", "--dry-run"]) == 0
    assert capsys.readouterr().out.split() == ["would", "convert", str(tmp_path / "out" / "walk.svg")]


def test_stdin_to_stdout(walk, capsysbinary, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(walk.read_bytes())))
    assert main(["convert", "-", "-o", "-", "--animate"]) == Exit.OK
    svg = capsysbinary.readouterr().out.decode()
    assert svg.count('inkscape:groupmode="layer"') == 3 and svg.count("<animate ") == 3


@pytest.mark.parametrize(("extra", "message"), [
    (["--max-frames", "2"], "3 frames, over the limit of 2 (raise it with --max-frames)"),
    (["--max-pixels", "100"], "3 frames are 108 pixels in all, over the limit of 100"),
    (["--max-output-pixels", "971", "--scale", "3", "--format", "png"],  # 3 frames of 18 × 18
     "3 PNG frames are 972 pixels in all, over the limit of 971 (the limit counts every frame; raise it with "
     "--max-output-pixels)"),
])
def test_the_limits_count_every_frame(walk, tmp_path, capsys, extra, message):
    out = tmp_path / "out"
    code = main(["convert", str(walk), "--out-dir", str(out), "--animate", *extra])
    err = drop_summary(capsys.readouterr().err)
    assert code == Exit.FAILED and err.count("\n") == 0 and message in err and "Traceback" not in err, err
    assert not out.exists() or list(out.iterdir()) == []
    # the limit raised to what the frames need: written
    raised = [{"2": "3", "100": "108", "971": "972"}.get(a, a) for a in extra]
    assert main(["convert", str(walk), "--out-dir", str(out), "--animate", "-q", *raised]) == Exit.OK
    assert len(list(out.iterdir())) == 1


@pytest.mark.parametrize(("extra", "message"), [
    (["--frames", "all"], "--animate writes every frame into one file; --frames all picks frames"),
    (["--frames", "1"], "--animate writes every frame into one file; --frames 1 picks frames"),
    (["-o", "x.pdf"], "--animate writes an SVG or a PNG (an animated PNG); a PDF cannot play frames"),
    (["--format", "svg,pdf"], "a PDF cannot play frames"),
])
def test_what_cannot_go_with_animate_is_a_usage_error(walk, tmp_path, capsys, monkeypatch, extra, message):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stopped:
        main(["convert", str(walk), "--animate", *extra])
    assert stopped.value.code == Exit.USAGE
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.gif"]


def test_a_folder_gives_its_aseprite_files_too(tmp_path):
    src = tmp_path / "art"
    src.mkdir()
    (src / "walk.aseprite").write_bytes(aseprite_bytes(6, 6, [LayerSpec("Layer 1")],
                                                       [FrameSpec([rgba_cel(0, rgba(c))]) for c in (1, 2)]))
    assert main(["convert", str(src), "--out-dir", str(tmp_path / "out"), "--animate", "-q"]) == Exit.OK
    assert len(layers(tmp_path / "out" / "walk.svg")) == 2


def test_frames_found_upscaled_apart_ask_for_the_pixel_size(tmp_path, capsys):
    from depixel.render.animation import encode_apng

    frames = [np.repeat(np.repeat(rgba(c), 4, axis=0), 4, axis=1) for c in (1, 2, 3)]
    frames[1][5, 7] = (1, 2, 3, 255)  # one odd pixel: frame 2 is not 4× upscaled art
    (tmp_path / "walk.png").write_bytes(encode_apng(frames, [100.0] * 3, 0))
    argv = ["convert", str(tmp_path / "walk.png"), "-o", str(tmp_path / "walk.svg"), "--animate", "-q"]
    assert main(argv) == Exit.FAILED
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "different sizes (upscaled in some, not in others); give the grid of all " \
        "with --pixel-size" in err, err
    assert not (tmp_path / "walk.svg").exists()
    assert main(argv + ["--pixel-size", "4"]) == Exit.OK
    assert 'viewBox="0 0 6 6"' in (tmp_path / "walk.svg").read_text()
