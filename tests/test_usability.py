"""Findings 2 and 4-8 of issue 13: diff tolerances, --frames all names, API checks, CLI
errors and options, renders that fill their last row, the progress bar on odd terminals."""
from __future__ import annotations

import io
import json
import math
import os
import pty
import shutil
import subprocess
import sys

import numpy as np
import pytest
from conftest import FIXTURES, drop_summary
from PIL import Image

import depixel
from depixel import api
from depixel.errors import DepixelError, ParameterError
from depixel_cli.main import main
from depixel_cli.options import Exit


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# --- 2. diff ------------------------------------------------------------------------------------

def test_each_diff_tolerance_works_alone(tmp_path, capsys):
    a = np.full((10, 20, 3), 200, np.uint8)
    b = a.copy()
    b[0, :5] = (0, 0, 0)  # 5 of 200 pixels differ (ratio 0.025), in a corner: not anti-aliasing
    Image.fromarray(a).save(tmp_path / "a.png")
    Image.fromarray(b).save(tmp_path / "b.png")
    base = ["diff", str(tmp_path / "a.png"), str(tmp_path / "b.png")]

    def verdict(*flags):
        code = main(base + list(flags))
        capsys.readouterr()
        return code

    assert verdict() == Exit.FAILED
    assert verdict("--max-ratio", "1") == Exit.OK
    assert verdict("--max-ratio", "0.03") == Exit.OK and verdict("--max-ratio", "0.02") == Exit.FAILED
    assert verdict("--max-pixels-diff", "100000") == Exit.OK
    assert verdict("--max-pixels-diff", "5") == Exit.OK and verdict("--max-pixels-diff", "4") == Exit.FAILED
    # both given: within either bound
    assert verdict("--max-pixels-diff", "4", "--max-ratio", "0.03") == Exit.OK
    assert verdict("--max-pixels-diff", "5", "--max-ratio", "0") == Exit.OK
    assert verdict("--max-pixels-diff", "4", "--max-ratio", "0.02") == Exit.FAILED
    assert main(base[:2] + [base[1], "--json"]) == Exit.OK  # an image is the same as itself
    assert json.loads(capsys.readouterr().out)["same"] is True


def test_diff_scale_compares_an_svg_with_its_pixel_art_at_that_scale(tmp_path, capsys):
    svg = tmp_path / "ghost.svg"
    assert main(["convert", str(FIXTURES / "ghost.png"), "-o", str(svg), "--stage", "cells"]) == Exit.OK
    assert main(["diff", str(svg), str(FIXTURES / "ghost.png"), "--scale", "8", "--json",
                 "--max-ratio", "0.1"]) == Exit.OK
    report = json.loads(capsys.readouterr().out)
    with Image.open(FIXTURES / "ghost.png") as art:
        assert (report["width"], report["height"]) == (art.width * 8, art.height * 8)
    assert report["ratio"] < 0.1  # the cells are the pixels, bar their cut corners


# --- 4. --frames all ------------------------------------------------------------------------------

def test_frames_all_keeps_still_names_and_reports_only_real_collisions(tmp_path, capsys):
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(FIXTURES / "heart.png", src / "boo.png")
    shutil.copy(FIXTURES / "heart_beat.gif", src / "boo.gif")  # 2 frames: boo-000, boo-001
    out = tmp_path / "out"
    assert main(["convert", str(src), "--out-dir", str(out), "--frames", "all", "--stage", "cells",
                 "-j", "1"]) == Exit.OK
    assert sorted(p.name for p in out.iterdir()) == ["boo-000.svg", "boo-001.svg", "boo.svg"]
    capsys.readouterr()
    # -o single.svg --frames all on a still image: single.svg
    single = tmp_path / "single.svg"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(single), "--frames", "all"]) == Exit.OK
    assert single.exists() and not list(tmp_path.glob("single-*"))
    # a real collision: a one-frame GIF and a PNG of one name both make boo.svg
    one = tmp_path / "one"
    one.mkdir()
    shutil.copy(FIXTURES / "heart.png", one / "boo.png")
    with Image.open(FIXTURES / "heart_beat.gif") as gif:
        gif.save(one / "boo.gif")  # the first frame only
    code = main(["convert", str(one), "--out-dir", str(tmp_path / "out1"), "--frames", "all", "-j", "1"])
    assert code == Exit.FAILED
    line = one_line(drop_summary(capsys.readouterr().err))
    assert "boo.png: output" in line and "boo.svg is already the output of" in line
    assert line.endswith("boo.gif; name the outputs apart with --name, e.g. --name '{stem}-{suffix}'")
    assert [p.name for p in (tmp_path / "out1").iterdir()] == ["boo.svg"]


# --- 5. the API checks like the CLI -------------------------------------------------------------------

SPRITE = np.array([[[0, 0, 0], [255, 255, 255]], [[255, 255, 255], [0, 0, 0]]], np.uint8)


