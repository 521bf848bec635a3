"""``depixel convert --out-dir DIR --prune`` (issue 45): a kept build folder mirrors its inputs.

The outputs whose inputs are gone are removed, and only those: never a file depixel did
not write, one edited since, one of another format, anything outside DIR or reached
through a symbolic link; nothing at all when an input argument gave no file. Each removal
is reported, in ``--json`` and in the summary line; ``--dry-run`` lists them. The real
command on real files throughout.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import FIXTURES

DEPIXEL = [sys.executable, "-m", "depixel"]


def depixel(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*DEPIXEL, *args], cwd=cwd, capture_output=True, text=True, timeout=300)


def files_in(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() or p.is_symlink())


@pytest.fixture
def built(tmp_path) -> Path:
    """``art/`` (heart.png, leaf.png, items/chip.png, items/old/mushroom.png) converted with -r
    into ``build/``; the current folder of every command."""
    art = tmp_path / "art"
    (art / "items" / "old").mkdir(parents=True)
    for name, where in (("heart.png", "heart.png"), ("leaf.png", "leaf.png"), ("chip.png", "items/chip.png"),
                        ("mushroom.png", "items/old/mushroom.png")):
        shutil.copy(FIXTURES / name, art / where)
    done = depixel("convert", "art", "-r", "--out-dir", "build", "-j", "1", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert files_in(tmp_path / "build") == ["heart.svg", "items/chip.svg", "items/old/mushroom.svg", "leaf.svg"]
    return tmp_path


def test_the_outputs_of_deleted_inputs_are_removed_and_reported(built):
    (built / "art" / "leaf.png").unlink()
    (built / "art" / "items" / "old" / "mushroom.png").unlink()
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "-j", "1", cwd=built)
    assert done.returncode == 0, done.stderr
    assert files_in(built / "build") == ["heart.svg", "items/chip.svg"]  # the emptied folder went too
    assert not (built / "build" / "items" / "old").exists()
    lines = done.stderr.splitlines()
    assert "depixel: removed build/leaf.svg (its input is gone)" in lines
    assert "depixel: removed build/items/old/mushroom.svg (its input is gone)" in lines
    assert re.fullmatch(r"depixel: 2 files: 0 converted, 2 up to date, 0 kept, 0 failed, 2 removed in [0-9.]+ s",
                        lines[-1]), lines[-1]
    again = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "--json", "-j", "1", cwd=built)
    report = json.loads(again.stdout)
    assert again.returncode == 0 and report["removed"] == 0
    assert files_in(built / "build") == ["heart.svg", "items/chip.svg"]


def test_json_lists_each_removal(built):
    (built / "art" / "heart.png").unlink()
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "--json", "-j", "1", cwd=built)
    report = json.loads(done.stdout)
    assert done.returncode == 0 and report["removed"] == 1
    assert {"output": "build/heart.svg", "input": None, "status": "removed"} in report["outputs"]
    assert not (built / "build" / "heart.svg").exists()


def test_dry_run_lists_what_would_go_and_removes_nothing(built):
    (built / "art" / "leaf.png").unlink()
    before = files_in(built / "build")
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "--dry-run", cwd=built)
    assert done.returncode == 0, done.stderr
    assert "would remove   build/leaf.svg (its input is gone)" in done.stdout.splitlines()
    assert ", 1 to remove (dry run: nothing written)" in done.stderr
    assert files_in(built / "build") == before
    report = json.loads(depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "--dry-run", "--json",
                                cwd=built).stdout)
    assert {"output": "build/leaf.svg", "input": None, "status": "to-remove"} in report["outputs"]
    assert files_in(built / "build") == before


def test_what_depixel_did_not_write_or_that_was_edited_stays(built):
    """An unstamped file, an edited output, an output with a stamp too old to tell an edit,
    another format's output and a hidden file stay, whose inputs are all gone."""
    build = built / "build"
    (build / "mine.svg").write_text("<svg xmlns='http://www.w3.org/2000/svg'/>")  # the user's
    text = (build / "leaf.svg").read_text()
    (build / "leaf.svg").write_text(text.replace("<svg ", "<svg data-edited='1' ", 1))  # edited
    old = (build / "items" / "chip.svg").read_text()
    (build / "items" / "chip.svg").write_text(re.sub(r"(depixel-options:[0-9a-f]{16})[^ ]*", r"\1", old))
    shutil.copy(build / "heart.svg", build / ".hidden.svg")
    other = depixel("convert", "art/heart.png", "-o", "build/heart.png", cwd=built)  # a stamped PNG
    assert other.returncode == 0, other.stderr
    for name in ("leaf.png", "items/chip.png", "heart.png"):
        (built / "art" / name).unlink()
    kept = {p: (build / p).read_bytes() for p in ("mine.svg", "leaf.svg", "items/chip.svg", ".hidden.svg",
                                                  "heart.png")}
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "--json", "-j", "1", cwd=built)
    assert done.returncode == 0, done.stderr
    assert {p: (build / p).read_bytes() for p in kept} == kept
    assert not (build / "heart.svg").exists()  # the one output as depixel wrote it
    report = json.loads(done.stdout)
    assert report["removed"] == 1
    reasons = {o["output"]: o["reason"] for o in report["outputs"] if o["input"] is None and o["status"] == "kept"}
    assert set(reasons) == {"build/leaf.svg", "build/items/chip.svg"}
    assert "edited since depixel wrote it" in reasons["build/leaf.svg"]
    assert "too old to tell" in reasons["build/items/chip.svg"]
    assert "depixel: note: build/leaf.svg: its input is gone, but it was edited since depixel wrote it; " \
           "not removed" in done.stderr.splitlines()


