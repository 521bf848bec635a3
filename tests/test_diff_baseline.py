"""``depixel diff BASELINE CURRENT`` against a hostile or unlucky file tree: ``--update`` and
``--prune`` never write or delete outside the baseline (symbolic links), report folders
never swallow the other outputs or the compared folders, an update stopped half-way says
what it changed, and report folders and temporary files of earlier runs are never
compared, copied or left behind. Each test runs the command (``main`` in this process, or
the ``depixel`` program for signals) on real files."""
from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from depixel.diff.staging import MARKER
from depixel_cli.main import main
from depixel_cli.options import Exit


def sprite(path: Path, colour: tuple[int, int, int], size: int = 8) -> Path:
    """A ``size``×``size`` PNG: black with a square of ``colour`` in its middle."""
    pixels = np.zeros((size, size, 4), np.uint8)
    pixels[..., 3] = 255
    pixels[size // 4:3 * size // 4, size // 4:3 * size // 4, :3] = colour
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels, "RGBA").save(path)
    return path


def digests(*folders: Path) -> dict[str, str]:
    """Every file under the folders (links not followed) → its content's digest."""
    found = {}
    for folder in folders:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and not path.is_symlink():
                found[str(path)] = hashlib.sha1(path.read_bytes()).hexdigest()
    return found


def run(*argv: str, capsys) -> tuple[int, str, str]:
    try:
        code = main(["diff", *argv])
    except SystemExit as exc:  # argparse's usage errors
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


RECORD = ".depixel-update.log"  # depixel.diff.update.RECORD: what an update keeps while it runs
RED, GREEN, BLUE, GREY = (255, 0, 0), (0, 255, 0), (0, 0, 255), (90, 90, 90)


# --- symbolic links: never written or deleted through ------------------------------------

def test_update_never_writes_through_a_linked_subfolder_that_leaves_the_baseline(tmp_path, capsys):
    outside = tmp_path / "outside"
    sprite(outside / "b.png", RED)
    base, cur = tmp_path / "base", tmp_path / "cur"
    sprite(base / "a.png", GREY)
    (base / "sub").symlink_to("../outside")
    sprite(cur / "a.png", GREEN)  # a change that may be approved
    sprite(cur / "sub" / "b.png", BLUE)
    before = digests(base, outside)
    code, out, err = run(str(base), str(cur), "--update", "--prune", capsys=capsys)
    assert code == Exit.USAGE
    assert digests(base, outside) == before  # refused before anything changed
    assert "different: sub/b.png" in out  # the verdicts are still printed
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "sub/b.png" in lines[0] and "symbolic link" in lines[0] \
        and "nothing was changed" in lines[0], err
    # the linked folder is compared (followed), not taken for missing files
    assert "missing" not in out and "new:" not in out


def test_update_replaces_a_linked_file_not_what_it_points_to(tmp_path, capsys):
    users = sprite(tmp_path / "outside" / "users.png", GREEN)
    kept = users.read_bytes()
    base, cur = tmp_path / "base", tmp_path / "cur"
    (base / "art").mkdir(parents=True)
    (base / "art" / "x.png").symlink_to("../../outside/users.png")
    sprite(cur / "art" / "x.png", BLUE)
    code, out, _ = run(str(base), str(cur), "--update", capsys=capsys)
    assert code == Exit.OK and "updated: art/x.png" in out
    assert users.read_bytes() == kept  # the user's file is untouched
    assert not (base / "art" / "x.png").is_symlink()
    assert (base / "art" / "x.png").read_bytes() == (cur / "art" / "x.png").read_bytes()


def test_update_keeps_baselines_deduplicated_by_a_link_apart(tmp_path, capsys):
    base, cur = tmp_path / "base", tmp_path / "cur"
    a = sprite(base / "a.png", GREY)
    (base / "b.png").symlink_to("a.png")
    sprite(cur / "a.png", GREY)
    sprite(cur / "b.png", RED)  # b changes, a does not
    assert (cur / "a.png").read_bytes() == a.read_bytes()
    code, out, _ = run(str(base), str(cur), "--update", capsys=capsys)
    assert code == Exit.OK and "updated: b.png" in out and "updated: a.png" not in out
    assert (base / "a.png").read_bytes() == (cur / "a.png").read_bytes()
    assert run(str(base), str(cur), capsys=capsys)[0] == Exit.OK  # a.png did not become b


def test_prune_removes_a_link_never_its_target(tmp_path, capsys):
    users = sprite(tmp_path / "outside" / "users.png", GREEN)
    base, cur = tmp_path / "base", tmp_path / "cur"
    sprite(base / "a.png", GREY)
    (base / "gone.png").symlink_to(users)
    sprite(cur / "a.png", GREY)
    code, out, _ = run(str(base), str(cur), "--update", "--prune", capsys=capsys)
    assert code == Exit.OK and "removed: gone.png" in out
    assert not os.path.lexists(base / "gone.png") and users.exists()


