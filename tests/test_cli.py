"""End-to-end tests of ``depixel convert`` through the real entry point (and the installed script)."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from conftest import FIXTURES
from PIL import Image

from depixel import api
from depixel_cli.main import main
from depixel_cli.options import Exit

SMALL = ["heart.png", "leaf.png", "potion_rgba.png", "leaf_la.png"]  # the quickest fixtures


def svg_root(path: Path) -> ET.Element:
    root = ET.parse(path).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    return root


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_folder_in_parallel_with_a_corrupt_file(tmp_path, capsys):
    src = tmp_path / "in"
    (src / "sub").mkdir(parents=True)
    for name in SMALL[:3]:
        shutil.copy(FIXTURES / name, src / name)
    shutil.copy(FIXTURES / SMALL[3], src / "sub" / SMALL[3])
    (src / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"not really" * 10)
    (src / "notes.txt").write_text("not an image, not picked from a folder")
    out = tmp_path / "out"

    code = main(["convert", str(src), "-r", "--out-dir", str(out), "-j", "2", "--json"])
    captured = capsys.readouterr()

    assert code == Exit.FAILED
    report = json.loads(captured.out)
    assert report["files"] == 5 and report["ok"] == 4 and report["skipped"] == 0
    assert [f["input"] for f in report["failed"]] == [str(src / "broken.png")]
    assert "broken.png" in report["failed"][0]["error"]
    expected = {out / "heart.svg", out / "leaf.svg", out / "potion_rgba.svg", out / "sub" / "leaf_la.svg"}
    statuses = {Path(o["output"]): o["status"] for o in report["outputs"]}
    assert statuses == {**{p: "converted" for p in expected}, out / "broken.svg": "failed"}
    assert {p for p in out.rglob("*") if p.is_file()} == expected  # nothing else, no temp files
    for path in expected:
        root = svg_root(path)
        assert root.find("{http://www.w3.org/2000/svg}title").text == path.with_suffix(".png").name
    error_lines = [line for line in captured.err.splitlines() if "error" in line]
    assert len(error_lines) == 1 and "broken.png" in error_lines[0]
    assert "Traceback" not in captured.err


def test_output_does_not_depend_on_jobs(tmp_path, capsys):
    names = ["ghost.png", "mushroom.png", "chip.png"]
    results = {}
    for jobs in ("1", "2"):
        out = tmp_path / f"j{jobs}"
        assert main(["convert", *[str(FIXTURES / n) for n in names], "--out-dir", str(out), "-j", jobs,
                     "--stage", "cells"]) == Exit.OK
        results[jobs] = {p.name: p.read_bytes() for p in out.iterdir()}
    assert len(results["1"]) == 3 and results["1"] == results["2"]


@pytest.mark.parametrize("fmt", ["png", "pdf"])
def test_png_and_pdf_outputs_open(tmp_path, fmt):
    out = tmp_path / f"heart.{fmt}"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(out), "--scale", "4"]) == Exit.OK
    if fmt == "png":
        with Image.open(out) as img:
            assert img.size == (40, 40)  # heart.png is 10×10
    else:
        assert out.read_bytes().startswith(b"%PDF-")


def test_format_option_in_batch_mode(tmp_path):
    out = tmp_path / "out"
    assert main(["convert", str(FIXTURES / "heart.png"), str(FIXTURES / "leaf.png"), "--out-dir", str(out),
                 "--format", "png", "--scale", "2", "--stage", "cells", "-j", "1"]) == Exit.OK
    with Image.open(out / "leaf.png") as img:
        assert img.size == (24, 24)


def test_up_to_date_outputs_are_skipped_stale_ones_reconverted(tmp_path, capsys):
    """Finding 13.3: an output is skipped only when newer than its input and made with the
    same options; an edited input or another option reconverts exactly the files concerned."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    for name in ("heart.png", "leaf.png"):
        shutil.copy(FIXTURES / name, src / name)
    args = ["convert", str(src), "--out-dir", str(out), "--stage", "cells", "-j", "1", "--json"]

    def statuses(argv):
        assert main(argv) == Exit.OK
        report = json.loads(capsys.readouterr().out)
        return {Path(o["output"]).name: o["status"] for o in report["outputs"]}, report

    assert statuses(args)[0] == {"heart.svg": "converted", "leaf.svg": "converted"}
    first = (out / "heart.svg").read_bytes()
    got, report = statuses(args)  # unchanged: every output listed, up to date
    assert got == {"heart.svg": "up-to-date", "leaf.svg": "up-to-date"}
    assert report["ok"] == 0 and report["skipped"] == 2
    # the input changes (and is newer): only its output is remade
    shutil.copy(FIXTURES / "ghost.png", src / "heart.png")
    os.utime(src / "heart.png", ns=((out / "heart.svg").stat().st_mtime_ns + 1,) * 2)  # newer, not future
    assert statuses(args)[0] == {"heart.svg": "converted", "leaf.svg": "up-to-date"}
    assert (out / "heart.svg").read_bytes() != first
    # another option that changes the bytes: both are remade; one that does not (-j): none
    assert set(statuses(args + ["--precision", "1"])[0].values()) == {"converted"}
    assert set(statuses(args + ["--precision", "1", "-j", "2"])[0].values()) == {"up-to-date"}
    # a file at the output that depixel did not write is kept (issue 33 item 4); --force replaces it
    (out / "leaf.svg").write_text("hand-made")
    assert statuses(args + ["--precision", "1"])[0]["leaf.svg"] == "kept"
    assert (out / "leaf.svg").read_text() == "hand-made"
    assert main(args + ["--precision", "1", "--force"]) == Exit.OK
    assert json.loads(capsys.readouterr().out)["ok"] == 2
    svg_root(out / "heart.svg")


