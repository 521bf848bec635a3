"""Nothing of the user's is overwritten (issue 35 findings 4 and 7, issue 33 items 4 and 6).

The stamp records the options, the input as read and a digest of the body depixel wrote:
an output edited since is kept and reported ``edited`` (exit 1), one without a stamp is
kept and reported ``kept``, both unless ``--force``; an input that changes while it is
converted is reported and its output never counts as up to date; ``--dry-run`` writes
nothing; every batch ends with a summary line. Real files throughout.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import pytest
from conftest import FIXTURES

from depixel.files import convert as files
from depixel.files import stamp as stamps
from depixel_cli.main import main
from depixel_cli.options import Exit

SUMMARY = re.compile(r"depixel: (\d+) files?: (\d+) converted, (\d+) up to date, (\d+) kept(, \d+ edited)?"
                     r"(, \d+ changed)?, (\d+) failed in [0-9.]+ s")


@pytest.fixture
def batch(tmp_path, capsys):
    """A folder of two inputs and a ``run(*extra) -> (exit code, {output name: status}, report)``
    converting it to ``out`` with --json."""
    src = tmp_path / "in"
    src.mkdir()
    for name in ("heart.png", "leaf.png"):
        shutil.copy(FIXTURES / name, src / name)

    def run(*extra: str) -> tuple[int, dict[str, str], dict]:
        code = main(["convert", str(src), "--out-dir", str(tmp_path / "out"), "--stage", "cells", "-j", "1",
                     "--json", *extra])
        report = json.loads(capsys.readouterr().out)
        return code, {Path(o["output"]).name: o["status"] for o in report["outputs"]}, report

    return src, tmp_path / "out", run


def png_with_comment(blob: bytes) -> bytes:
    """A PNG with a ``tEXt`` Comment chunk added before IEND, as an editor may add one."""
    body = b"tEXtComment\0touched up"
    return blob[:-12] + struct.pack(">I", len(body) - 4) + body + struct.pack(">I", zlib.crc32(body)) + blob[-12:]


@pytest.mark.parametrize("fmt", ["svg", "png", "pdf"])
def test_an_edited_output_is_kept_and_reported(batch, fmt):
    """Finding 4: an output depixel wrote and someone edited (the stamp still in it) is
    not replaced when its input changes: kept, ``edited`` in the JSON, exit 1; --force
    replaces it. An untouched one beside it is replaced as before."""
    src, out, run = batch
    assert run("--format", fmt)[:2] == (Exit.OK, {f"heart.{fmt}": "converted", f"leaf.{fmt}": "converted"})
    edited = out / f"heart.{fmt}"
    blob = edited.read_bytes()
    assert stamps.intact(blob)
    if fmt == "svg":  # what Inkscape does: the comment kept, something added
        edit = blob.replace(b"<svg ", b"<!-- touched up --><svg ", 1)
    elif fmt == "png":
        edit = png_with_comment(blob)
    else:
        edit = blob.replace(b"/Creator (depixel)", b"/Creator (Depixel)")
    assert edit != blob and stamps.parse(edit) == stamps.parse(blob) and not stamps.intact(edit)
    edited.write_bytes(edit)
    for name in ("heart.png", "leaf.png"):  # both inputs change
        shutil.copy(FIXTURES / "ghost.png", src / name)
    code, statuses, report = run("--format", fmt)
    assert code == Exit.FAILED
    assert statuses == {f"heart.{fmt}": "edited", f"leaf.{fmt}": "converted"}
    assert report["edited"] == 1 and report["ok"] == 1 and report["failed"] == []
    assert "edited since depixel wrote it" in next(o["reason"] for o in report["outputs"] if o["status"] == "edited")
    assert edited.read_bytes() == edit
    assert run("--format", fmt, "--force")[:2] == (Exit.OK, {f"heart.{fmt}": "converted", f"leaf.{fmt}": "converted"})
    assert stamps.intact(edited.read_bytes())


def test_an_output_depixel_did_not_write_is_kept(batch):
    """Issue 33 item 4: a file without a stamp (written by hand, or saved by a tool that
    strips comments) is never overwritten in a batch: kept with the reason, exit 0;
    --force replaces it."""
    src, out, run = batch
    out.mkdir()
    (out / "heart.svg").write_text("<svg xmlns='http://www.w3.org/2000/svg'/>")
    code, statuses, report = run()
    assert (code, statuses) == (Exit.OK, {"heart.svg": "kept", "leaf.svg": "converted"})
    assert report["kept"] == 1 and "no depixel stamp" in report["outputs"][0]["reason"]
    assert (out / "heart.svg").read_text() == "<svg xmlns='http://www.w3.org/2000/svg'/>"
    # a stamped output whose stamp a tool stripped is no longer known to be depixel's: kept
    stripped = re.sub(rb"<!--.*?-->\n?", b"", (out / "leaf.svg").read_bytes())
    (out / "leaf.svg").write_bytes(stripped)
    shutil.copy(FIXTURES / "ghost.png", src / "leaf.png")
    assert run()[1] == {"heart.svg": "kept", "leaf.svg": "kept"}
    assert (out / "leaf.svg").read_bytes() == stripped
    assert run("--force")[1] == {"heart.svg": "converted", "leaf.svg": "converted"}


def test_untouched_outputs_are_overwritten_and_up_to_date_ones_skipped(batch):
    """The rule for outputs depixel wrote: made from this input with these options, up to
    date (a touched input with the same bytes too); otherwise replaced."""
    src, out, run = batch
    run()
    os.utime(src / "heart.png", ns=(1, 1))  # only the mtime moves (a checkout, a touch)
    assert run()[1] == {"heart.svg": "up-to-date", "leaf.svg": "up-to-date"}
    shutil.copy(FIXTURES / "ghost.png", src / "heart.png")
    os.utime(src / "heart.png", ns=(1, 1))  # other bytes, even with an older mtime
    assert run()[1] == {"heart.svg": "converted", "leaf.svg": "up-to-date"}
    assert run("--precision", "1")[1] == {"heart.svg": "converted", "leaf.svg": "converted"}


def test_dry_run_writes_nothing_and_says_what_would_happen(batch, capsys):
    src, out, run = batch
    run()
    (out / "leaf.svg").write_text("mine")
    shutil.copy(FIXTURES / "ghost.png", src / "heart.png")
    shutil.copy(FIXTURES / "ghost.png", src / "new.png")
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in out.iterdir()}
    code, statuses, report = run("--dry-run")
    assert code == Exit.OK and report["dry_run"] is True
    assert statuses == {"heart.svg": "to-convert", "leaf.svg": "kept", "new.svg": "to-convert"}
    assert {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in out.iterdir()} == before
    (src / "broken.png").write_bytes(b"not an image")
    assert main(["convert", str(src), "--out-dir", str(out / "sub"), "--dry-run"]) == Exit.FAILED
    listed = capsys.readouterr()
    assert not (out / "sub").exists()  # not even the folder
    assert sorted(line.split()[0] for line in listed.out.splitlines()) == ["failed", "would", "would", "would"]
    assert re.fullmatch(r"depixel: 4 files: 3 to convert, 0 up to date, 0 kept, 1 failed "
                        r"\(dry run: nothing written\) in [0-9.]+ s", listed.err.strip()), listed.err


def test_convert_o_overwrites_only_what_depixel_wrote(tmp_path, capsys):
    """``-o FILE`` (docs/cli.md): a stamped output is converted again even when up to date;
    an existing file depixel did not write, or one edited since, is an error (exit 1) and is
    left as it was, unless --force."""
    target = tmp_path / "heart.svg"
    argv = ["convert", str(FIXTURES / "heart.png"), "-o", str(target), "--stage", "cells"]
    target.write_text("my drawing")
    assert main(argv) == Exit.FAILED
    assert "heart.svg: not written by depixel" in capsys.readouterr().err
    assert target.read_text() == "my drawing"
    assert main(argv + ["--force"]) == Exit.OK
    first = target.stat().st_mtime_ns
    assert main(argv) == Exit.OK and target.stat().st_mtime_ns >= first  # depixel's own: rewritten
    target.write_bytes(target.read_bytes().replace(b"<svg ", b"<!-- mine --><svg ", 1))
    assert main(argv) == Exit.FAILED
    assert "edited since depixel wrote it" in capsys.readouterr().err
    assert b"<!-- mine -->" in target.read_bytes()
    # devices are not files anyone edits: written as before
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", os.devnull, "--format", "svg"]) == Exit.OK


def test_stdin_to_a_file_is_stamped_and_never_up_to_date(tmp_path):
    target = tmp_path / "s.svg"
    argv = [sys.executable, "-m", "depixel", "convert", "-", "-o", str(target), "--stage", "cells"]
    for _ in range(2):  # the second run replaces depixel's own output
        run = subprocess.run(argv, input=(FIXTURES / "heart.png").read_bytes(), capture_output=True, timeout=120)
        assert run.returncode == 0, run.stderr
    found = stamps.parse(target.read_bytes())
    assert found is not None and found.identity is None and stamps.intact(target.read_bytes())


def test_an_input_changed_during_its_conversion_is_reported_and_converted_again(batch, monkeypatch):
    """Finding 7: the input replaced while it is converted: ``changed during conversion``,
    exit 1; the output is of the version read and is not up to date: the next run converts
    the new input, and the one after finds it up to date."""
    src, out, run = batch
    real = files.conversions

    def replaced_meanwhile(*args, **kwargs):
        if kwargs["title"] == "heart.png":  # after the read, before the write
            shutil.copy(FIXTURES / "ghost.png", src / "heart.png")
        return real(*args, **kwargs)

    monkeypatch.setattr(files, "conversions", replaced_meanwhile)
    code, statuses, report = run()
    monkeypatch.undo()
    assert code == Exit.FAILED and report["changed"] == 1
    assert statuses == {"heart.svg": "changed", "leaf.svg": "converted"}
    assert "heart.png: changed during conversion" in report["outputs"][0]["reason"]
    assert run()[1] == {"heart.svg": "converted", "leaf.svg": "up-to-date"}
    ghost = out.parent / "ghost.svg"
    assert main(["convert", str(FIXTURES / "ghost.png"), "-o", str(ghost), "--stage", "cells"]) == Exit.OK
    strip = re.compile(rb"<!--.*?-->\n|<title>.*?</title>")  # the stamp and the file's name
    assert strip.sub(b"", (out / "heart.svg").read_bytes()) == strip.sub(b"", ghost.read_bytes())
    assert run()[1] == {"heart.svg": "up-to-date", "leaf.svg": "up-to-date"}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_an_input_replaced_under_a_real_conversion(tmp_path):
    """Finding 7 as reported: a sprite converted to PNG at --scale 8, replaced once the
    conversion runs (a second process, a real file)."""
    from test_temporary_files import converting, noise

    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    noise(src / "s.png", 200)
    noise(tmp_path / "other.png", 32)  # (converted again below: small is enough)
    argv = [sys.executable, "-m", "depixel", "convert", str(src), "--out-dir", str(out), "--format", "png",
            "--scale", "8"]
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True)
    converting(proc)
    shutil.copy(tmp_path / "other.png", src / "s.png")
    _, err = proc.communicate(timeout=300)
    if proc.returncode == 0:
        pytest.skip("finished before the input was replaced")
    assert proc.returncode == 1 and "changed during conversion" in err, err
    again = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and SUMMARY.search(again.stderr).group(2) == "1", again.stderr


def test_every_batch_ends_with_a_summary_line_and_json_has_bytes_and_seconds(tmp_path):
    """Issue 33 item 6: without a terminal, a batch still prints its summary line on stderr;
    the JSON gives every written output's bytes and seconds."""
    src = tmp_path / "in"
    src.mkdir()
    for name in ("heart.png", "leaf.png", "ghost.png"):
        shutil.copy(FIXTURES / name, src / name)
    (src / "broken.png").write_bytes(b"not an image")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "ghost.svg").write_text("mine")
    argv = [sys.executable, "-m", "depixel", "convert", str(src), "--out-dir", str(tmp_path / "out"),
            "--stage", "cells"]
    run = subprocess.run(argv + ["--json"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    summary = SUMMARY.fullmatch(run.stderr.strip().splitlines()[-1])
    assert summary is not None, run.stderr
    assert summary.group(1, 2, 3, 4, 7) == ("4", "2", "0", "1", "1")
    report = json.loads(run.stdout)
    for entry in (o for o in report["outputs"] if o["status"] == "converted"):
        assert entry["bytes"] == Path(entry["output"]).stat().st_size and entry["seconds"] >= 0
    again = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert SUMMARY.fullmatch(again.stderr.strip().splitlines()[-1]).group(2, 3, 4) == ("0", "2", "1")
