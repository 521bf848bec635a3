"""Temporary files (issue 35, finding 3): a name only this run can have, and cleanup that
removes exactly what this run made, never a user's file that looks like one.

The real-interrupt tests run ``python -m depixel`` and send SIGINT once the conversion runs
(the process has spent more CPU than its start-up, measured from /proc: no sleep that
assumes a speed).
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from depixel.errors import ParameterError
from depixel.files import output
from depixel.options import ConvertOptions
from depixel_cli.convert.batch import Job, Options, remove_temporary_files

#: what a user may keep beside an output: names the old ``.NAME.*.tmp`` glob matched
USER_FILES = (".{name}.mine.tmp", ".{name}.0123456789ab.tmp", ".{name}.depixel-1-0123456789ab.tmp",
              ".{name}.depixel-x-fedcba987654.tmp")


def user_files(folder: Path, name: str = "big.svg") -> dict[Path, bytes]:
    """The user's own files beside the output ``name`` in ``folder``, with their bytes."""
    made = {}
    for pattern in USER_FILES:
        path = folder / pattern.format(name=name)
        path.write_bytes(b"mine: " + name.encode())
        made[path] = path.read_bytes()
    return made


def test_a_temporary_name_holds_the_pid_and_the_run_token(tmp_path):
    token = output.run_token()
    assert re.fullmatch(r"[0-9a-f]{12}", token) and output.run_token() == token  # drawn once a run
    name = output.temporary_path(tmp_path / "big.svg").name
    assert name == f".big.svg.depixel-{os.getpid()}-{token}.tmp"
    assert output.temporary_path(tmp_path / "big.svg", "00112233", pid=7).name == ".big.svg.depixel-7-00112233.tmp"
    long = "é" * 200 + ".svg"  # cut to 64 bytes of its UTF-8, not 64 characters (NAME_MAX is in bytes)
    assert len(os.fsencode(output.temporary_path(tmp_path / long).name)) < 128
    for bad in ("*", "../x", "ABCDEF01", "12"):
        with pytest.raises(ParameterError, match="run token"):
            output.temporary_path(tmp_path / "big.svg", bad)


def test_writing_uses_the_run_token_and_leaves_nothing(tmp_path, monkeypatch):
    seen = []
    real_replace = os.replace

    def spy(src, dst):
        seen.append(Path(src).name)
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", spy)
    output.write_atomic(tmp_path / "big.svg", "<svg/>", token="00112233")
    assert seen == [f".big.svg.depixel-{os.getpid()}-00112233.tmp"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.svg"]
    assert not output.remove_created()  # the registry forgot it once renamed


def test_cleanup_removes_this_runs_files_and_no_other(tmp_path):
    mine = user_files(tmp_path)
    token = "00112233aabb"
    ours = [output.temporary_path(tmp_path / "big.svg", token, pid=pid) for pid in (4242, 4243)]
    ours.append(ours[0].with_name(ours[0].name[:-4] + "-1.tmp"))  # a second writer thread's name
    for path in ours:
        path.write_bytes(b"partial")
    other_run = output.temporary_path(tmp_path / "big.svg", "99999999aaaa", pid=4242)
    other_run.write_bytes(b"another run's")
    other_output = output.temporary_path(tmp_path / "big.svg.bak", token, pid=4242)
    other_output.write_bytes(b"another output's")
    job = Job(tmp_path / "big.png", tmp_path / "big.svg", Options(ConvertOptions(), ("svg",), "first", False,
                                                                     token=token))
    remove_temporary_files(job)  # what the command does for the job of a worker that was killed
    assert not any(p.exists() for p in ours)
    assert all(p.read_bytes() == data for p, data in mine.items())
    assert other_run.exists() and other_output.exists()
    assert output.remove_temporary(tmp_path / "big.svg", token) == []  # nothing left of ours


def test_the_registry_removes_what_this_process_left(tmp_path, monkeypatch):
    mine = user_files(tmp_path)

    def interrupted(*args):
        raise KeyboardInterrupt

    def refused(path):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "fdopen", interrupted)  # after the file is made
    monkeypatch.setattr(os, "unlink", refused)  # ... and the writer's own removal fails
    with pytest.raises(KeyboardInterrupt):
        output.write_atomic(tmp_path / "big.svg", "<svg/>")
    monkeypatch.undo()
    left = [p for p in tmp_path.iterdir() if p not in mine]
    assert [p.name for p in left] == [output.temporary_path(tmp_path / "big.svg").name]
    assert output.remove_created() == left
    assert sorted(tmp_path.iterdir()) == sorted(mine)


def cpu_seconds(pid: int) -> float:
    """CPU seconds of ``pid`` and its live children (the workers of a batch)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        children = [int(c) for task in Path(f"/proc/{pid}/task").iterdir()
                    for c in (task / "children").read_text().split()]
    except (FileNotFoundError, ProcessLookupError):
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK") + sum(map(cpu_seconds, children))


def converting(proc: subprocess.Popen, seconds: float = 1.0, timeout: float = 120) -> None:
    """Wait until ``proc`` and its workers have spent ``seconds`` of CPU (a start-up is
    ~0.3 s): it converts."""
    deadline = time.monotonic() + timeout
    while cpu_seconds(proc.pid) < seconds:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)


def noise(path: Path, side: int) -> None:
    """Four colours at random: seconds of work at 400 × 400."""
    palette = np.array([[0, 0, 0], [255, 0, 0], [0, 255, 0], [0, 0, 255]], np.uint8)
    Image.fromarray(palette[np.random.default_rng(1).integers(0, 4, (side, side))]).save(path)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_ctrl_c_during_a_conversion_keeps_the_users_tmp_files(tmp_path):
    """The finding as reported: SIGINT while ``convert big.png -o big.svg`` runs removed
    ``.big.svg.mine.tmp`` and ``.big.svg.0123456789ab.tmp`` (a ``.big.svg.*.tmp`` glob)."""
    noise(tmp_path / "big.png", 400)
    mine = user_files(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(tmp_path / "big.png"), "-o",
                             str(tmp_path / "big.svg")], stderr=subprocess.PIPE, text=True)
    converting(proc)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("finished before the signal")
    assert proc.returncode == 130, stderr
    assert all(p.read_bytes() == data for p, data in mine.items())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["big.png", *(p.name for p in mine)])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_stopped_batch_keeps_the_users_tmp_files(tmp_path):
    """-j 2, SIGINT: the workers' jobs are abandoned and cleaned up; every user file beside
    every output survives, and no temporary file of the run is left."""
    folder, out = tmp_path / "in", tmp_path / "out"
    folder.mkdir()
    out.mkdir()
    noise(tmp_path / "big.png", 300)
    mine = {}
    for i in range(6):
        os.link(tmp_path / "big.png", folder / f"big{i}.png")
        mine.update(user_files(out, f"big{i}.svg"))
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(folder), "--out-dir", str(out),
                             "-j", "2"], stderr=subprocess.PIPE, text=True)
    converting(proc, 2.0)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode in (0, 130), stderr
    assert all(p.read_bytes() == data for p, data in mine.items())
    assert not [p.name for p in out.iterdir() if ".depixel-" in p.name and p not in mine]
