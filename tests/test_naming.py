"""Where outputs go and what they are called: beside the input by default, ``--name
TEMPLATE``, and several formats in one pass (``--format svg,png``)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import FIXTURES
from PIL import Image

import depixel.api
from depixel.files import stamp as stamps
from depixel_cli.main import main
from depixel_cli.options import Exit


@pytest.fixture
def art(tmp_path, monkeypatch) -> Path:
    """A scratch folder holding sprite.png and an animated pair, mush.png and mush.gif (two frames)."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(FIXTURES / "heart.png", tmp_path / "sprite.png")
    (tmp_path / "art").mkdir()
    shutil.copy(FIXTURES / "mushroom.png", tmp_path / "art" / "mush.png")
    shutil.copy(FIXTURES / "heart_beat.gif", tmp_path / "art" / "mush.gif")
    return tmp_path


def names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def report(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


# --- 7. beside the input ------------------------------------------------------------------------

def test_without_o_the_svg_goes_beside_the_input(art, capsys):
    assert main(["convert", "sprite.png"]) == Exit.OK
    assert names(art) == ["art", "sprite.png", "sprite.svg"]
    # the same bytes as -o names (the stamp included): a one-file batch
    assert main(["convert", "sprite.png", "-o", "named.svg"]) == Exit.OK
    assert (art / "sprite.svg").read_bytes() == (art / "named.svg").read_bytes()
    # run again: up to date, not rewritten (the same rule as --out-dir)
    assert main(["convert", "sprite.png", "--json"]) == Exit.OK
    assert [o["status"] for o in report(capsys)["outputs"]] == ["up-to-date"]


def test_format_picks_the_extension_beside_the_input(art, capsys):
    assert main(["convert", "sprite.png", "--format", "pdf"]) == Exit.OK
    assert (art / "sprite.pdf").read_bytes().startswith(b"%PDF")
    capsys.readouterr()
    # a PNG beside a PNG would be the input itself: refused, with the way out
    assert main(["convert", "sprite.png", "--format", "png"]) == Exit.FAILED
    err = capsys.readouterr().err.splitlines()
    assert err == ["depixel: error: sprite.png: output sprite.png would overwrite an input; name the outputs "
                   "otherwise with --name, e.g. --name '{stem}-depixel'", err[-1]]
    assert err[-1].startswith("depixel: 1 file: 0 converted,")  # the summary line of every batch
    assert main(["convert", "sprite.png", "--format", "png", "--name", "{stem}-depixel"]) == Exit.OK
    assert Image.open(art / "sprite-depixel.png").size == Image.open(art / "sprite.png").size


def test_a_folder_without_out_dir_writes_beside_each_file_and_skips_its_own_pngs(art, capsys):
    (art / "art" / "deep").mkdir()
    shutil.copy(FIXTURES / "leaf.png", art / "art" / "deep" / "leaf.png")
    assert main(["convert", "art", "-r", "--format", "svg,png", "--name", "{stem}-{suffix}", "--json"]) == Exit.OK
    first = report(capsys)
    assert names(art / "art" / "deep") == ["leaf-png.png", "leaf-png.svg", "leaf.png"]
    assert first["ok"] == 3
    # the PNGs it wrote carry its stamp: the next run does not take them as inputs
    assert main(["convert", "art", "-r", "--format", "svg,png", "--name", "{stem}-{suffix}", "--json"]) == Exit.OK
    again = report(capsys)
    assert again["files"] == 3 and again["skipped"] == 3
    assert names(art / "art" / "deep") == ["leaf-png.png", "leaf-png.svg", "leaf.png"]


def test_help_says_where_outputs_go(capsys):
    with pytest.raises(SystemExit):
        main(["convert", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default: each output beside its input, sprite.png -> sprite.svg" in text
    assert "Without -o and --out-dir, each output is written beside its input (sprite.png -> sprite.svg)" in text
    assert "--name TEMPLATE" in text and "{suffix}" in text


# --- 5. --name and several formats ---------------------------------------------------------------

def test_a_collision_suggests_name_which_resolves_it(art, capsys):
    assert main(["convert", "art", "--out-dir", "out"]) == Exit.FAILED
    err = capsys.readouterr().err
    assert ("art/mush.png: output out/mush.svg is already the output of art/mush.gif; name the outputs apart "
            "with --name, e.g. --name '{stem}-{suffix}'") in err
    assert main(["convert", "art", "--out-dir", "out2", "--name", "{stem}-{suffix}"]) == Exit.OK
    assert names(art / "out2") == ["mush-gif.svg", "mush-png.svg"]


def test_name_fields_and_frames(art):
    assert main(["convert", "art/mush.gif", "--out-dir", "out", "--frames", "all",
                 "--name", "{suffix}_{stem}@{frame}x"]) == Exit.OK
    assert names(art / "out") == ["gif_mush@000x.svg", "gif_mush@001x.svg"]
    # without {frame}: the frame number follows the name, as without --name
    assert main(["convert", "art/mush.gif", "--out-dir", "out3", "--frames", "all", "--name", "{stem}-8x"]) == Exit.OK
    assert names(art / "out3") == ["mush-8x-000.svg", "mush-8x-001.svg"]
    # one frame asked for: {frame} is its number
    assert main(["convert", "art/mush.gif", "--out-dir", "out4", "--frames", "1", "--name", "{stem}.{frame}"]) == 0
    assert names(art / "out4") == ["mush.001.svg"]


def test_several_formats_in_one_pass_each_stamped(art, capsys, monkeypatch):
    runs = []
    real = depixel.api.depixelize
    monkeypatch.setattr(depixel.api, "depixelize", lambda *a, **k: runs.append(1) or real(*a, **k))
    assert main(["convert", "art/mush.gif", "--out-dir", "out", "--format", "svg,png,pdf", "--frames", "all",
                 "--scale", "4", "-j", "1", "--json"]) == Exit.OK
    outputs = report(capsys)["outputs"]
    assert [Path(o["output"]).name for o in outputs] == [
        "mush-000.svg", "mush-000.png", "mush-000.pdf", "mush-001.svg", "mush-001.png", "mush-001.pdf"]
    assert len(runs) == 2  # the pipeline once a frame, not once an output
    stamped = {Path(o["output"]).suffix: stamps.read(o["output"]) for o in outputs[:3]}
    assert None not in stamped.values() and len(set(stamped.values())) == 3
    # each is what converting to that format alone writes
    for fmt in ("svg", "png"):
        assert main(["convert", "art/mush.gif", "-o", f"alone.{fmt}", "--scale", "4"]) == Exit.OK
        assert (art / f"alone.{fmt}").read_bytes() == (art / "out" / f"mush-000.{fmt}").read_bytes()
    # a rerun skips all six
    assert main(["convert", "art/mush.gif", "--out-dir", "out", "--format", "svg,png,pdf", "--frames", "all",
                 "--scale", "4", "--json"]) == Exit.OK
    assert {o["status"] for o in report(capsys)["outputs"]} == {"up-to-date"}