def test_never_overwrites_an_input(tmp_path, capsys):
    shutil.copy(FIXTURES / "heart.png", tmp_path / "heart.png")
    before = (tmp_path / "heart.png").read_bytes()
    code = main(["convert", str(tmp_path), "--out-dir", str(tmp_path), "--format", "png", "--stage", "cells"])
    assert code == Exit.FAILED
    assert "would overwrite an input" in capsys.readouterr().err
    assert (tmp_path / "heart.png").read_bytes() == before
    # a single explicit output onto the input is refused too
    code = main(["convert", str(tmp_path / "heart.png"), "-o", str(tmp_path / "heart.png"), "--stage", "cells"])
    assert code == Exit.FAILED
    assert (tmp_path / "heart.png").read_bytes() == before


def test_folder_inputs_leave_out_hidden_files_other_files_and_the_output_folder(tmp_path):
    """A folder gives its images (in subfolders with -r), not hidden ones, not other files,
    not folders named like images, and not what lies in the output folder inside it (unless
    the output folder is the input folder); a file named again is taken once."""
    from depixel_cli.convert.inputs import expand_inputs

    src = tmp_path / "in"
    for name in ("a.png", ".hidden.png", ".cache/b.png", "sub/c.GIF", "out/d.png", "notes.txt"):
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        (src / name).write_bytes(b"")
    (src / "folder.png").mkdir()

    found, problems = expand_inputs([str(src), str(src / "a.png")], True, exclude=src / "out")
    assert [(str(path), str(rel)) for path, rel in found] == [(str(src / "a.png"), "a.png"),
                                                              (str(src / "sub" / "c.GIF"), "sub/c.GIF")]
    assert problems == []
    found, _ = expand_inputs([str(src)], True, exclude=src)
    assert [str(rel) for _, rel in found] == ["a.png", "out/d.png", "sub/c.GIF"]
    found, _ = expand_inputs([str(src / "*" / "*.png")], False, exclude=src / "out")
    assert found == []


def test_glob_keeps_relative_folders(tmp_path):
    for sub in ("a", "b"):
        (tmp_path / "art" / sub).mkdir(parents=True)
        shutil.copy(FIXTURES / "heart.png", tmp_path / "art" / sub / "heart.png")
    out = tmp_path / "out"
    code = main(["convert", str(tmp_path / "art" / "**" / "*.png"), "--out-dir", str(out), "--stage", "cells",
                 "-j", "1"])
    assert code == Exit.OK
    assert {p.relative_to(out).as_posix() for p in out.rglob("*.svg")} == {"a/heart.svg", "b/heart.svg"}


def test_two_inputs_with_one_output_name_fail_cleanly(tmp_path, capsys):
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        shutil.copy(FIXTURES / "heart.png", tmp_path / sub / "heart.png")
    out = tmp_path / "out"
    code = main(["convert", str(tmp_path / "a" / "heart.png"), str(tmp_path / "b" / "heart.png"),
                 "--out-dir", str(out), "--stage", "cells", "-j", "1"])
    assert code == Exit.FAILED
    assert "already the output of" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["heart.svg"]


