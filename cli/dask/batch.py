"""``depixel convert … --dask ADDRESS``: the batch's files as tasks on a Dask cluster.

Each task is :func:`depixel_cli.dask.task.run_task`, the same conversion that ``-j`` runs in
a worker process, so outputs, up-to-date skipping and failure messages are the same, byte
for byte. Inputs and outputs travel as paths: the workers read and write them on a
filesystem they share with the command (docs/scale.md explains why paths and not bytes).
Paths are made absolute before they are sent, since a worker's working folder is not the
command's.

A batch never loses or misreports a file:

* its task keys carry a random token of the run, so two batches on one scheduler never
  share a task (the scheduler would hand one the other's result);
* the cluster is checked before the first task (:mod:`depixel_cli.dask.cluster`);
* a task's report is checked against the disk: an output the worker says it wrote but
  that is not here, up to date, is a failure with the reason;
* the batch's *run marker* in the output folder is removed when the batch ends, and a task
  renames its output into place only while the marker exists, so that a stopped batch's
  tasks do not complete files its report calls interrupted;
* a stop (Ctrl-C, SIGTERM, the scheduler lost, no worker for ``--dask-timeout`` seconds)
  reports each unfinished file from the disk: converted if its outputs are there,
  interrupted if its task was running, cancelled if it never started;
* the temporary files named with the run's token (``Options.token``) are removed at the
  end from every output folder (a killed worker's included), and no others.

A worker that dies is Dask's to handle: it reschedules the task on another worker and,
after ``distributed.scheduler.allowed-failures`` deaths, fails it (``KilledWorker``), which
fails only that file.
"""
from __future__ import annotations

import os
import time
from dataclasses import replace
from functools import partial
from pathlib import Path

from depixel.errors import display_name
from depixel.files.output import remove_temporary_in

from ..convert.batch import (
    CANCELLED,
    DONE,
    INTERRUPTED,
    Job,
    Outcome,
    _outputs_to_make,
    abandoned,
    already_done,
    claim_outputs_of_the_dead,
    frame_targets,
)
from ..convert.run import Progress
from ..options import say
from .cluster import (
    check_joined,
    check_workers,
    checked_address,
    close,
    connect,
    make_marker,
    quiet_dask,
    reachable,
    wait_for_a_worker,
)
from .task import run_task, running_keys

#: Seconds between two looks at the signals while waiting for tasks.
POLL_SECONDS = 0.2
#: Seconds between two looks at the cluster (its workers, the tasks running) while waiting.
LOOK_SECONDS = 1.0
#: Seconds given, after the run marker is removed, to a task that saw it just before.
SETTLE_SECONDS = 0.1
#: Times a task that ran on a worker failing the probe is sent again, bound to the workers that
#: passed it (sent again, at the next look, when those all left).
MAX_TRIES = 3


def run_dask(jobs: list[Job], address: str, folder: Path | None, report, signals, progress: Progress | None,
             timeout: float, debug: bool = False) -> list[Outcome]:
    """Run the jobs, whose outputs are under ``folder`` (None: beside their inputs), as tasks
    on the Dask scheduler at ``address``; like :func:`depixel_cli.convert.run.run`, returns
    the outcomes in the order of ``jobs``. No wait on the cluster lasts more than ``timeout`` seconds; a cluster that
    cannot run the batch is a :class:`DaskError` (one line) before any task; ``debug``
    shows Dask's own logs."""
    address, host, port = checked_address(address)  # before importing Dask: a typo is refused at once
    outcomes: dict[int, Outcome] = {}
    for i, job in enumerate(jobs):  # up to date: decided here, no task (and no cluster when all are)
        if (done := already_done(job)) is not None:
            outcomes[i] = done
            report(done)
    todo = [i for i in range(len(jobs)) if i not in outcomes]
    if todo:
        signals.raising = False  # a signal is seen by the loops, which stop cleanly
        if folder is None:  # the run marker goes beside the first output
            folder = frame_targets(jobs[todo[0]])[0][2].parent
        with quiet_dask(debug):
            _Run(jobs, address, folder, report, signals, progress, timeout).run(todo, host, port, outcomes)
    return [outcomes[i] for i in range(len(jobs))]


