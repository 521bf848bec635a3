"""Streams and signals as a Unix tool has them (issue 35, findings 2, 8, 9 and 11).

Every test runs the command in a subprocess with the real thing: a pipe whose reader goes
away, ``/dev/full``, a closed descriptor, a FIFO, SIGINT or SIGTERM sent at the moment
named (while importing, while cairo writes a PNG, while a worker stops).
"""
from __future__ import annotations

import errno
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image

import depixel
from depixel_cli.main import main
from depixel_cli.options import Exit

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux pipes, /dev/full, /proc")

#: The ``depixel`` script as installed (what the console entry point runs), independent of
#: whether the script in the virtual environment was made before the entry point moved.
SCRIPT = [sys.executable, "-c", "from depixel_cli.entry import main; main()"]
DEPIXEL = [sys.executable, "-m", "depixel"]
HEART = FIXTURES / "heart.png"


def noise_png(path: Path, size: int = 64, seed: int = 0) -> Path:
    """A 3-colour noise sprite: its SVG (~400 KB) is far larger than a pipe holds (64 KB)."""
    palette = np.array([(20, 20, 20), (230, 60, 60), (250, 250, 250)], np.uint8)
    Image.fromarray(palette[np.random.default_rng(seed).integers(0, 3, (size, size))], "RGB").save(path)
    return path