def test_animated_gif_frames(tmp_path, capsys):
    gif = FIXTURES / "heart_beat.gif"
    assert main(["convert", str(gif), "-o", str(tmp_path / "beat.svg"), "--frames", "all"]) == Exit.OK
    frames = sorted(tmp_path.glob("beat-*.svg"))
    assert [p.name for p in frames] == ["beat-000.svg", "beat-001.svg"]
    assert frames[0].read_bytes() != frames[1].read_bytes()
    for path in frames:
        svg_root(path)
    assert capsys.readouterr().err == ""

    assert main(["convert", str(gif), "-o", str(tmp_path / "first.svg")]) == Exit.OK
    assert "2 frames" in one_line(capsys.readouterr().err)
    assert (tmp_path / "first.svg").read_bytes() == frames[0].read_bytes()


def test_background_flattens_before_converting(tmp_path):
    out = tmp_path / "potion.svg"
    assert main(["convert", str(FIXTURES / "potion_rgba.png"), "-o", str(out), "--background", "white",
                 "--stage", "cells"]) == Exit.OK
    assert "fill-opacity" not in out.read_text()  # every colour is opaque once flattened
    plain = tmp_path / "plain.svg"
    assert main(["convert", str(FIXTURES / "potion_rgba.png"), "-o", str(plain), "--stage", "cells"]) == Exit.OK
    assert "fill-opacity" in plain.read_text()


def test_tuning_flags_reach_the_pipeline(tmp_path):
    default, tuned = tmp_path / "default.svg", tmp_path / "tuned.svg"
    assert main(["convert", str(FIXTURES / "ghost.png"), "-o", str(default), "--stage", "cells"]) == Exit.OK
    # with a huge luma threshold the dark outline merges with the light body
    assert main(["convert", str(FIXTURES / "ghost.png"), "-o", str(tuned), "--stage", "cells",
                 "--threshold-y", "255", "--threshold-u", "255", "--threshold-v", "255"]) == Exit.OK
    assert default.read_bytes() != tuned.read_bytes()
    coarse = tmp_path / "coarse.svg"
    assert main(["convert", str(FIXTURES / "leaf.png"), "-o", str(coarse), "--precision", "0"]) == Exit.OK
    assert "." not in "".join(p.get("d") for p in svg_root(coarse).iter("{http://www.w3.org/2000/svg}path"))