def test_symlinked_subfolders_of_the_current_folder_are_followed_so_prune_keeps_theirs(tmp_path, capsys):
    base, cur, shared = tmp_path / "base", tmp_path / "cur", tmp_path / "shared"
    sprite(base / "a.png", GREY)
    sprite(base / "icons" / "i.png", RED)
    sprite(shared / "i.png", RED)
    sprite(cur / "a.png", GREY)
    (cur / "icons").symlink_to(shared)
    (cur / "loop").symlink_to(".")  # a link back to a folder it lies in: not followed forever
    code, out, _ = run(str(base), str(cur), "--update", "--prune", capsys=capsys)
    assert code == Exit.OK and "removed" not in out
    assert (base / "icons" / "i.png").exists()
    assert out.splitlines()[-1].startswith("same after --update: 2 files: 2 same")


# --- requested outputs never inside one another, nor over the compared folders -----------

@pytest.fixture
def changed(tmp_path) -> tuple[Path, Path]:
    base, cur = tmp_path / "base", tmp_path / "cur"
    sprite(base / "a.png", GREY)
    sprite(cur / "a.png", RED)
    return base, cur


@pytest.mark.parametrize("outputs", [
    ["--html", "report", "--junit", "report/junit.xml"],
    ["--html", "rep", "--diff-out", "rep/diffs"],
    ["--html", "X", "--diff-out", "X"],
    ["--diff-out", "d", "--html", "d/html"],
])
def test_outputs_inside_a_report_folder_are_refused_up_front(changed, tmp_path, capsys, outputs):
    base, cur = changed
    argv = [str(base), str(cur)] + [str(tmp_path / v) if not v.startswith("--") else v for v in outputs]
    code, out, err = run(*argv, capsys=capsys)
    assert code == Exit.USAGE and out == ""
    assert err.count("\n") == 1 and "folder replaced whole" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["base", "cur"]  # nothing written


@pytest.mark.parametrize("which", ["baseline", "current"])
def test_a_report_folder_may_not_be_a_compared_folder(tmp_path, capsys, which):
    base, cur = tmp_path / "base", tmp_path / "cur"
    base.mkdir()  # an empty baseline: a folder a report may replace
    sprite(cur / "a.png", RED)
    folder = base if which == "baseline" else cur
    code, out, err = run(str(base), str(cur), "--update", "--html", str(folder), capsys=capsys)
    assert code == Exit.USAGE and err.count("\n") == 1 and f"is the {which}" in err, err
    assert not (base / "a.png").exists() and (cur / "a.png").exists()
    code, _, err = run(str(base), str(cur), "--diff-out", str(tmp_path), capsys=capsys)
    assert code == Exit.USAGE and "holds the baseline" in err


def test_each_output_is_kept_when_they_are_apart(changed, tmp_path, capsys):
    base, cur = changed
    code, _, _ = run(str(base), str(cur), "--html", str(tmp_path / "rep"), "--diff-out", str(tmp_path / "diffs"),
                     "--junit", str(tmp_path / "rep-junit.xml"), capsys=capsys)
    assert code == Exit.FAILED
    assert (tmp_path / "rep" / "index.html").is_file() and (tmp_path / "diffs" / "a.png.diff.png").is_file()
    assert (tmp_path / "rep-junit.xml").is_file()


# --- report folders inside the current folder ---------------------------------------------

def test_a_report_inside_the_current_folder_is_never_compared_nor_approved(changed, capsys):
    base, cur = changed
    assert run(str(base), str(cur), "--html", str(cur / "report"), "--diff-out", str(cur / "diffs"),
               capsys=capsys)[0] == Exit.FAILED
    assert (cur / "report" / MARKER).is_file() and (cur / "report" / "images" / "a.png.diff.png").is_file()
    code, out, _ = run(str(base), str(cur), "--update", "--prune", capsys=capsys)
    assert code == Exit.OK
    assert out.splitlines()[-1] == "same after --update: 1 file: 1 different"
    assert sorted(p.name for p in base.iterdir()) == ["a.png"]  # no picture of the report copied


def test_html_onto_a_symbolic_link_replaces_the_folder_it_points_to(changed, tmp_path, capsys):
    base, cur = changed
    (tmp_path / "reports" / "latest").mkdir(parents=True)
    (tmp_path / "report").symlink_to("reports/latest")
    for _ in range(2):
        assert run(str(base), str(cur), "--html", str(tmp_path / "report"), capsys=capsys)[0] == Exit.FAILED
    assert (tmp_path / "report").is_symlink() and (tmp_path / "reports" / "latest" / "index.html").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["base", "cur", "report", "reports"]  # no stray .old
    assert sorted(p.name for p in (tmp_path / "reports").iterdir()) == ["latest"]


# --- an update stopped half-way -------------------------------------------------------------