class _Run:
    """One batch on the cluster: its token, client, run marker, and the outcomes of its tasks."""

    def __init__(self, jobs: list[Job], address: str, folder: Path, report, signals, progress: Progress | None,
                 timeout: float) -> None:
        self.jobs, self.address, self.folder, self.report = jobs, address, folder, report
        self.signals, self.progress, self.timeout = signals, progress, timeout
        # in its task keys and run marker: drawn for each run (a process's run_token, in the
        # temporary files' names, is the same for every batch a library user runs)
        self.token = os.urandom(6).hex()
        self.client = None
        self.marker: Path | None = None
        self.begun = 0  # the marker's modification time: the shared filesystem's clock, not this machine's
        self.good: set[str] = set()  # workers that passed the probe
        self.bad: dict[str, str] = {}  # workers that failed it (joined during the batch): why
        self.tries: dict[int, int] = {}  # job index → times its task was sent again from a failing worker
        self.bound: dict[str, set[str]] = {}  # the key of a task sent again → the workers it is bound to
        self.sent_again = 0  # tasks sent again, for their keys

    def run(self, todo: list[int], host: str, port: int, outcomes: dict[int, Outcome]) -> None:
        stopped = lambda: self.signals.signum is not None  # noqa: E731
        try:
            reachable(self.address, host, port, self.timeout)
            self.client = connect(self.address, self.timeout)
            if wait_for_a_worker(self.client, self.address, self.timeout, stopped):
                self.marker = make_marker(self.folder, self.token)
                self.signals.on_second = self._close_marker  # a second Ctrl-C exits at once: no task writes after
                self.begun = self.marker.stat().st_mtime_ns
                self.good = check_workers(self.client, self.folder, self.token, self.marker)
            if stopped():
                for i in todo:
                    outcomes[i] = Outcome(self.jobs[i].source, self.jobs[i].output, state=CANCELLED)
                    self.report(outcomes[i])
                return
            self._watch(todo, outcomes)
        finally:
            self._end()

    def _tell(self, text: str) -> None:
        if self.progress is not None:
            self.progress.message(text)
        else:
            say(text)

    def _watch(self, todo: list[int], outcomes: dict[int, Outcome]) -> None:
        """Submit the tasks and collect them until all are reported or the batch stops."""
        from distributed import as_completed  # noqa: PLC0415

        assert self.client is not None and self.marker is not None
        sent = {i: _absolute(self.jobs[i]) for i in todo}
        keys = [f"depixel-{self.token}-{i}-{self.jobs[i].source.name}" for i in todo]
        futures = self.client.map(partial(run_task, marker=str(self.marker)), list(sent.values()), key=keys,
                                  pure=False)
        index = {future.key: i for i, future in zip(todo, futures)}
        pending = set(futures)
        # results fetched by the client's event loop: a result whose worker died is computed
        # again there, without blocking this loop (and its watchdog) until a worker comes
        finished = as_completed(futures, loop=self.client.loop, with_results=True, raise_errors=False)
        assigned: set[str] = set()  # the keys of the tasks on a worker at the last look
        last_event = last_look = time.monotonic()
        alone_since: float | None = None  # since when the scheduler has had no worker
        stop: str | None = None
        while pending and stop is None and self.signals.signum is None:
            done = finished.next_batch(block=False)
            now = time.monotonic()
            for future, result in done:
                i = index[future.key]
                pending.discard(future)
                if (again := self._again(result, i, sent[i])) is not None:  # its worker failed the probe
                    index[again.key] = i
                    pending.add(again)
                    finished.add(again)
                    continue
                outcome = self._outcome(result, self.jobs[i], sent[i])
                if outcome is None:
                    pending.add(future)
                    stop = f"lost the Dask scheduler at {self.address}"
                    break
                outcomes[i] = outcome
                if self.progress is not None:
                    self.progress.current(self.jobs[i].source)
                self.report(outcome)
                last_event = now
            if stop is None and now - last_look >= LOOK_SECONDS:
                last_look = now
                looked = self._look()
                if looked is None:
                    stop = f"lost the Dask scheduler at {self.address}"
                    break
                assigned, alive = looked
                self._check_joined(alive)
                self.good &= alive
                for future in [f for f in pending if f.key in self.bound and not self.bound[f.key] & alive]:
                    if self.good:  # sent again to workers that all left: to those that passed now
                        self.bound.pop(future.key)
                        again = self._send(index[future.key], sent[index[future.key]])
                        future.cancel()
                        pending.discard(future)
                        index[again.key] = index[future.key]
                        pending.add(again)
                        finished.add(again)
                usable = alive & self.good  # the workers that may convert this batch
                alone_since = None if usable else alone_since or now
                if alone_since is not None and now - max(alone_since, last_event) >= self.timeout:
                    which = "worker" if not alive else "worker that can convert this batch"
                    stop = (f"the Dask scheduler at {self.address} has had no {which} for {self.timeout:g} s "
                            "(--dask-timeout)")
            if not done:
                time.sleep(POLL_SECONDS)
        if stop is not None:
            self._tell(f"error: {stop}")
        if pending:
            self._stop(pending, index, assigned, outcomes)

    def _look(self) -> tuple[set[str], set[str]] | None:
        """(keys of the tasks assigned to a worker, the workers alive), or None when the
        scheduler is lost."""
        assert self.client is not None
        if self.client.status != "running":
            return None
        try:
            processing = self.client.processing()  # {worker: [key, ...]} for every worker
        except Exception:  # the connection closed while asking
            return None
        return {key for keys in processing.values() for key in keys}, set(processing)

    def _check_joined(self, workers: set[str]) -> None:
        """Probe the workers not seen before (they joined during the batch), as every
        worker was before the first task; say once which cannot convert this batch."""
        new = sorted(workers - self.good - set(self.bad))
        if not new or self.marker is None:
            return
        assert self.client is not None
        for worker, problem in check_joined(self.client, new, self.folder, self.token, self.marker).items():
            if problem is None:
                self.good.add(worker)
            else:
                self.bad[worker] = problem
                self._tell(f"warning: {problem}; it joined during the batch: its tasks are sent to the other "
                           "workers")

    def _again(self, result, i: int, job: Job):
        """When the task of job ``i`` ran on a worker that fails the probe (one that joined
        during the batch, of another depixel version, say), the task sent again, to the
        workers that passed it; None when its result stands."""
        if not (isinstance(result, tuple) and len(result) == 2 and isinstance(result[0], Outcome)):
            return None
        worker = result[1]
        if worker not in self.good and worker not in self.bad:
            self._check_joined({worker})
        if worker not in self.bad or not self.good or self.tries.get(i, 0) >= MAX_TRIES:
            return None
        self.tries[i] = self.tries.get(i, 0) + 1
        return self._send(i, job)

    def _send(self, i: int, job: Job):
        """Send the task of job ``i`` again, bound to the workers that passed the probe (only
        them: the scheduler would otherwise give it to whichever is idle, the others too)."""
        assert self.client is not None and self.marker is not None
        self.sent_again += 1
        future = self.client.submit(partial(run_task, marker=str(self.marker)), job, pure=False,
                                    key=f"depixel-{self.token}-{i}-again{self.sent_again}-{self.jobs[i].source.name}",
                                    workers=sorted(self.good), allow_other_workers=False)
        self.bound[future.key] = set(self.good)
        return future

    def _stop(self, pending: set, index: dict, assigned: set[str], outcomes: dict[int, Outcome]) -> None:
        """Cancel the queued tasks, close the run marker to the running ones, and report each
        unfinished file from the disk: converted when its outputs are there, else interrupted
        when its task was running (asked of the workers; with the scheduler lost, assigned to
        a worker at the last look), else cancelled."""
        assert self.client is not None
        running = assigned
        if self.client.status == "running":
            try:
                found = self.client.run(running_keys, on_error="ignore")
                running = {key for keys in found.values() for key in keys}
                self.client.cancel(list(pending))
            except Exception:  # the scheduler went meanwhile
                pass
        self._close_marker(settle=True)
        for future in sorted(pending, key=lambda f: index[f.key]):
            i = index[future.key]
            outcome = abandoned(self.jobs[i], self.begun)
            if outcome.state == INTERRUPTED and not outcome.written and future.key not in running:
                outcome.state = CANCELLED
            outcomes[i] = outcome
            self.report(outcome)

    def _close_marker(self, settle: bool = False) -> None:
        """Remove the run marker: from now on the batch's tasks write nothing more (with
        ``settle``, after a moment for a rename that saw it just before)."""
        if self.marker is not None:
            try:
                self.marker.unlink()
            except OSError:
                pass
            self.marker = None
            if settle:
                time.sleep(SETTLE_SECONDS)

    def _end(self) -> None:
        """Close the marker and the client, and remove this run's temporary files."""
        self._close_marker()
        self.signals.on_second = None
        if self.client is not None:
            close(self.client)
        folders: set[tuple[str, str]] = set()
        for job in self.jobs:
            folders.update((os.path.realpath(target.parent), job.options.token)
                           for _, _, target, _ in frame_targets(job))
        for folder, token in folders:
            remove_temporary_in(folder, token)

    def _outcome(self, result, job: Job, sent: Job) -> Outcome | None:
        """The outcome of a task from its ``result`` (what :func:`run_task` returned, or the
        cancellation, or ``(type, exception, traceback)`` of its failure), with the command's
        own (relative) paths and checked against the disk; None when the scheduler is lost
        (the client then cancels every task)."""
        assert self.client is not None
        if isinstance(result, tuple) and len(result) == 2 and isinstance(result[0], Outcome):
            outcome, worker = result
            if worker in self.bad:  # sent again as often as it could be: the true reason
                return Outcome(job.source, job.output, error=f"{display_name(job.source)}: converted by a worker "
                               f"that cannot convert this batch: {self.bad[worker]}")
            return _checked(_local(outcome, job, sent), job, worker, self.begun)
        if isinstance(result, BaseException):  # cancelled
            if self.client.status != "running":
                return None
            return Outcome(job.source, job.output, error=f"{display_name(job.source)}: its Dask task was cancelled "
                           "on the cluster")
        exc = result[1]  # KilledWorker (its worker died every time), a task that could not be unpickled, ...
        reason = "worker process died on every Dask worker that tried it" if type(exc).__name__ == "KilledWorker" \
            else f"Dask task failed ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
        return Outcome(job.source, job.output, error=f"{display_name(job.source)}: {reason}")


