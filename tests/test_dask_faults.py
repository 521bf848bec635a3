"""``depixel convert --dask`` on clusters that fail: workers without depixel, of another
version, that write elsewhere or die mid-write, a scheduler with no worker or killed
mid-run, addresses that are not addresses. Each test runs the command as a process on a
real cluster (a ``LocalCluster`` of worker processes, made faulty by
tests/dask_worker_preload.py, or a ``dask scheduler`` process) and checks what it says and
what is on disk: one line, never a hang, never a file reported that is not there."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import FIXTURES
from test_faults import wait_for_outputs

from depixel.files import stamp

distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")

PRELOAD = Path(__file__).parent / "dask_worker_preload.py"


@contextlib.contextmanager
def local_cluster(workers: int = 1, fault: str | None = None, **options):
    """A LocalCluster of ``workers`` single-threaded worker processes, each made faulty by
    the preload as ``fault`` says, with its ``options`` (``env``: the workers' variables)."""
    if fault:
        options = {**options, "preload": [str(PRELOAD)],
                   "env": {"DEPIXEL_TEST_WORKER": fault, **options.get("env", {})}}
    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  **options) as local:
        yield local


@contextlib.contextmanager
def cluster(workers: int = 1, fault: str | None = None, **env: str):
    """The address of a :func:`local_cluster` whose workers have the variables ``env``."""
    with local_cluster(workers, fault, env=env) as local:
        yield local.scheduler_address


def sprites(folder: Path, count: int, source: Path = FIXTURES / "mushroom.png") -> Path:
    folder.mkdir(parents=True)
    for i in range(count):
        shutil.copy(source, folder / f"s{i:03d}.png")
    return folder


def command(*args: str) -> list[str]:
    """``depixel convert -q ARGS`` (-q: the errors only, no summary line)."""
    return [sys.executable, "-m", "depixel", "convert", "-q", *args]


def convert(*args: str, cwd: Path | None = None, timeout: float = 120) -> tuple[int, list[str], dict | None, float]:
    """Run ``depixel convert -q ARGS --json``: exit code, stderr lines, the report, seconds."""
    start = time.monotonic()
    proc = subprocess.run(command(*args, "--json"), capture_output=True,
                          text=True, timeout=timeout, cwd=cwd)
    report = json.loads(proc.stdout) if proc.stdout.strip() else None
    return proc.returncode, proc.stderr.splitlines(), report, time.monotonic() - start


def stamped(folder: Path) -> set[str]:
    """Names of the complete outputs in ``folder`` (with their options stamp)."""
    return {p.name for p in folder.glob("*.svg") if stamp.read(p) is not None}


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_a_worker_without_depixel_is_refused_at_once(tmp_path):
    """Before: the batch hung for good (the worker died on its first task, the scheduler
    waited for another)."""
    with cluster(fault="no-depixel") as address:
        code, err, report, seconds = convert(str(sprites(tmp_path / "in", 3)), "--out-dir", str(tmp_path / "out"),
                                             "--dask", address, timeout=60)
    assert code == 1 and report is None
    assert len(err) == 1 and err[0].startswith("depixel: error: Dask worker tcp://"), err
    assert "depixel is not installed there" in err[0]
    assert leftovers(tmp_path / "out") == [] and stamped(tmp_path / "out") == set()


def test_a_worker_with_another_version_is_refused(tmp_path):
    with cluster(fault="other-version") as address:
        code, err, report, _ = convert(str(sprites(tmp_path / "in", 3)), "--out-dir", str(tmp_path / "out"),
                                       "--dask", address, timeout=60)
    assert code == 1 and len(err) == 1, err
    assert "has depixel 0.0.0+other" in err[0] and err[0].startswith("depixel: error: Dask worker tcp://")


def test_a_scheduler_without_workers_is_left_after_the_timeout(tmp_path):
    """Before: waited forever, silent."""
    with cluster(workers=0) as address:
        code, err, report, seconds = convert(str(sprites(tmp_path / "in", 2)), "--out-dir", str(tmp_path / "out"),
                                             "--dask", address, "--dask-timeout", "2", timeout=60)
    assert code == 1
    assert err == [f"depixel: error: no Dask worker joined the scheduler at {address} in 2 s (--dask-timeout)"]
    assert 2 <= seconds < 30


