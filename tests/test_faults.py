"""Batches under real signals and real dead workers (issues 13.1 and 17.2-3).

Each test runs ``python -m depixel`` in a subprocess on a folder of copies of a fixture,
waits until the batch has really started (a first output exists: no sleep that assumes a
speed), sends a real signal and checks what a user would: the exit code, the ``--json``
summary, no temporary file, no process left behind.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import FIXTURES

from depixel_cli import pool
from depixel_cli.pool import Finished, Meanwhile, Signals, run_jobs

#: generous on a loaded 2-core machine; the measured time is ~0.1-1.2 s (docs/cli.md)
STOP_SECONDS = 6.0


def batch_folder(tmp_path: Path, copies: int = 40, large: bool = False) -> Path:
    """``copies`` of the mushroom; ``large``: a 17 × 19 tiling of it (272×266 pixels, more
    than the command converts itself while its workers start: every file is a worker's)."""
    folder = tmp_path / "in"
    folder.mkdir()
    source = FIXTURES / "mushroom.png"
    if large:
        from PIL import Image

        with Image.open(source) as tile:
            tiled = Image.new(tile.mode, (tile.width * 17, tile.height * 19))
            for x in range(17):
                for y in range(19):
                    tiled.paste(tile, (x * tile.width, y * tile.height))
        source = tmp_path / "tiled.png"
        tiled.save(source)
    for i in range(copies):
        shutil.copy(source, folder / f"m{i:03d}.png")
    return folder


def start(folder: Path, out: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(folder), "--out-dir", str(out),
                             "--json", *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_outputs(out: Path, proc: subprocess.Popen, count: int = 1, timeout: float = 180) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if out.is_dir() and len(list(out.glob("*.svg"))) >= count:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    raise AssertionError("the batch did not start")


def wait_for_workers(proc: subprocess.Popen, count: int = 2, timeout: float = 60) -> list[int]:
    """The workers of ``proc`` once there are ``count`` (this process converts the first
    files itself while they start, so the first outputs may come before them)."""
    deadline = time.monotonic() + timeout
    while len(found := children(proc.pid)) < count and time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    return found


def children_of(pid: int) -> list[int]:
    """The child processes of ``pid``, listed by each of its threads (a thread that ends
    while it is read, such as the one starting the workers, has none left)."""
    found = []
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except FileNotFoundError:
        return found
    for task in tasks:
        try:
            found += [int(child) for child in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError):
            continue
    return found


def children(pid: int) -> list[int]:
    """Worker processes of ``pid``: its children (forked or spawned), or those of its fork
    server."""
    found = []
    for child in children_of(pid):
        try:
            cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
        except (FileNotFoundError, ProcessLookupError):
            continue
        if b"forkserver" in cmdline:
            found += children_of(child)
        elif b"resource_tracker" not in cmdline:
            found.append(child)
    return found


def helpers(pid: int) -> list[int]:
    """Every other process under ``pid`` (fork server, resource tracker): they must go too."""
    return [child for child in children_of(pid) if child not in children(pid)]


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/status").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return "\nState:\tZ" not in state  # a zombie orphan (nobody reaps it here) is dead


def assert_gone(pids: list[int]) -> None:
    deadline = time.monotonic() + 10
    while any(alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(alive(p) for p in pids), "a worker outlived the command"


pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


@pytest.mark.parametrize("jobs,signum,code", [("2", signal.SIGINT, 130), ("2", signal.SIGTERM, 143),
                                              ("1", signal.SIGINT, 130), ("1", signal.SIGTERM, 143),
                                              ("2 starting", signal.SIGINT, 130)])
def test_first_signal_stops_the_batch_with_a_summary(tmp_path, jobs, signum, code):
    """-j 2 after its workers started; "2 starting": at the first output, usually while the
    command converts files itself and its workers are still starting."""
    out = tmp_path / "out"
    proc = start(batch_folder(tmp_path), out, "-j", jobs.split()[0])
    wait_for_outputs(out, proc)
    workers = children(proc.pid) if jobs != "2" else wait_for_workers(proc)
    assert len(workers) == {"2": 2, "1": 0}.get(jobs, len(workers))
    workers += helpers(proc.pid)
    sent = time.monotonic()
    proc.send_signal(signum)
    stdout, stderr = proc.communicate(timeout=60)
    assert time.monotonic() - sent < STOP_SECONDS
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and "Exception ignored" not in stderr
    report = json.loads(stdout)
    assert report["interrupted"] is True and report["files"] == 40
    status = {Path(o["output"]).name: o["status"] for o in report["outputs"]}
    assert len(status) == 40 and "cancelled" in status.values()
    written = {p.name for p in out.iterdir()}
    assert {n for n, s in status.items() if s == "converted"} == written  # no temporary file, nothing unlisted
    assert report["ok"] == len(written) < 40
    assert_gone(workers)


def test_sigterm_to_the_whole_group_leaves_nothing_behind(tmp_path):
    """17.3: SIGTERM to the process group (workers included, as a service manager sends it)."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(batch_folder(tmp_path)), "--out-dir",
                             str(out), "--json", "-j", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    wait_for_outputs(out, proc)
    workers = wait_for_workers(proc) + helpers(proc.pid)
    assert len(workers) >= 2
    os.killpg(proc.pid, signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert json.loads(stdout)["interrupted"] is True
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert_gone(workers)


def test_workers_die_with_a_killed_command(tmp_path):
    """17.3: even SIGKILL of the command (no chance to clean up) leaves no worker running,
    and no worker's temporary file (files too large for the command to convert itself:
    a file it converts itself, as with -j 1, may leave one when it is killed)."""
    out = tmp_path / "out"
    proc = start(batch_folder(tmp_path, large=True), out, "-j", "2")
    wait_for_outputs(out, proc)
    workers = wait_for_workers(proc) + helpers(proc.pid)
    assert len(workers) >= 2
    proc.kill()
    proc.communicate(timeout=60)
    assert_gone(workers)
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_second_ctrl_c_exits_at_once_quietly(tmp_path):
    out = tmp_path / "out"
    proc = start(batch_folder(tmp_path), out, "-j", "2")
    wait_for_outputs(out, proc)
    workers = wait_for_workers(proc) + helpers(proc.pid)
    proc.send_signal(signal.SIGINT)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in stderr and "Exception ignored" not in stderr
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert_gone(workers)


def test_ctrl_c_without_json_says_what_was_done(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(batch_folder(tmp_path, 20)),
                             "--out-dir", str(out), "-j", "2"], stderr=subprocess.PIPE, text=True)
    wait_for_outputs(out, proc)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130
    last = stderr.strip().splitlines()[-1]
    assert last.startswith("depixel: 20 files: ") and "not started (interrupted)" in last, stderr


@pytest.mark.parametrize("argv", [["render", "{svg}", "-o", "{out}.png", "--width", "6000"],
                                  ["diff", "{svg}", "{svg}", "--scale", "150"]])
def test_single_commands_stop_on_a_signal(tmp_path, argv):
    """render and diff (inspect and a single convert share the code path) exit 130 at once."""
    svg = tmp_path / "noise.svg"
    import numpy as np

    import depixel

    noise = np.random.default_rng(0).integers(0, 2, (24, 24, 3), dtype=np.uint8) * 255
    svg.write_text(depixel.convert(noise, stage="cells"))
    args = [a.format(svg=svg, out=tmp_path / "out") for a in argv]
    proc = subprocess.Popen([sys.executable, "-m", "depixel", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    while proc.poll() is None and b"libcairo" not in Path(f"/proc/{proc.pid}/maps").read_bytes():
        time.sleep(0.02)  # until it renders (before that, Python itself may still be importing)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("finished before the signal")
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines() == ["depixel: interrupted"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["noise.svg"]


def test_killed_worker_fails_only_its_file_after_a_retry(tmp_path):
    """Issue 17.2 on the real command: SIGKILL one worker mid-batch; every file converts."""
    out = tmp_path / "out"
    proc = start(batch_folder(tmp_path, 30), out, "-j", "2")
    wait_for_outputs(out, proc)
    victim = wait_for_workers(proc)[0]
    os.kill(victim, signal.SIGKILL)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    report = json.loads(stdout)
    assert report["ok"] == 30 and report["failed"] == []
    assert "converted on the retry" in stderr and "SIGKILL" in stderr
    assert len(list(out.iterdir())) == 30


def test_pool_reports_a_file_that_kills_every_worker(tmp_path):
    """A file whose worker dies twice fails alone; one that kills it once converts on the retry."""
    jobs = [(name, str(tmp_path)) for name in ("a", "always", "b", "once", "c")]
    done: list[Finished] = []
    with Signals(raising=False) as signals:
        from pool_jobs import crash

        run_jobs(jobs, 2, crash, done.append, signals)
    by_name = {jobs[f.index][0]: f for f in done}
    assert set(by_name) == {"a", "always", "b", "once", "c"}
    assert by_name["always"].died == "killed by SIGKILL" and by_name["always"].result is None
    assert by_name["once"].retried == "killed by SIGKILL" and by_name["once"].result.startswith("once done")
    for name in "abc":
        assert by_name[name].result.startswith(f"{name} done") and by_name[name].died is None


def test_worker_killed_holding_its_next_job_loses_neither(tmp_path):
    """A worker holds the job it runs and the next (in its pipe): when it dies, the one it
    ran is retried once and the one behind it runs as if nothing happened (not retried,
    not reported twice, not lost)."""
    jobs = [(name, str(tmp_path)) for name in ("a", "once", "b", "c")]
    done: list[Finished] = []
    started: list[int] = []
    with Signals(raising=False) as signals:
        from pool_jobs import crash_holding_next

        run_jobs(jobs, 1, crash_holding_next, done.append, signals, started=started.append)
    assert (tmp_path / "held next").read_text() == "True"  # it did die holding "b"
    assert sorted(jobs[f.index][0] for f in done) == ["a", "b", "c", "once"]
    by_name = {jobs[f.index][0]: f for f in done}
    assert by_name["once"].retried == "killed by SIGKILL" and by_name["once"].result.startswith("once done")
    for name in "abc":
        assert by_name[name].result.startswith(f"{name} done") and by_name[name].retried is None
    assert [jobs[i][0] for i in started] == ["a", "once", "once", "b", "c"]  # as each began running


def test_main_process_converts_while_the_workers_start(tmp_path, monkeypatch):
    """With ``here`` and a fork server (not on Linux), the main process converts jobs from
    the end of the queue while the workers start (the fork server's imports), and every job
    still runs exactly once."""
    monkeypatch.setattr(pool, "START_METHOD", "forkserver")
    jobs = [(f"j{i}", str(tmp_path)) for i in range(40)]
    done: list[Finished] = []
    with Signals(raising=False) as signals:
        from pool_jobs import crash

        run_jobs(jobs, 2, crash, done.append, signals, meanwhile=Meanwhile(crash))
    assert sorted(f.index for f in done) == list(range(40))
    pids = [int(f.result.split()[-1]) for f in done]
    here = [f.index for f, pid in zip(done, pids) if pid == os.getpid()]
    assert here and min(here) >= 40 - len(here)  # the last jobs of the queue
    assert len(set(pids) - {os.getpid()}) == 2  # and the two workers the rest
    done.clear()
    with Signals(raising=False) as signals:  # the last job is not one it may run: it runs none
        run_jobs(jobs, 2, crash, done.append, signals, meanwhile=Meanwhile(crash, lambda job: job[0] != "j39"))
    assert sorted(f.index for f in done) == list(range(40))
    assert all(int(f.result.split()[-1]) != os.getpid() for f in done)


def test_workers_are_forked_from_the_command_with_its_imports():
    """Linux: a worker is the command's own child and has what a conversion imports (the
    command imported it once), and what the command had imported besides: no fork server
    imports depixel again."""
    from pool_jobs import imported

    import depixel_cli.convert.command  # noqa: F401  (imported by the command, not by the pool's preload)

    modules = (*pool.PRELOAD, "depixel_cli.convert.command")
    done: list[Finished] = []
    with Signals(raising=False) as signals:
        run_jobs([modules] * 4, 2, imported, done.append, signals)
    assert [f.result for f in done] == [(os.getpid(), True)] * 4


def test_forked_worker_holds_no_other_pipe():
    """Each pipe has one end in one worker: a worker forked after another closes the
    command's end of the other's pipe and of its own, so closing it ends the worker (EOF)."""
    from pool_jobs import crash

    context = pool.context()
    first = pool._Worker(context, crash)
    second = pool._Worker(context, crash, [first])
    try:
        for worker in (first, second):
            worker.conn.close()
            worker.process.join(10)
            assert worker.process.exitcode == 0
    finally:
        for worker in (first, second):
            pool._signal(worker, signal.SIGKILL)


def test_progress_bar_starts_no_thread(monkeypatch):
    """The command forks its workers: the progress bar on a terminal adds no thread (tqdm's
    monitor), whose locks a forked worker could inherit held."""
    import pty
    import threading

    from depixel_cli.convert.run import Progress

    master, slave = pty.openpty()
    with os.fdopen(slave, "w") as terminal:
        monkeypatch.setattr(sys, "stderr", terminal)
        threads = threading.active_count()
        progress = Progress(3)
        progress.step()
        assert progress.bar is not None and threading.active_count() == threads
        progress.close()
    os.close(master)


def test_main_process_converts_only_small_files_itself(tmp_path):
    """Memory: the main process takes a file while its workers start only up to 256×256."""
    from PIL import Image

    from depixel_cli.convert.batch import Job
    from depixel_cli.convert.run import small

    for size, expected in (((256, 256), True), ((257, 256), False)):
        Image.new("RGB", size).save(tmp_path / "x.png")
        assert small(Job(tmp_path / "x.png", tmp_path / "x.svg", None)) is expected  # type: ignore[arg-type]
    (tmp_path / "x.png").write_bytes(b"not an image")
    assert not small(Job(tmp_path / "x.png", tmp_path / "x.svg", None))  # type: ignore[arg-type]


def test_worker_stop_swallowed_by_a_finalizer_stops_again(tmp_path):
    """SIGTERM that lands in a generator's cleanup (where Python swallows the exception and
    prints "Exception ignored") is raised again outside it, with nothing printed."""
    code = """if True:
        import os, signal, sys, time
        from depixel_cli import worker
        signal.signal(signal.SIGTERM, worker.raise_stop)
        if sys.argv[1] == "hook":
            sys.unraisablehook = worker.unraisable
        def frames():
            try:
                yield 1
            finally:
                os.kill(os.getpid(), signal.SIGTERM)  # as if it arrived during this cleanup
                time.sleep(0.1)
        gen = frames()
        next(gen)
        try:
            del gen
            time.sleep(float(sys.argv[2]))  # (a Stop raised again ends it at once)
            print("went on")
        except worker.Stop:
            print("stopped")
    """
    done = subprocess.run([sys.executable, "-c", code, "hook", "60"], capture_output=True, text=True, timeout=120)
    stdout, stderr = done.stdout, done.stderr
    without = subprocess.run([sys.executable, "-c", code, "none", "0.2"], capture_output=True, text=True, timeout=60)
    assert without.stdout.strip() == "went on" and "Exception ignored" in without.stderr  # what it prevents
    assert stdout.strip() == "stopped" and "Exception ignored" not in stderr


def test_worker_stopped_while_it_sets_itself_up_exits_quietly():
    """SIGTERM while a fresh worker asks the kernel to stop it with its parent (a worker
    started just before a stop request): the worker ends without a traceback."""
    code = """if True:
        import os, signal
        from multiprocessing import Pipe
        from depixel_cli import worker
        def slow_setup():
            os.kill(os.getpid(), signal.SIGTERM)  # as if it arrived during the set-up
            signal.pause()  # SIGTERM raised _Stop before this returns
        worker.die_with_parent = slow_setup
        here, there = Pipe()
        worker.serve(there, print)
        print("quiet")
    """
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "quiet" and "Traceback" not in done.stderr, done.stderr


def test_an_output_the_dead_worker_completed_counts_as_converted(tmp_path, monkeypatch):
    """A worker killed after renaming its output into place but before reporting: the retry
    finds the output up to date; the batch lists it as converted (written since the batch
    began), not as skipped. An output from before the batch stays up to date."""
    from depixel.options import ConvertOptions
    from depixel_cli import pool
    from depixel_cli.convert import batch
    from depixel_cli.convert import run as batch_run

    options = batch.Options(ConvertOptions.build(stage="cells", max_pixels=None), ("svg",), "first", force=False)
    (tmp_path / "out").mkdir()
    jobs = [batch.Job(FIXTURES / name, tmp_path / "out" / f"{name}.svg", options) for name in ("heart.png", "ghost.png")]

    def killed_after_the_rename_then_retried(jobs, workers, fn, report, signals, **_):
        for index, job in enumerate(jobs):
            fn(job)  # the worker that died: its output in place, no result sent
            report(pool.Finished(index, fn(job), retried="SIGKILL"))

    monkeypatch.setattr(pool, "run_jobs", killed_after_the_rename_then_retried)
    with pool.Signals(raising=False) as signals:
        outcomes = batch_run.run(jobs, 2, lambda outcome: None, signals)
    for job, outcome in zip(jobs, outcomes):
        assert outcome.written == [job.output] and outcome.up_to_date == [], outcome
        assert "converted on the retry" in outcome.notes[0]
    retried = batch.run_job(jobs[0])  # up to date now: a batch that begins after it skips it
    batch.claim_outputs_of_the_dead(retried, time.time_ns())
    assert retried.up_to_date == [jobs[0].output] and retried.written == []