@pytest.mark.parametrize("argv", [
    ["convert", "-"],  # stdin needs -o
    ["convert", "a.png", "-o", "x.svg", "--name", "{stem}"],  # -o names the file itself
    ["convert", "a.png", "-o", "x.svg", "--format", "svg,png"],  # -o is one file
    ["convert", "a.png", "--name", "{nope}"],
    ["convert", "a.png", "--name", "sub/{stem}"],
    ["convert", "a.png", "--format", "svg,gif"],
    ["convert", "a.png", "b.png", "-o", "x.svg"],
    ["convert", "a.png", "-o", "x.svg", "--out-dir", "d"],
    ["convert", "a.png", "-o", "x.jpg"],
    ["convert", "a.png", "-o", "x.svg", "--threshold-y", "-1"],
    ["convert", "a.png", "-o", "x.svg", "--sparse-window", "1"],
    ["convert", "a.png", "-o", "x.svg", "--background", "nocolour"],
    ["convert", "-", "-o", "-", "--frames", "all"],
    ["render", "a.svg", "-o", "x.png", "--scale", "2", "--width", "9"],
])
def test_usage_errors_are_one_line_exit_2(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(FIXTURES / "heart.png", tmp_path / "a.png")
    shutil.copy(FIXTURES / "heart.png", tmp_path / "b.png")
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == Exit.USAGE
    one_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png"]


@pytest.mark.parametrize("content", [None, b"", b"hello", (FIXTURES / "heart.png").read_bytes()[:60]])
def test_bad_input_is_one_line_exit_1_and_no_output(content, tmp_path, capsys):
    source = tmp_path / "input.png"  # missing, empty, text, truncated
    if content is not None:
        source.write_bytes(content)
    out = tmp_path / "out.svg"
    assert main(["convert", str(source), "-o", str(out)]) == Exit.FAILED
    assert source.name in one_line(capsys.readouterr().err)
    assert not out.exists()


def test_debug_shows_the_traceback(tmp_path, capsys):
    assert main(["--debug", "convert", str(tmp_path / "missing.png"), "-o", str(tmp_path / "x.svg")]) == Exit.FAILED
    assert "Traceback" in capsys.readouterr().err


def test_version_lists_dependencies(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    import depixel

    assert out.startswith(f"depixel {depixel.__version__}\n")
    for name in ("numpy", "pillow", "cairosvg", "tqdm"):
        assert f"  {name} " in out


def test_help_shows_examples_first(capsys):
    with pytest.raises(SystemExit):
        main(["convert", "--help"])
    text = capsys.readouterr().out
    assert text.index("examples:") < text.index("--out-dir DIR ")
    assert "--curve-weight" in text and "--no-optimize" in text


def test_installed_script_stdin_to_stdout(tmp_path):
    """Through the installed ``depixel`` script with real pipes: PNG on stdin, SVG on stdout."""
    script = Path(sys.executable).with_name("depixel")
    if not script.exists():
        pytest.skip("depixel script not installed next to the interpreter")
    png = (FIXTURES / "heart.png").read_bytes()
    run = subprocess.run([str(script), "convert", "-", "-o", "-"], input=png, capture_output=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stderr == b""
    expected = api.convert(api.load(FIXTURES / "heart.png")).encode()  # no title: stdin has no name
    assert run.stdout == expected

    bad = subprocess.run([str(script), "convert", "-", "-o", "-"], input=b"junk", capture_output=True, timeout=120)
    assert bad.returncode == 1 and bad.stdout == b""
    assert bad.stderr.decode().startswith("depixel: error: <stdin>:")


@pytest.mark.parametrize("name", ["ghost.png", "inputs/ghost_x4.jpg"])
def test_svg_conversion_loads_only_what_it_needs(tmp_path, name):
    """Start-up cost of every process: SVG output needs no cairo, the graph kernels no scipy,
    numpy 2's ``np.unique`` would import ``numpy.ma`` (~45 ms; depixel/arrays.py), neither
    the atomic write nor the spelling hints need ``tempfile`` or ``difflib`` (~3 and ~2 ms),
    a PNG needs no JPEG reader (~7 ms with the ``subprocess`` module it imports), and nothing
    imports ``numpy.random`` (~13 ms; the relaxation has no random draws); the options
    stamp takes CPython's own SHA-256, not OpenSSL's through ``hashlib`` (~4 ms); only the
    command run has its arguments and module (``depixel_cli.tools``, ``depixel_cli.inkscape.command``),
    and the help width does not need ``shutil`` (~4 ms)."""
    unneeded = ("cairosvg", "cairocffi", "scipy", "numpy.ma", "tempfile", "difflib", "numpy.random", "_hashlib",
                "shutil", "depixel_cli.tools", "depixel_cli.inkscape.command")
    if name.endswith(".png"):  # nor the JPEG decoder's chroma model (~3 ms)
        unneeded += ("PIL.JpegImagePlugin", "subprocess", "depixel.prepare.chroma", "depixel.prepare.chroma_unmix")
    code = (
        "import sys; from depixel_cli.main import main; "
        f"rc = main(['convert', {str(FIXTURES / name)!r}, '-o', {str(tmp_path / 'h.svg')!r}, '-q']); "
        f"print(rc, *(m for m in {unneeded!r} if m in sys.modules))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.stdout.split() == ["0"], run.stderr


def test_only_the_command_run_gets_its_arguments():
    """The other commands are listed with their help line alone (``depixel --help`` and a
    mistyped command show no more); the one asked for is defined in full."""
    from depixel_cli.main import build_parser, command_of

    assert command_of(["--debug", "convert", "a.png", "-o", "b.svg"]) == "convert"
    assert command_of(["--version"]) == "" and command_of([]) == ""

    def options(parser, name):
        sub = next(a for a in parser._actions if a.dest == "command")
        return {o for a in sub.choices[name]._actions for o in a.option_strings}

    every, only = build_parser(), build_parser("convert")
    assert options(only, "convert") == options(every, "convert") and "--out-dir" in options(only, "convert")
    assert options(only, "diff") == {"-h", "--help"} and "--max-ratio" in options(every, "diff")
    assert only.format_help() == every.format_help()


def test_help_width_is_the_terminal_width_as_shutil_finds_it(monkeypatch):
    from depixel_cli.main import _help_width

    monkeypatch.setenv("COLUMNS", "63")
    assert _help_width() == 61 == shutil.get_terminal_size().columns - 2
    monkeypatch.setenv("COLUMNS", "junk")
    assert _help_width() == shutil.get_terminal_size().columns - 2
    monkeypatch.delenv("COLUMNS")
    assert _help_width() == shutil.get_terminal_size().columns - 2