@pytest.mark.skipif(not Path("/proc/self/cwd").exists(), reason="needs /proc/self/cwd (Linux)")
def test_a_worker_that_does_not_share_the_output_folder_is_refused(tmp_path, monkeypatch):
    """The output folder is given as /proc/self/cwd/out, which is a different folder for the
    command and for the workers (started in another working folder): what a worker with
    another filesystem at the same path sees. Before: exit 0, every file reported converted,
    the command's folder empty."""
    here, there = tmp_path / "command", tmp_path / "worker"
    (there / "out").mkdir(parents=True)
    here.mkdir()
    src = sprites(tmp_path / "in", 3)
    monkeypatch.chdir(there)  # the workers' working folder
    with cluster() as address:
        monkeypatch.chdir(tmp_path)
        code, err, report, _ = convert(str(src), "--out-dir", "/proc/self/cwd/out", "--dask", address, cwd=here)
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith("depixel: error: Dask worker tcp://")
    assert "does not see the output folder /proc/self/cwd/out as this machine does" in err[0]
    assert leftovers(here / "out") == leftovers(there / "out") == []
    assert stamped(there / "out") == set()  # refused before any task


def test_outputs_a_worker_reports_but_this_machine_does_not_have_are_failures(tmp_path):
    """A worker that passes the checks, then reports files converted that are not where the
    command reads (here it writes nothing): each file fails, with the reason. Before: exit
    0, "ok": 3, an empty folder."""
    with cluster(fault="liar") as address:
        code, err, report, _ = convert(str(sprites(tmp_path / "in", 3)), "--out-dir", str(tmp_path / "out"),
                                       "--dask", address)
    assert code == 1 and report is not None
    assert report["ok"] == 0 and len(report["failed"]) == 3
    assert all("reported it converted, but the file is not there" in f["error"] for f in report["failed"])
    assert err[0].startswith("depixel: error: ") and all(line.startswith("depixel: ") for line in err)


def test_a_worker_killed_during_the_atomic_write_leaves_nothing_behind(tmp_path):
    """One worker is killed with its temporary file written, not renamed (s001); another
    just after the rename of s004, before it reports. Dask retries both elsewhere. Before:
    a 0-byte .s001.svg.*.tmp stayed, and s004 was reported up to date, not converted."""
    flags = tmp_path / "flags"
    flags.mkdir()
    with cluster(2, "kill", DEPIXEL_TEST_KILL_BEFORE="s001.svg", DEPIXEL_TEST_KILL_AFTER="s004.svg",
                 DEPIXEL_TEST_FLAGS=str(flags)) as address:
        code, err, report, _ = convert(str(sprites(tmp_path / "in", 8)), "--out-dir", str(tmp_path / "out"),
                                       "--dask", address)
    assert sorted(p.name for p in flags.iterdir()) == ["after", "before"], (err, report)  # both kills happened
    assert code == 0 and err == []
    assert report["ok"] == 8 and {o["status"] for o in report["outputs"]} == {"converted"}
    assert leftovers(tmp_path / "out") == []
    assert stamped(tmp_path / "out") == {f"s{i:03d}.svg" for i in range(8)}