def test_nothing_outside_the_folder_or_through_a_link_is_removed(built, tmp_path):
    """A linked folder and a linked file inside the build folder lead to stamped outputs
    elsewhere, whose inputs are not among the run's: neither the links nor what they lead to
    are removed."""
    outside = tmp_path / "outside"
    shutil.copytree(built / "build", outside)  # depixel's outputs, as it wrote them
    (built / "build" / "linked").symlink_to(outside, target_is_directory=True)
    (built / "build" / "alias.svg").symlink_to(outside / "heart.svg")
    before = files_in(outside)
    (built / "art" / "leaf.png").unlink()
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "-j", "1", cwd=built)
    assert done.returncode == 0, done.stderr
    assert files_in(outside) == before
    assert (built / "build" / "linked").is_symlink() and (built / "build" / "alias.svg").is_symlink()
    assert not (built / "build" / "leaf.svg").exists()
    assert "removed build/leaf.svg" in done.stderr and done.stderr.count("removed build/") == 1


def test_an_input_that_gave_no_file_removes_nothing(built):
    """A mistyped folder must not empty the build folder: nothing removed, one error, exit 1."""
    before = files_in(built / "build")
    done = depixel("convert", "atr", "-r", "--out-dir", "build", "--prune", cwd=built)
    assert done.returncode == 1
    assert "depixel: error: --prune: nothing removed, since atr gave no input (a mistyped folder would " \
           "empty --out-dir)" in done.stderr.splitlines()
    assert files_in(built / "build") == before


def test_without_r_only_the_folders_the_run_writes_into_are_looked_at(built):
    (built / "art" / "items" / "chip.png").unlink()
    (built / "art" / "leaf.png").unlink()
    done = depixel("convert", "art", "--out-dir", "build", "--prune", "-j", "1", cwd=built)
    assert done.returncode == 0, done.stderr
    assert files_in(built / "build") == ["heart.svg", "items/chip.svg", "items/old/mushroom.svg"]


def test_prune_needs_an_output_folder(built):
    for args in (["art"], ["art/heart.png", "-o", "x.svg"]):
        done = depixel("convert", *args, "--prune", cwd=built)
        assert done.returncode == 2 and "--prune removes the outputs in --out-dir DIR" in done.stderr
        assert len(done.stderr.strip().splitlines()) == 1
    assert not (built / "x.svg").exists() and not (built / "art" / "heart.svg").exists()


def test_the_runs_outputs_of_an_input_that_fails_stay(built):
    """An input that is there but cannot be converted is not gone: its old output stays."""
    (built / "art" / "leaf.png").write_bytes(b"not a picture any more")
    done = depixel("convert", "art", "-r", "--out-dir", "build", "--prune", "-j", "1", cwd=built)
    assert done.returncode == 1 and "art/leaf.png: not an image" in done.stderr
    assert (built / "build" / "leaf.svg").is_file() and "depixel: removed" not in done.stderr


def test_an_output_that_cannot_be_removed_is_an_error(built, monkeypatch, capsys):
    """(In this process, the removal made to fail: a root user may remove anything.)"""
    from depixel_cli.main import main

    (built / "art" / "items" / "chip.png").unlink()
    real_unlink = os.unlink

    def unlink(path, *args, **kwargs):
        if Path(path).name == "chip.svg":
            raise PermissionError(13, "Permission denied")
        return real_unlink(path, *args, **kwargs)

    monkeypatch.setattr(os, "unlink", unlink)
    monkeypatch.chdir(built)
    assert main(["convert", "art", "-r", "--out-dir", "build", "--prune", "-j", "1"]) == 1
    err = capsys.readouterr().err
    assert "depixel: error: build/items/chip.svg: its input is gone, but it cannot be removed (Permission " \
           "denied)" in err.splitlines()
    assert (built / "build" / "items" / "chip.svg").is_file()
