"""What ``depixel convert`` reports of existing outputs and inputs (issue 45, the first hour).

* A hand-edited output is ``edited`` on every run, also while its input is unchanged (it
  was reported ``up-to-date``), and kept.
* An output whose stamp is from before the body digest cannot be told edited or not: it is
  kept (``kept``, with the reason) unless ``--force``, never overwritten and reported
  ``converted``.
* ``--dry-run`` decodes each input it would convert, so a corrupt one fails as the real run
  fails it.
* ``--name '{suffix}'`` on a file without extension is refused for that file (it wrote a
  hidden ``.svg``).

The real command on real files throughout.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import FIXTURES


def depixel(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "depixel", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def statuses(done: subprocess.CompletedProcess) -> dict[str, str]:
    return {o["output"]: o["status"] for o in json.loads(done.stdout)["outputs"]}


@pytest.fixture
def built(tmp_path) -> Path:
    """``art/heart.png`` and ``art/leaf.png`` converted into ``out/``."""
    (tmp_path / "art").mkdir()
    for name in ("heart.png", "leaf.png"):
        shutil.copy(FIXTURES / name, tmp_path / "art" / name)
    assert depixel("convert", "art", "--out-dir", "out", "-j", "1", cwd=tmp_path).returncode == 0
    return tmp_path


def test_an_output_edited_by_hand_is_edited_on_every_run(built):
    svg = built / "out" / "heart.svg"
    edited = svg.read_text().replace("<svg ", "<svg data-mine='1' ", 1)
    svg.write_text(edited)
    for _ in range(2):
        done = depixel("convert", "art", "--out-dir", "out", "--json", "-j", "1", cwd=built)
        assert done.returncode == 1
        assert statuses(done) == {"out/heart.svg": "edited", "out/leaf.svg": "up-to-date"}
        assert json.loads(done.stdout)["edited"] == 1
        assert re.search(r"2 files: 0 converted, 1 up to date, 0 kept, 1 edited, 0 failed in", done.stderr)
        assert "depixel: error: out/heart.svg: edited since depixel wrote it" in done.stderr
        assert svg.read_text() == edited
    listed = depixel("convert", "art", "--out-dir", "out", "--dry-run", cwd=built)
    assert listed.stdout.splitlines()[0].startswith("edited         out/heart.svg: edited since depixel wrote it")
    assert depixel("convert", "art", "--out-dir", "out", "--force", "-j", "1", cwd=built).returncode == 0
    assert "data-mine" not in svg.read_text()


@pytest.mark.parametrize("fmt", ["svg", "png"])
def test_an_old_stamp_edited_by_hand_is_kept_unless_forced(built, fmt):
    """A stamp with the options only (before issue 35): an edit cannot be told, so the
    output is kept, with the reason; ``--force`` replaces it with a complete stamp."""
    if fmt == "png":
        assert depixel("convert", "art", "--out-dir", "out", "--format", "png", "-j", "1", cwd=built).returncode == 0
    out = built / "out" / f"heart.{fmt}"
    blob = out.read_bytes()
    found = re.search(rb"depixel-options:[0-9a-f]{16}(;[^ \0]*body=[0-9a-f]{16})", blob)
    old = blob.replace(found.group(1), b"")  # the old format's stamp, its length changed (a PNG's chunk is
    if fmt == "png":  # then broken: fixed here, as the old depixel wrote it)
        old = _rechunk(old)
    old += b"<!-- edited -->" if fmt == "svg" else b""
    out.write_bytes(old)
    done = depixel("convert", "art", "--out-dir", "out", "--format", fmt, "--json", "-j", "1", cwd=built)
    assert done.returncode == 0, done.stderr
    assert out.read_bytes() == old
    entry = next(o for o in json.loads(done.stdout)["outputs"] if o["output"] == f"out/heart.{fmt}")
    assert entry["status"] == "kept" and "too old to tell whether it was edited" in entry["reason"]
    assert f"depixel: note: out/heart.{fmt}: written by a depixel too old to tell whether it was edited since " \
           "(its stamp has no body digest); kept, --force overwrites it" in done.stderr.splitlines()
    single = depixel("convert", "art/heart.png", "-o", f"out/heart.{fmt}", cwd=built)  # a named output: an error
    assert single.returncode == 1 and out.read_bytes() == old
    forced = depixel("convert", "art", "--out-dir", "out", "--format", fmt, "--force", "--json", "-j", "1", cwd=built)
    assert forced.returncode == 0 and statuses(forced)[f"out/heart.{fmt}"] == "converted"
    assert re.search(rb";body=[0-9a-f]{16}", out.read_bytes())


def _rechunk(png: bytes) -> bytes:
    """``png`` with the length and CRC of its depixel-options ``tEXt`` chunk made right."""
    import struct
    import zlib

    at = png.index(b"tEXtdepixel-options") - 4
    end = png.index(b"IEND") - 4
    body = png[at + 4:end - 4]
    return png[:at] + struct.pack(">I", len(body) - 4) + body + struct.pack(">I", zlib.crc32(body)) + png[end:]


def corrupt_png(path: Path) -> None:
    """A PNG whose header reads but whose pixel data is damaged."""
    blob = bytearray((FIXTURES / "mushroom.png").read_bytes())
    at = blob.index(b"IDAT") + 8
    blob[at:at + 16] = bytes(b ^ 0x55 for b in blob[at:at + 16])
    path.write_bytes(bytes(blob))


def test_dry_run_fails_a_corrupt_input_as_the_run_does(built):
    corrupt_png(built / "art" / "broken.png")
    (built / "art" / "cut.png").write_bytes((FIXTURES / "heart.png").read_bytes()[:120])  # truncated
    dry = depixel("convert", "art", "--out-dir", "out2", "--dry-run", "--json", cwd=built)
    real = depixel("convert", "art", "--out-dir", "out2", "--json", "-j", "1", cwd=built)
    assert dry.returncode == real.returncode == 1
    failed = {f["input"]: f["error"] for f in json.loads(dry.stdout)["failed"]}
    assert failed == {f["input"]: f["error"] for f in json.loads(real.stdout)["failed"]}
    assert failed == {"art/broken.png": "art/broken.png: truncated or corrupt image data",
                      "art/cut.png": "art/cut.png: truncated or corrupt image data"}
    assert statuses(dry) == {"out2/heart.svg": "to-convert", "out2/leaf.svg": "to-convert",
                             "out2/broken.svg": "failed", "out2/cut.svg": "failed"}
    listed = depixel("convert", "art/broken.png", "-o", "one.svg", "--dry-run", cwd=built)
    assert listed.returncode == 1
    assert listed.stdout == "failed         art/broken.png: truncated or corrupt image data\n"


@pytest.mark.parametrize("whole", [["--frames", "all"], ["--animate"]])
def test_dry_run_fails_a_corrupt_frame_of_an_animation(built, whole):
    """``--frames all`` and ``--animate`` decode every frame, as the conversion does."""
    blob = (FIXTURES / "heart_beat.gif").read_bytes()
    (built / "art" / "beat.gif").write_bytes(blob[:-8])  # its frames all counted, the last one's data cut
    dry = depixel("convert", "art/beat.gif", "--out-dir", "anim", *whole, "--dry-run", cwd=built)
    real = depixel("convert", "art/beat.gif", "--out-dir", "anim", *whole, "-j", "1", cwd=built)
    assert real.returncode == 1 and dry.returncode == 1, (real.stderr, dry.stdout)
    assert dry.stdout.startswith("failed         art/beat.gif: ")
    assert dry.stdout.split("art/beat.gif: ", 1)[1].strip() in real.stderr


def test_a_name_that_is_empty_for_a_file_is_refused_for_that_file(built):
    shutil.copy(FIXTURES / "heart.png", built / "art" / "sprite")  # no extension
    done = depixel("convert", "art/sprite", "art/leaf.png", "--out-dir", "named", "--name", "{suffix}", "-j", "1",
                   cwd=built)
    assert done.returncode == 1
    assert "depixel: error: art/sprite: --name '{suffix}' names nothing for it (it has no extension); e.g. " \
           "--name '{stem}-{suffix}'" in done.stderr.splitlines()
    assert sorted(p.name for p in (built / "named").iterdir()) == ["png.svg"]  # no hidden .svg