def _absolute(job: Job) -> Job:
    return replace(job, source=job.source.absolute(), output=job.output.absolute(),
                   targets=tuple((frame, fmt, path.absolute(), sprite) for frame, fmt, path, sprite in job.targets))


def _local(outcome: Outcome, job: Job, sent: Job) -> Outcome:
    """The outcome with the command's own (relative) paths."""
    names = {str(sent.source): str(job.source)}
    names.update((str(a[2]), str(b[2])) for a, b in zip(frame_targets(sent), frame_targets(job)))
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


def _checked(outcome: Outcome, job: Job, worker: str, begun: int) -> Outcome:
    """The outcome as the disk here shows it: an output the worker reported converted or up
    to date that is not here, up to date (made from this input with these options), makes
    the file failed, with the reason. An output the task found up to date but written
    during this batch was completed by a try whose worker died after the rename: converted,
    not skipped. (An input that changed while converted is reported as such: its output is
    not current by design.)"""
    if outcome.error or outcome.changed or outcome.state != DONE:
        return outcome
    claim_outputs_of_the_dead(outcome, begun)
    here = Outcome(job.source)  # its up_to_date: the outputs current here, --force or not
    try:
        _outputs_to_make(replace(job, options=replace(job.options, force=False, explicit=False)), here)
    except Exception as exc:  # the input is gone or unreadable here
        outcome.error = f"{display_name(job.source)}: cannot check its outputs here ({exc})"
    stale = [target for target in outcome.written + outcome.up_to_date if target not in here.up_to_date]
    if stale and outcome.error is None:
        target = stale[0]
        said = "converted" if target in outcome.written else "up to date"
        found = "is not there" if not os.path.lexists(target) else "there is not the file it wrote"
        outcome.error = (f"{display_name(target)}: Dask worker {worker} reported it {said}, but the file {found}: "
                         "the workers must write to a filesystem that this machine shares, at the same path")
    if outcome.error:
        outcome.written = [p for p in outcome.written if p not in stale]
        outcome.up_to_date = [p for p in outcome.up_to_date if p not in stale]
    return outcome
