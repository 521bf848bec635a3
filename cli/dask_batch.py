"""``depixel convert … --dask ADDRESS``: the batch's files as tasks on a Dask cluster.

Each task is the same :func:`depixel_cli.batch.run_job` that ``-j`` runs in a worker process,
so outputs, up-to-date skipping and failure messages are the same, byte for byte. Inputs
and outputs travel as paths: the workers read and write them on a filesystem they share
with the command (docs/scale.md explains why paths and not bytes). Paths are made absolute
before they are sent, since a worker's working folder is not the command's.

A worker that dies is Dask's to handle: it reschedules the task on another worker and,
after ``distributed.scheduler.allowed-failures`` deaths, fails it (``KilledWorker``), which
fails only that file. On Ctrl-C or SIGTERM, queued tasks are cancelled; a task already
running on a worker cannot be stopped by Dask and finishes there (its output is written
atomically, whole or not at all).
"""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from depixel.errors import DepixelError, display_name

from .batch import CANCELLED, INTERRUPTED, Job, Outcome, already_done, frame_targets, run_job
from .batch_run import Progress

#: Seconds between two looks at the signals while waiting for tasks.
POLL_SECONDS = 0.2


class DaskError(DepixelError):
    """The Dask extra is missing or the scheduler cannot be reached."""


def run_dask(jobs: list[Job], address: str, report, signals, progress: Progress | None = None) -> list[Outcome]:
    """Run the jobs as tasks on the Dask scheduler at ``address``; like
    :func:`depixel_cli.batch_run.run`, returns the outcomes in the order of ``jobs``."""
    try:
        from distributed import Client, as_completed  # noqa: PLC0415
    except ImportError:
        raise DaskError("--dask needs the Dask extra: pip install 'depixel[dask]'") from None
    if not jobs:
        return []
    try:
        client = Client(address, timeout="20s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise DaskError(f"cannot reach the Dask scheduler at {address} ({str(exc).splitlines()[0]})") from None
    outcomes: dict[int, Outcome] = {}
    signals.raising = False  # a signal is seen by the loop below, which cancels the queue
    try:
        for i, job in enumerate(jobs):  # up to date: decided here, no task
            if (done := already_done(job)) is not None:
                outcomes[i] = done
                report(done)
        todo = [i for i in range(len(jobs)) if i not in outcomes]
        absolute = {i: _absolute(jobs[i]) for i in todo}
        futures = client.map(run_job, list(absolute.values()), pure=False,
                             key=[f"depixel-{i}-{jobs[i].source.name}" for i in todo])
        index = {future.key: i for i, future in zip(todo, futures)}
        pending = set(futures)
        finished = as_completed(futures, loop=client.loop)
        while pending and signals.signum is None:
            done = finished.next_batch(block=False)
            if not done:
                time.sleep(POLL_SECONDS)
                continue
            pending.difference_update(done)
            for future in done:
                i = index[future.key]
                outcomes[i] = _outcome(future, jobs[i], absolute[i])
                if progress is not None:
                    progress.current(jobs[i].source)
                report(outcomes[i])
        if pending:  # stopped: queued tasks are cancelled, running ones finish on their worker
            try:
                running = {key for keys in client.processing().values() for key in keys}
            except Exception:  # the scheduler is gone: nothing is known to run
                running = set()
            client.cancel(list(pending))
            for future in pending:
                i = index[future.key]
                state = INTERRUPTED if future.key in running else CANCELLED
                outcomes[i] = Outcome(jobs[i].source, jobs[i].output, state=state)
                report(outcomes[i])
    finally:
        client.close(timeout=2)
    return [outcomes[i] for i in range(len(jobs))]


def _absolute(job: Job) -> Job:
    return replace(job, source=job.source.absolute(), output=job.output.absolute(),
                   targets=tuple((frame, fmt, path.absolute()) for frame, fmt, path in job.targets))


def _outcome(future, job: Job, sent: Job) -> Outcome:
    """The task's outcome with the command's own (relative) paths, or its failure."""
    try:
        outcome = future.result()
    except Exception as exc:  # KilledWorker (its worker died every time), a lost connection, ...
        reason = "worker process died on every Dask worker that tried it" if type(exc).__name__ == "KilledWorker" \
            else f"Dask task failed ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
        return Outcome(job.source, job.output, error=f"{display_name(job.source)}: {reason}")
    names = {str(sent.source): str(job.source)}
    names.update((str(a), str(b)) for (*_, a), (*_, b) in zip(frame_targets(sent), frame_targets(job)))
    local = {Path(a): Path(b) for a, b in names.items()}
    outcome.source, outcome.output = job.source, job.output
    outcome.written = [local.get(p, p) for p in outcome.written]
    outcome.up_to_date = [local.get(p, p) for p in outcome.up_to_date]
    outcome.kept = [local.get(p, p) for p in outcome.kept]
    outcome.edited = [local.get(p, p) for p in outcome.edited]
    outcome.seconds = {local.get(p, p): s for p, s in outcome.seconds.items()}
    outcome.sizes = {local.get(p, p): n for p, n in outcome.sizes.items()}
    outcome.changed = outcome.changed and _relative(outcome.changed, names)
    outcome.error = outcome.error and _relative(outcome.error, names)
    outcome.notes = [_relative(note, names) for note in outcome.notes]
    return outcome


def _relative(text: str, names: dict[str, str]) -> str:
    for a, b in names.items():
        text = text.replace(display_name(a), display_name(b))
    return text