def test_an_update_stopped_by_a_file_it_cannot_write_says_what_it_changed(tmp_path, capsys):
    base, cur = tmp_path / "base", tmp_path / "cur"
    for name in ("a.png", "z.png"):
        sprite(base / name, GREY)
        sprite(cur / name, RED)
    (base / "m").write_text("a file where the current folder has a folder")
    sprite(cur / "m" / "new.png", BLUE)
    code, out, err = run(str(base), str(cur), "--update", capsys=capsys)
    assert code == Exit.USAGE
    assert "updated: a.png" in out and "z.png" not in out.split("updated: a.png")[1].split("\n")[1]
    assert "updated: z.png" not in out
    assert err.count("\n") == 1 and "--update stopped after 1 of 3 changes" in err and RECORD in err, err
    record = (base / RECORD).read_text().splitlines()
    assert record[1:] == ["updated: a.png"]  # the record of what was changed stays
    assert (base / "a.png").read_bytes() == (cur / "a.png").read_bytes()
    assert (base / "z.png").read_bytes() != (cur / "z.png").read_bytes()
    # once the obstacle is gone, the same command completes the update and drops the record
    (base / "m").unlink()
    code, out, _ = run(str(base), str(cur), "--update", capsys=capsys)
    assert code == Exit.OK and "updated: z.png" in out and "added: m/new.png" in out
    assert not (base / RECORD).exists()


def test_an_update_stopped_by_ctrl_c_lists_what_it_changed(tmp_path):
    base, cur = tmp_path / "base", tmp_path / "cur"
    base.mkdir()
    for i in range(400):
        sprite(cur / f"s{i:03d}.png", (i % 256, 40, 90), size=64)
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "diff", str(base), str(cur), "--update", "-j", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline:
        if (base / RECORD).exists() and len((base / RECORD).read_text().splitlines()) > 3:
            proc.send_signal(signal.SIGINT)
            break
        time.sleep(0.01)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGINT, (out, err)
    said = [line.removeprefix("added: ") for line in out.splitlines()]
    recorded = [line.removeprefix("added: ") for line in (base / RECORD).read_text().splitlines()[1:]]
    written = sorted(p.name for p in base.glob("*.png"))
    assert 3 <= len(written) < 400 and said == recorded == written, err
    assert err.splitlines()[-1] == "depixel: interrupted"
    assert f"--update stopped after {len(written)} changes" in err
    assert not [p for p in base.iterdir() if p.name.endswith(".tmp")]


# --- what runs killed outright leave --------------------------------------------------------

def killed_writer(code: str) -> None:
    """Run ``code`` in a Python process that then kills itself with SIGKILL."""
    subprocess.run([sys.executable, "-c", code + "\nimport os, signal; os.kill(os.getpid(), signal.SIGKILL)"],
                   check=False, timeout=60)


def test_the_temporary_folder_of_a_killed_report_is_removed_by_the_next_run(changed, tmp_path, capsys):
    base, cur = changed
    killed_writer(f"from depixel.diff.staging import Staged; Staged({str(tmp_path / 'report')!r})")
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(".report.")]
    assert len(left) == 1 and left[0].endswith(".tmp")
    assert run(str(base), str(cur), "--html", str(tmp_path / "report"), capsys=capsys)[0] == Exit.FAILED
    assert sorted(p.name for p in tmp_path.iterdir()) == ["base", "cur", "report"]


def test_the_temporary_file_of_a_killed_update_is_removed_by_the_next(changed, capsys):
    base, cur = changed
    killed_writer(f"from depixel.files.output import stage; stage({str(base / 'a.png')!r}, b'half')")
    assert [p.name for p in base.iterdir() if p.name.endswith(".tmp")]
    assert run(str(base), str(cur), "--update", capsys=capsys)[0] == Exit.OK
    assert sorted(p.name for p in base.iterdir()) == ["a.png"]


# --- errors name what the user asked for ----------------------------------------------------

def test_a_report_that_cannot_be_written_is_named_not_its_temporary_folder(changed, tmp_path):
    base, cur = changed
    limit = ("import resource, signal; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
             "resource.setrlimit(resource.RLIMIT_FSIZE, (3000, 3000)); ")  # a disk that fills at 3 KB a file
    proc = subprocess.run([sys.executable, "-c", limit + "import sys; from depixel_cli.main import main; "
                           "sys.exit(main(sys.argv[1:]))", "diff", str(base), str(cur), "--html",
                           str(tmp_path / "report")], capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "report/index.html" in lines[0] and ".tmp" not in lines[0], proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["base", "cur"]


def test_diff_out_to_stdout_with_json_is_refused(changed, capsys):
    base, cur = changed
    code, out, err = run(str(base / "a.png"), str(cur / "a.png"), "--diff-out", "-", "--json", capsys=capsys)
    assert code == Exit.USAGE and out == "" and err.count("\n") == 1 and "stdout" in err
    code, out, _ = run(str(base / "a.png"), str(cur / "a.png"), "--json", capsys=capsys)
    assert code == Exit.FAILED and json.loads(out)["same"] is False