def test_losing_the_scheduler_is_one_line_and_a_true_summary(tmp_path):
    """The scheduler process killed mid-run. Before: 53 lines of FutureCancelledError and a
    distributed.client traceback, a file complete on disk reported failed, and another
    written after the command had exited."""
    big = tmp_path / "big.png"
    tiled(big, 8)
    scheduler_file = tmp_path / "scheduler.json"
    flags = tmp_path / "flags"
    flags.mkdir()
    # one task at a time a worker (no task queued on it): once the scheduler is gone, the
    # tasks the workers have begun are all they will run
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--port", "0",
                                  "--dashboard-address", ":0", "--no-show", "--scheduler-file", str(scheduler_file)],
                                 env={**os.environ, "DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION": "1.0"},
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers = None
    try:
        address = scheduler_address(scheduler_file, scheduler)
        workers = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "2",
                                    "--nthreads", "1", "--no-dashboard", "--preload", str(PRELOAD)],
                                   env={**os.environ, "DEPIXEL_TEST_WORKER": "track", "DEPIXEL_TEST_FLAGS": str(flags)},
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        out = tmp_path / "out"
        proc = subprocess.Popen(command(str(sprites(tmp_path / "in", 12, big)),
                                 "--out-dir", str(out), "--json", "--dask", address),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_outputs(out, proc, count=2)
        scheduler.kill()
        stdout, stderr = proc.communicate(timeout=120)
        on_disk = stamped(out)
        wait_for_running_tasks(flags, workers)
        assert stamped(out) == on_disk, "a file was completed after the command exited"
    finally:
        for process in (scheduler, workers):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    assert proc.returncode == 1
    assert stderr.splitlines() == [f"depixel: error: lost the Dask scheduler at {address}"]
    report = json.loads(stdout)
    converted = {Path(o["output"]).name for o in report["outputs"] if o["status"] == "converted"}
    assert converted == on_disk and len(converted) >= 2
    assert report["failed"] == [] and report["not_done"] == 12 - len(converted)
    assert {o["status"] for o in report["outputs"]} <= {"converted", "interrupted", "cancelled"}
    assert leftovers(out) == []


def scheduler_address(scheduler_file: Path, scheduler: subprocess.Popen, timeout: float = 120) -> str:
    """The address in the scheduler file that ``scheduler`` writes, once it is there whole."""
    deadline = time.monotonic() + timeout
    while True:
        assert scheduler.poll() is None and time.monotonic() < deadline, "the scheduler did not start"
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (OSError, ValueError, KeyError):
            time.sleep(0.05)


def wait_for_running_tasks(flags: Path, workers: subprocess.Popen | None = None, timeout: float = 120) -> None:
    """Until every task that a ``track`` worker began has ended (or the ``workers`` process
    is gone): the tasks still running when the command stopped end, and so may have written
    or left something, before the test looks."""
    deadline = time.monotonic() + timeout
    while True:
        began = {p.name.removesuffix(".started") for p in flags.glob("*.started")}
        ended = {p.name.removesuffix(".ended") for p in flags.glob("*.ended")}
        if began <= ended or (workers is not None and workers.poll() is not None):
            return
        assert time.monotonic() < deadline, f"tasks still running: {sorted(began - ended)}"
        time.sleep(0.05)


def tiled(path: Path, times: int) -> None:
    """The mushroom tiled ``times`` × ``times``: a sprite that takes a second or so."""
    from PIL import Image

    with Image.open(FIXTURES / "mushroom.png") as tile:
        image = Image.new(tile.mode, (tile.width * times, tile.height * times))
        for x in range(times):
            for y in range(times):
                image.paste(tile, (x * tile.width, y * tile.height))
    image.save(path)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_bad_addresses_are_one_line_at_once(tmp_path):
    """Before: one line, then 40 s and "Exception ignored in Client.__del__"; tls:// and
    ucx:// an internal TypeError; a refused connection waited 20 s."""
    src = sprites(tmp_path / "in", 1)
    addresses = {"foo.invalid": "unknown host foo.invalid", "tcp://": "not a scheduler address",
                 "": "not a scheduler address", "tcp://h:8786/extra": "not a scheduler address",
                 "http://h:80": "unknown scheme http://", "tcp://h:99999": "port 99999 is out of range",
                 "tls://127.0.0.1:8786": "no TLS certificate is configured",
                 "ucx://127.0.0.1:8786": "UCX needs the distributed-ucxx package",
                 f"tcp://127.0.0.1:{free_port()}": "Connection refused"}
    # every wait that Dask or the command could make lasts 600 s here, so "at once" is any
    # time well under that, however busy the machine
    env = {**os.environ, "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": "", "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": "",
           "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "600s"}
    procs = {address: subprocess.Popen(command(str(src), "--out-dir", str(tmp_path / f"out{i}"), "--dask", address,
                                               "--dask-timeout", "600"), env=env,
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i, address in enumerate(addresses)}
    start = time.monotonic()
    for address, proc in procs.items():
        stdout, stderr = proc.communicate(timeout=600)
        assert proc.returncode == 1, (address, stderr)
        assert len(stderr.splitlines()) == 1 and stderr.startswith("depixel: error: "), (address, stderr)
        assert addresses[address] in stderr, (address, stderr)
    assert time.monotonic() - start < 200  # all nine at once: ~3 s on a quiet machine, none waited 600 s


def test_ctrl_c_reports_only_the_running_files_as_interrupted(tmp_path):
    """Before: files reported abandoned that had never started, and files written after the
    command exited."""
    big = tmp_path / "big.png"
    tiled(big, 8)
    out = tmp_path / "out"
    flags = tmp_path / "flags"
    flags.mkdir()
    with local_cluster(2, "track", env={"DEPIXEL_TEST_FLAGS": str(flags)}) as local:
        proc = subprocess.Popen(command(str(sprites(tmp_path / "in", 12, big)),
                                 "--out-dir", str(out), "--json", "--dask", local.scheduler_address),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_outputs(out, proc, count=2)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
        on_disk = stamped(out)
        # the batch's tasks gone from the scheduler (none left to start), then the running ones ended
        deadline = time.monotonic() + 120
        while local.scheduler.tasks:
            assert time.monotonic() < deadline, "the scheduler kept the stopped batch's tasks"
            time.sleep(0.05)
        wait_for_running_tasks(flags)
        assert stamped(out) == on_disk, "a file was completed after the command exited"
    assert proc.returncode == 130 and "Traceback" not in stderr
    report = json.loads(stdout)
    statuses = [o["status"] for o in report["outputs"]]
    assert {Path(o["output"]).name for o in report["outputs"] if o["status"] == "converted"} == on_disk
    assert statuses.count("interrupted") <= 2  # two workers of one thread: at most two running
    assert len(statuses) == 12 and "cancelled" in statuses
    assert leftovers(out) == []


def test_a_cluster_left_without_workers_stops_the_batch(tmp_path):
    """The only worker goes mid-run: after --dask-timeout seconds without a worker or a
    finished task, the batch stops with one line and reports what is on disk."""
    big = tmp_path / "big.png"
    tiled(big, 8)
    out = tmp_path / "out"
    with cluster(workers=0) as address:
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                   "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True)
        try:
            proc = subprocess.Popen(command(str(sprites(tmp_path / "in", 12, big)),
                                     "--out-dir", str(out), "--json", "--dask", address, "--dask-timeout", "2"),
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            wait_for_outputs(out, proc, count=1)
        finally:
            os.killpg(worker.pid, signal.SIGKILL)  # the worker and its nanny
            worker.wait()
        stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert stderr.splitlines() == [f"depixel: error: the Dask scheduler at {address} has had no worker for 2 s "
                                   "(--dask-timeout)"]
    report = json.loads(stdout)
    converted = {Path(o["output"]).name for o in report["outputs"] if o["status"] == "converted"}
    assert converted == stamped(out) and len(converted) >= 1
    assert report["failed"] == [] and report["not_done"] == 12 - len(converted) > 0
    assert leftovers(out) == []


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl to make a test certificate")
def test_a_tls_scheduler_is_used_with_the_configured_certificate(tmp_path):
    """tls:// with the client's certificate in the Dask configuration: converts (before: an
    internal TypeError, whatever the configuration)."""
    key, cert = tmp_path / "key.pem", tmp_path / "cert.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=localhost", "-days",
                    "2", "-keyout", str(key), "-out", str(cert)], check=True, capture_output=True)
    security = distributed.security.Security(
        tls_ca_file=str(cert), tls_client_cert=str(cert), tls_client_key=str(key), tls_scheduler_cert=str(cert),
        tls_scheduler_key=str(key), tls_worker_cert=str(cert), tls_worker_key=str(key), require_encryption=True)
    env = {**os.environ, "DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(cert),
           "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(cert), "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(key)}
    with local_cluster(1, protocol="tls", security=security) as local:
        assert local.scheduler_address.startswith("tls://")
        proc = subprocess.run(command(str(sprites(tmp_path / "in", 2)),
                               "--out-dir", str(tmp_path / "out"), "--json", "--dask", local.scheduler_address),
                              env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stderr == ""
    assert json.loads(proc.stdout)["ok"] == 2 and stamped(tmp_path / "out") == {"s000.svg", "s001.svg"}