def shell(command: str, *argv: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """``depixel ARGV`` with the shell redirections of ``command`` (``>&-``, ``<&-``, ``> /dev/full``)."""
    return subprocess.run(["sh", "-c", f'"$@" {command}', "sh", *DEPIXEL, *argv], capture_output=True, text=True,
                          timeout=timeout)


def lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


def messages(err: str) -> tuple[list[str], str]:
    """A batch's lines on stderr but its summary line, and the summary (``N files: …``)."""
    found = lines(err)
    assert re.fullmatch(r"depixel: \d+ files?: .* in [0-9.]+ s", found[-1]), err
    return found[:-1], found[-1]


# --- finding 2: output streams --------------------------------------------------------------

def test_reader_that_goes_away_ends_the_run_quietly(tmp_path):
    """``convert big.png -o - | head -c 100``: the reader takes 100 bytes and closes the pipe
    while depixel writes; depixel stops with 141 (SIGPIPE's status) and says nothing. Before,
    Python's buffered writer returned after the first 64 KB and the run exited 0."""
    proc = subprocess.Popen([*DEPIXEL, "convert", str(noise_png(tmp_path / "big.png")), "-o", "-"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert len(proc.stdout.read(100)) == 100
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert len(lines(err)) <= 1 and "Traceback" not in err and "internal error" not in err, err


@pytest.mark.parametrize("argv", [["--version"], ["diff", str(HEART), str(HEART), "--json"]])
def test_pipe_closed_before_the_first_line(argv):
    """``depixel --version | head -1`` when ``head`` is gone before depixel writes: 141, no
    traceback (Python's own exit would print "Exception ignored … BrokenPipeError")."""
    proc = subprocess.Popen([*DEPIXEL, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert lines(err) == [], err


def test_full_disk_and_closed_stdout_are_one_line():
    full = shell("> /dev/full", "convert", str(HEART), "-o", "-")
    assert full.returncode == 1 and lines(full.stderr) == [
        "depixel: error: <stdout>: cannot write (No space left on device)"], full.stderr
    closed = shell(">&-", "convert", str(HEART), "-o", "-")
    assert closed.returncode == 1 and lines(closed.stderr) == [
        "depixel: error: <stdout>: cannot write (standard output is closed)"], closed.stderr


def test_named_pipe_with_no_reader_is_refused_at_once(tmp_path):
    """``-o fifo.svg`` with nobody reading waited forever; now one line, nothing made."""
    fifo = tmp_path / "fifo.svg"
    os.mkfifo(fifo)
    run = subprocess.run([*DEPIXEL, "convert", str(HEART), "-o", str(fifo)], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 1
    assert lines(run.stderr) == [f"depixel: error: {fifo}: a pipe nobody reads; refusing to wait for a reader"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo.svg"]


def test_pipes_with_a_reader_are_written(tmp_path):
    """A FIFO someone reads, and ``/dev/stdout`` that is a pipe (which resolved to a file name
    in /proc that does not exist: "No such file or directory"), get what a file would."""
    expected = (tmp_path / "h.svg")
    assert main(["convert", str(HEART), "-o", str(expected), "-q"]) == Exit.OK
    fifo = tmp_path / "fifo.svg"
    os.mkfifo(fifo)
    received: list[bytes] = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_bytes()))
    reader.start()
    run = subprocess.run([*DEPIXEL, "convert", str(HEART), "-o", str(fifo)], capture_output=True, timeout=60)
    reader.join(60)
    assert run.returncode == 0, run.stderr
    assert received == [expected.read_bytes()]
    through = subprocess.run([*DEPIXEL, "convert", str(HEART), "-o", "/dev/stdout", "--format", "svg"],
                             capture_output=True, timeout=60)
    assert through.returncode == 0 and through.stdout == expected.read_bytes(), through.stderr


# --- finding 8: Ctrl-C at any moment -----------------------------------------------------------

def mapped(pid: int, name: bytes) -> bool:
    try:
        return name in Path(f"/proc/{pid}/maps").read_bytes()
    except (FileNotFoundError, ProcessLookupError):
        return False


def test_the_installed_script_enters_before_the_imports():
    """The console script runs depixel_cli.entry (SCRIPT above is what it does)."""
    from conftest import ROOT

    assert 'depixel = "depixel_cli.entry:main"' in (ROOT / "pyproject.toml").read_text()


@pytest.mark.parametrize("delay", [0.0, 0.02, 0.05, 0.1])
def test_ctrl_c_while_importing(tmp_path, delay):
    """SIGINT once numpy is being imported (the command's first ~0.1-0.2 s): before, Python's
    KeyboardInterrupt traceback from whatever module was loading."""
    proc = subprocess.Popen([*SCRIPT, "convert", str(noise_png(tmp_path / "n.png")), "-o", str(tmp_path / "n.svg")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not mapped(proc.pid, b"_multiarray_umath") and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.001)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert lines(err) == ["depixel: interrupted"], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["n.png"]


def test_ctrl_c_while_cairo_writes_a_png(tmp_path):
    """SIGINT while cairo encodes a PNG (a 2000-pixel render of noise: ~1.5 s of encoding after
    0.05 s of drawing). Cairo used to hand each block to Python, where the signal was raised
    in the callback and swallowed by cffi ("Exception ignored from cffi callback", a
    traceback) and the command failed with exit 1; now it is raised when cairo returns."""
    noise = np.random.default_rng(0).integers(0, 256, (256, 256, 4), dtype=np.uint8)
    noise[..., 3] = 255
    buffer = io.BytesIO()
    Image.fromarray(noise, "RGBA").save(buffer, "PNG")
    import base64

    svg = tmp_path / "photo.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
                   'width="256" height="256"><image width="256" height="256" xlink:href="data:image/png;base64,'
                   f'{base64.b64encode(buffer.getvalue()).decode()}"/></svg>')
    proc = subprocess.Popen([*DEPIXEL, "render", str(svg), "-o", str(tmp_path / "out.png"), "--width", "2000"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while proc.poll() is None and not mapped(proc.pid, b"libcairo"):
        time.sleep(0.005)
    time.sleep(0.5)  # drawn, now encoding
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the render ended before the signal")
    assert proc.returncode == 130, err
    assert lines(err) == ["depixel: interrupted"], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["photo.svg"]


# --- finding 9: closed stdin, SIGTERM to the process group --------------------------------------

@pytest.mark.parametrize("argv", [["convert", "-", "-o", "{dir}/x.svg"], ["render", "-", "-o", "{dir}/x.png"]])
def test_closed_stdin_is_a_usage_error(tmp_path, argv):
    run = shell("<&-", *(a.format(dir=tmp_path) for a in argv))
    assert run.returncode == Exit.USAGE
    (line,) = lines(run.stderr)
    assert line.startswith(f"depixel {argv[0]}: error: - reads the ") and line.endswith("which is closed")
    assert list(tmp_path.iterdir()) == []


def worker_script(body: str) -> subprocess.CompletedProcess:
    code = "if True:\n    import os, signal, sys, time\n    from multiprocessing import Pipe\n" \
           "    from depixel_cli import worker\n    here, there = Pipe()\n" + body
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)


def test_worker_signalled_before_its_handlers_stops_quietly():
    """A worker is forked with SIGTERM blocked; a SIGTERM sent meanwhile (the group's, at a
    stop request just after the worker started) is delivered when ``serve`` unblocks it,
    which was outside its ``try``: the Stop escaped to multiprocessing's traceback."""
    done = worker_script("""
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    os.kill(os.getpid(), signal.SIGTERM)  # pending until serve unblocks it
    try:
        worker.serve(there, print)
        print("quiet")
    except worker.Stop:
        print("escaped")
    """)
    assert done.stdout.strip() == "quiet", done.stdout + done.stderr


def test_stopping_worker_ignores_further_signals():
    """Once stopping, a worker ignores SIGTERM: the group's SIGTERM stops it, the main
    process's own SIGTERM may then arrive while it exits (a Stop raised in multiprocessing's
    exit code is printed with a traceback)."""
    done = worker_script("""
    def stopped(job):
        os.kill(os.getpid(), signal.SIGTERM)  # the group's signal, during the job
        time.sleep(5)
    here.send("job")
    worker.serve(there, stopped)
    try:
        os.kill(os.getpid(), signal.SIGTERM)  # the main process's, while the worker exits
        time.sleep(0.2)
        print("quiet")
    except worker.Stop:
        print("escaped")
    """)
    assert done.stdout.strip() == "quiet", done.stdout + done.stderr


def test_sigterm_to_the_process_group_many_times(tmp_path):
    """SIGTERM to the whole group of ``convert -j 2`` (what ``timeout`` and systemd do) as soon
    as both workers run, at 12 moments 0-55 ms apart: every run exits 143 without a worker's
    traceback and leaves no temporary file (before: 4 runs in 40 printed one)."""
    from test_faults import batch_folder, children

    folder = batch_folder(tmp_path, copies=30)
    for run in range(12):
        out = tmp_path / f"out{run}"
        proc = subprocess.Popen([*DEPIXEL, "convert", str(folder), "--out-dir", str(out), "-j", "2", "--json"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        deadline = time.monotonic() + 60
        while len(children(proc.pid)) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        time.sleep(0.005 * run)
        os.killpg(proc.pid, signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 143, err
        assert "Traceback" not in err and "Exception ignored" not in err, err
        assert not out.exists() or not list(out.rglob(".*"))  # no temporary file left


# --- finding 11: inputs that are pipes, -j N, the same error for every file -----------------------

def test_named_pipe_among_the_inputs_is_one_failed_file(tmp_path):
    """An input that is a FIFO nobody writes to (as one swapped in while a batch runs): the
    header look-ups of the batch's planning and the conversion opened it and waited forever."""
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("a.png", "b.png"):
        shutil.copy(HEART, folder / name)
    os.mkfifo(folder / "swapped.png")
    out = tmp_path / "out"
    run = subprocess.run([*DEPIXEL, "convert", str(folder / "a.png"), str(folder / "swapped.png"),
                          str(folder / "b.png"), "--out-dir", str(out), "-j", "2"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    said, summary = messages(run.stderr)
    assert said == [f"depixel: error: {folder / 'swapped.png'}: a pipe nothing was written to"]
    assert "3 files: 2 converted" in summary and "1 failed" in summary
    assert sorted(p.name for p in out.iterdir()) == ["a.svg", "b.svg"]


def test_explicit_jobs_are_capped_by_memory(tmp_path):
    """``-j 1000`` on 4 files with memory for 2 conversions: 2 workers and a note (before, 4
    processes: only ``-j auto`` looked at the memory)."""
    folder = tmp_path / "in"
    folder.mkdir()
    for i in range(4):
        shutil.copy(HEART, folder / f"h{i}.png")
    from depixel.limits import PEAK_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES

    with Image.open(HEART) as img:
        need = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * img.size[0] * img.size[1]
    code = ("import sys; from depixel_cli.convert import run as batch_run; "
            f"batch_run.available_memory = lambda: {int(need * 2.5)}; "
            "from depixel_cli.main import main; sys.exit(main(sys.argv[1:]))")
    run = subprocess.run([sys.executable, "-c", code, "convert", str(folder), "--out-dir", str(tmp_path / "out"),
                          "-j", "1000"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    (note,), _ = messages(run.stderr)
    assert note.startswith("depixel: note: -j 1000: 2 workers, not 4: converting "), note
    assert len(list((tmp_path / "out").iterdir())) == 4


def test_the_same_error_for_every_input_is_printed_once(tmp_path, monkeypatch, capsys):
    """A folder where no file can be created (what a read-only folder does for a normal user;
    also checked when running as root): the error once, then the count; an input's own error
    is still printed."""
    folder = tmp_path / "in"
    folder.mkdir()
    for i in range(5):
        shutil.copy(HEART, folder / f"h{i}.png")
    (folder / "junk.png").write_bytes(b"not an image")
    out = tmp_path / "out"
    out.mkdir()
    real_open = os.open

    def refuse(path, flags, *args, **kwargs):
        if flags & os.O_CREAT and str(path).startswith(str(out)):
            raise PermissionError(errno.EACCES, "Permission denied")
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    assert main(["convert", str(folder), "--out-dir", str(out), "-j", "1"]) == Exit.FAILED
    err, summary = messages(capsys.readouterr().err)
    assert "6 files: 0 converted" in summary and "6 failed" in summary
    assert err == [f"depixel: error: {out / 'h0.svg'}: permission denied (cannot write in its folder)",
                   f"depixel: error: {folder / 'junk.png'}: not an image (no format Pillow reads recognises it)",
                   f"depixel: error: 4 more files failed the same way: {out / '…'}: permission denied "
                   "(cannot write in its folder)"], err


def test_numpy_warnings_never_reach_the_terminal(tmp_path):
    """A numpy overflow inside a conversion (here one provoked on purpose) is no message."""
    code = ("import sys, numpy as np; from depixel import api; depixelize = api.depixelize\n"
            "def overflowing(*args, **kwargs):\n    np.float64(1e308) * 10\n    return depixelize(*args, **kwargs)\n"
            "api.depixelize = overflowing\n"
            "from depixel_cli.main import main; sys.exit(main(sys.argv[1:]))")
    run = subprocess.run([sys.executable, "-c", code, "convert", str(HEART), "-o", str(tmp_path / "h.svg")],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    warned = subprocess.run([sys.executable, "-W", "default", "-c", code.split("\nfrom depixel_cli")[0] +
                             "\napi.depixelize(np.zeros((2, 2, 4), np.uint8))"], capture_output=True, text=True,
                            timeout=120)
    assert "RuntimeWarning" in warned.stderr  # what the command hides


def test_curve_weight_beyond_its_range_is_one_line():
    run = subprocess.run([*DEPIXEL, "convert", str(HEART), "-o", "-", "--curve-weight", "1e308"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == Exit.USAGE and run.stdout == ""
    assert lines(run.stderr) == ["depixel: error: --curve-weight must be between 0 and 1000, not 1e+308"]


def test_version_still_prints(capsys):
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.startswith(f"depixel {depixel.__version__}\n")