@pytest.mark.parametrize("kwargs,match", [
    ({"scale": 0}, "scale must be a positive number"),
    ({"scale": -2}, "scale must be a positive number"),
    ({"scale": math.nan}, "scale must be a finite number"),
    ({"scale": True}, "scale must be a positive number"),
    ({"precision": 30}, "precision must be between 0 and 12"),
    ({"stage": "optimised"}, "did you mean 'optimized'"),
    ({"background": "nocolour"}, "unknown colour"),
    ({"background": (300, 0, 0)}, "background must be between 0 and 255"),
    ({"width": 0}, "width must be at least 1"),
    ({"params": {"seed": 1}}, "params must be a depixel.Params"),
])
def test_api_arguments_are_checked(kwargs, match):
    for call in (lambda: depixel.convert(SPRITE, **kwargs), lambda: depixel.convert_bytes(SPRITE, "png", **kwargs)):
        with pytest.raises(ParameterError, match=match):
            call()


def test_api_points_a_file_name_at_the_file_functions():
    with pytest.raises(ParameterError, match=r"smw_boo.png: convert takes pixels .* use depixel.convert_file"):
        depixel.convert("smw_boo.png")
    with pytest.raises(DepixelError, match="unknown format 'jpg'"):
        depixel.convert_bytes(SPRITE, "jpg")
    with pytest.raises(DepixelError, match=r"unknown shading 'smoth' \(did you mean 'smooth'\?\)"):
        depixel.convert_bytes(SPRITE, "png", shading="smoth")


def test_api_width_and_height(tmp_path):
    svg = depixel.convert(SPRITE, width=100, stage="cells")
    assert 'width="100"' in svg and 'height="100"' in svg
    png = depixel.convert_bytes(SPRITE, "png", height=30, stage="cells")
    assert Image.open(io.BytesIO(png)).size == (30, 30)


# --- 6. the command line -------------------------------------------------------------------------------

@pytest.mark.parametrize("argv,fragment", [
    (["convert", "{heart}", "-o", "boo.png", "--format", "svg"], "the name says PNG but --format is SVG"),
    (["render", "{svg}", "-o", "boo.webp"], "render writes PNG, PDF or EPS"),
    (["render", "{svg}", "-o", "boo.svg"], "render writes PNG, PDF or EPS"),
    (["convert", "{heart}", "-o", "x.svg", "--scael", "8"], "depixel convert: error: unrecognized arguments: "
                                                          "--scael 8 (--scael: did you mean --scale?)"),
    (["convert", "{heart}", "-o", "x.svg", "--stage", "optimised"], "did you mean optimized?"),
    (["diff", "{svg}", "{svg}", "--max-ratoi", "1"], "depixel diff: error: unrecognized arguments"),
    (["convert", "{heart}", "-o", "x.svg", "--sparse-window", "100"], "--sparse-window must be between 2 and 64"),
])
def test_usage_errors_name_the_command_and_suggest(argv, fragment, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    svg = tmp_path / "heart.svg"
    svg.write_text(depixel.convert(api.load(FIXTURES / "heart.png"), stage="cells"))
    try:
        code = main([a.format(heart=FIXTURES / "heart.png", svg=svg) for a in argv])
    except SystemExit as exc:
        code = exc.code
    assert code == Exit.USAGE
    assert fragment in one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["heart.svg"]


def test_format_without_a_known_extension_is_honoured(tmp_path):
    out = tmp_path / "sprite.out"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(out), "--format", "png"]) == Exit.OK
    assert out.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("command", ["convert", "render", "diff", "inspect"])
def test_debug_is_in_every_command_help(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    assert "--debug" in capsys.readouterr().out


def test_convert_width_and_height(tmp_path):
    png, svg = tmp_path / "heart.png", tmp_path / "heart.svg"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(png), "--width", "64"]) == Exit.OK
    assert Image.open(png).size == (64, 64)  # heart.png is 10x10
    assert main(["convert", str(FIXTURES / "ghost.png"), "-o", str(svg), "--height", "160", "--stage", "cells"]) == 0
    assert 'width="180" height="160"' in svg.read_text()  # ghost is 18x16


# --- 7. renders fill their last row and column --------------------------------------------------------

def test_render_at_an_uneven_size_keeps_the_edges_opaque(tmp_path):
    art = np.random.default_rng(3).integers(0, 256, (33, 27, 3), dtype=np.uint8)  # win31_386's 27x33
    svg = tmp_path / "art.svg"
    svg.write_text(depixel.convert(art, stage="cells"))
    for flag, value in (("--width", "800"), ("--scale", "7.3")):
        out = tmp_path / f"art{flag}.png"
        assert main(["render", str(svg), "-o", str(out), flag, value]) == Exit.OK
        alpha = np.asarray(Image.open(out).convert("RGBA"))[..., 3]
        assert alpha.min() == 255, (flag, alpha[-1].min(), alpha[:, -1].min())
    assert Image.open(tmp_path / "art--width.png").size == (800, 978)


# --- 8. the progress bar -------------------------------------------------------------------------------

def test_progress_bar_under_a_zero_width_terminal_shows_the_file(tmp_path):
    """A pty whose size was never set reports 0 columns (script -q -c does this)."""
    src = tmp_path / "in"
    src.mkdir()
    for i in range(3):
        shutil.copy(FIXTURES / "heart.png", src / f"sprite{i}.png")
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(src), "--out-dir", str(tmp_path / "out"),
                             "-j", "1", "--stage", "cells"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=slave)
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        seen += chunk
    os.close(master)
    assert proc.wait(timeout=120) == 0
    text = seen.decode("utf-8", "replace")
    assert "/3" in text and "file" in text, text  # the bar: n/3 files
    assert "sprite" in text and ".png" in text, text  # and the file being converted
    assert "3 files: 3 converted" in text
