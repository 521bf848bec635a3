"""What a Dask worker runs for ``depixel convert --dask`` (:mod:`depixel_cli.dask.batch`):
the probe before a batch, and each file's task.

Both are sent by reference (module and name), so a worker must have this package: a worker
without it fails the probe with ``ModuleNotFoundError``, which the command reports. The
batch's *run marker*, a file the command creates in the output folder and removes when the
batch ends, is how a worker tells that it sees the command's files, and whether the batch
is still running.
"""
from __future__ import annotations

import os
import socket

from ..convert.batch import Job, Outcome, run_job


def probe(folder: str, token: str, marker: str) -> dict[str, str | bool | None]:
    """Run on every worker before a batch: depixel's version here, whether this worker sees
    the command's ``marker`` (the output ``folder``, as the command sees it), and the name of
    a probe file it wrote there and read back, for the command to read too. Never raises."""
    import depixel  # noqa: PLC0415 (the version this worker would convert with)

    found: dict[str, str | bool | None] = {
        "version": depixel.__version__, "host": socket.gethostname(), "sees_marker": False, "probe": None,
        "error": None}
    try:
        with open(marker, encoding="ascii") as fh:
            found["sees_marker"] = fh.read() == token
    except OSError:
        pass
    if not found["sees_marker"]:
        return found  # writing would leave a file the command cannot see, so cannot remove
    name = f".depixel-probe.{token}.{os.urandom(6).hex()}.tmp"
    path = os.path.join(folder, name)
    try:
        with open(path, "x", encoding="ascii") as fh:
            fh.write(name)
        with open(path, encoding="ascii") as fh:
            if fh.read() == name:
                found["probe"] = name
    except OSError as exc:
        found["error"] = exc.strerror or str(exc)
    return found


def run_task(job: Job, marker: str) -> tuple[Outcome, str]:
    """Convert one file as :func:`depixel_cli.convert.batch.run_job` does, each output renamed into
    place only while the command's run ``marker`` exists (a stopped batch removes it).
    Returns the outcome and the address of the worker (for the command's messages). Never
    raises."""
    from distributed import get_worker  # noqa: PLC0415

    from depixel.files.output import STILL_WANTED  # noqa: PLC0415

    scope = STILL_WANTED.set(lambda: os.path.exists(marker))
    try:
        return run_job(job), get_worker().address
    finally:
        STILL_WANTED.reset(scope)


def running_keys(dask_worker) -> list[str]:
    """Run on every worker when a batch stops: the keys of the tasks this worker is running
    (the scheduler knows only which are assigned to it, some still queued there)."""
    return [str(task.key) for task in dask_worker.state.all_running_tasks]
