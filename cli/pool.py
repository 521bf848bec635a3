"""Worker processes that survive faults and stop cleanly on Ctrl-C or SIGTERM.

One design serves every command (docs/cli.md, "Interrupts and faults"):

* :class:`Signals` turns the first SIGINT/SIGTERM into a request to stop (a flag, and an
  :class:`Interrupted` exception where work may be abandoned at once) and makes a second one
  exit at once, quietly, with 128 + the signal number.
* :func:`run_jobs` hands jobs to each worker over its own pipe, at most :data:`DEPTH` at a
  time (the one it runs and the next, waiting in the pipe so the worker never idles while
  the main process reports a result), so the main process always knows which jobs a worker
  holds: the first is running, the others have not started. A worker that dies (killed,
  out of memory) fails only the job it was running, which is retried once in a fresh
  worker; the jobs waiting behind it go back to the queue untouched. On a stop request no
  new job is handed out, queued jobs are cancelled, running ones get SIGTERM (a worker then
  abandons its file; the atomic writer removes its temporary file) and, after a short
  grace, SIGKILL; their temporary files are removed by the caller's ``cleanup``. No worker
  outlives the command: they also get SIGTERM from the kernel when the main process dies.

On Linux, workers are forked from the main process once it has imported what a conversion
needs (:data:`PRELOAD`): a worker starts in about a millisecond, imports nothing and shares
those pages, and no fork server imports depixel a second time (~0.5 s of CPU a batch). A
forked worker closes the other workers' pipes it inherited (so each pipe has one end in one
worker) and the main process has no other thread when it forks. Elsewhere they are forked
from a ``forkserver`` that imported :data:`PRELOAD` once (``spawn`` where there is none),
and the main process converts files while it starts. Workers ignore SIGINT, which a
terminal sends to the whole process group: only the main process decides what Ctrl-C means.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from .worker import serve

#: Seconds running jobs get to stop after SIGTERM before they are killed.
GRACE_SECONDS = 1.0
#: Times a job whose worker died is tried again, each time in a fresh worker.
RETRIES = 1
#: Jobs a worker holds at once: the one it runs and the next, already in its pipe.
DEPTH = 2
#: What the main process (Linux) or the fork server imports before the workers are forked, so
#: that no worker imports it: the job code, the modules a conversion imports on first use
#: (~0.1 s of each worker's first file otherwise) and the worker loop (this module, and
#: ctypes for ``worker.die_with_parent``).
PRELOAD = ["depixel_cli.convert.batch", "PIL.PngImagePlugin", "depixel.curves.splines", "depixel.optimize.stage",
           "tempfile", "depixel_cli.pool", "depixel_cli.worker", "ctypes"]
#: How workers start: ``fork`` from the main process on Linux; elsewhere (where a forked
#: process may not use some system libraries) a ``forkserver``, else ``spawn``.
START_METHOD = "fork" if sys.platform.startswith("linux") else "forkserver"


class Interrupted(BaseException):
    """A stop request (SIGINT or SIGTERM) raised where work can be abandoned at once."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


class Signals:
    """While active (a context manager): the first SIGINT or SIGTERM sets :attr:`signum`
    and, when :attr:`raising` is on, raises :class:`Interrupted`; a second one calls
    ``on_second`` (kill the workers) and exits at once with 128 + its number."""

    def __init__(self, raising: bool = True) -> None:
        self.signum: int | None = None
        self.raising = raising
        self.on_second: Callable[[], None] | None = None
        self.wakeup_fd: int | None = None  # written to on a signal: wakes a select() loop
        self._saved: dict[int, Any] = {}

    def __enter__(self) -> Signals:
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._saved[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._saved.items():
            signal.signal(signum, handler)

    def _handle(self, signum: int, frame: object) -> None:
        if self.signum is not None:  # the second one: no more waiting
            if self.on_second is not None:
                self.on_second()
            os._exit(128 + signum)
        self.signum = signum
        if self.wakeup_fd is not None:
            try:
                os.write(self.wakeup_fd, b"!")
            except OSError:
                pass
        if self.raising:
            raise Interrupted(signum)


@dataclass(eq=False)
class Finished:
    """What :func:`run_jobs` reports for one job: its result, or why there is none."""

    index: int
    result: Any = None
    died: str | None = None  # the worker died on every try: how
    retried: str | None = None  # the worker died once and the retry gave the result: how
    interrupted: bool = False  # running when the stop came, abandoned
    cancelled: bool = False  # not started when the stop came


class Meanwhile(NamedTuple):
    """What this process does while workers that take time to start (not forked from it)
    start: ``run(job)`` on jobs from the end of the queue (None: interrupted, cleaned up), as
    long as the next is ``local(job)``."""

    run: Callable[[Any], Any]
    local: Callable[[Any], bool] = lambda job: True


def run_jobs(jobs: Sequence[Any], workers: int, function: Callable[[Any], Any], report: Callable[[Finished], None],
             signals: Signals, cleanup: Callable[[Any], None] = lambda job: None,
             started: Callable[[int], None] = lambda index: None, meanwhile: Meanwhile | None = None) -> None:
    """Run ``function(job)`` for every job in ``workers`` processes; ``report`` gets each
    :class:`Finished` as it happens (cancelled jobs last), ``started`` each index as it
    begins. ``function`` must be picklable by reference and must not raise. With
    ``meanwhile``, this process converts jobs itself while the workers start. Returns when
    all are reported."""
    pool = _Pool(function, signals, cleanup, started)
    try:
        if pool.forks:
            import importlib  # noqa: PLC0415

            for name in PRELOAD:  # once here, shared by every worker forked after
                importlib.import_module(name)
            pool.run(list(enumerate(jobs)), workers, report)
        elif meanwhile is not None and workers >= 2:
            pool.start_meanwhile(pending := list(enumerate(jobs)), workers, meanwhile.run, meanwhile.local, report)
            pool.run(pending, workers, report)
        else:
            pool.run(list(enumerate(jobs)), workers, report)
    finally:
        pool.close()


class _Worker:
    conn: Any  # this process's end of the worker's pipe (a multiprocessing Connection)

    def __init__(self, context, function: Callable, others: Sequence[_Worker] = ()) -> None:
        """A started worker; forked from this process, it closes the pipes of ``others``."""
        parent, child = context.Pipe()
        inherited = [w.conn for w in others] + [parent] if context.get_start_method() == "fork" else []
        self.process = context.Process(target=serve, args=(child, function, inherited), daemon=True)
        # SIGINT and SIGTERM stay blocked from here until the worker has its own handlers (a
        # forked worker inherits the mask, and this process's handlers until then)
        # (multiprocessing flushes stdout and stderr before it forks: nothing is written twice)
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            self.process.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        child.close()
        self.conn = parent
        self.jobs: list[tuple[int, Any]] = []  # in the order sent: the first is running

    def give(self, job: tuple[int, Any]) -> None:
        self.jobs.append(job)
        try:
            self.conn.send(job[1])
        except OSError:
            pass  # it died already: seen through its sentinel

    def results(self) -> list[Any]:
        """The results waiting in the pipe (of the first jobs held, in order)."""
        found: list[Any] = []
        try:
            while len(found) < len(self.jobs) and self.conn.poll():
                found.append(self.conn.recv())
        except (EOFError, OSError):
            pass
        return found

    def how_it_died(self) -> str:
        self.process.join(5)
        code = self.process.exitcode
        if code is not None and code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        return f"exit code {code}"


class _Pool:
    def __init__(self, function: Callable, signals: Signals, cleanup: Callable[[Any], None],
                 started: Callable[[int], None]) -> None:
        self.started = started
        self.context = context()
        self.forks = self.context.get_start_method() == "fork"
        self.function = function
        self.signals = signals
        self.cleanup = cleanup
        self.workers: list[_Worker] = []
        self.wake_r, self.wake_w = os.pipe()
        os.set_blocking(self.wake_w, False)
        signals.wakeup_fd = self.wake_w
        signals.on_second = self.kill_all

    def run(self, pending: list[tuple[int, Any]], size: int, report: Callable[[Finished], None]) -> None:
        from multiprocessing.connection import wait  # noqa: PLC0415

        tries: dict[int, int] = {}
        retried: dict[int, str] = {}
        while (pending or any(w.jobs for w in self.workers)) and self.signals.signum is None:
            self._hand_out(pending, size)
            busy = [w for w in self.workers if w.jobs]
            ready = wait([w.conn for w in busy] + [w.process.sentinel for w in busy] + [self.wake_r])
            for worker in busy:
                if worker.conn in ready or worker.process.sentinel in ready:
                    self._collect(worker, pending, tries, retried, report)
        if self.signals.signum is not None:
            self._stop(pending, report)

    def start_meanwhile(self, pending: list[tuple[int, Any]], size: int, here: Callable[[Any], Any],
                        local: Callable[[Any], bool], report: Callable[[Finished], None]) -> None:
        """Start the workers in a thread, each given its first jobs as soon as it is up,
        while this thread runs ``here`` on jobs from the end of the queue (until one is not
        ``local``): the fork server's imports (~0.4 s, serial) no longer leave a core idle."""
        import threading  # noqa: PLC0415

        lock = threading.Lock()
        failed: list[BaseException] = []

        def start() -> None:
            for _ in range(size):
                try:
                    worker = _Worker(self.context, self.function)
                except Exception as exc:  # raised here, in the main thread, as without the thread
                    failed.append(exc)
                    return
                with lock:
                    self.workers.append(worker)
                    self._top_up(worker, pending, size, DEPTH)

        starter = threading.Thread(target=start, name="depixel-start-workers", daemon=True)
        starter.start()
        try:
            while starter.is_alive() and self.signals.signum is None:
                with lock:
                    if len(pending) <= size * DEPTH or not local(pending[-1][1]):
                        break
                    index, job = pending.pop()
                self.started(index)
                result = here(job)
                report(Finished(index, interrupted=True) if result is None else Finished(index, result))
        finally:
            starter.join()
        if failed and self.signals.signum is None:  # after a stop (its signal may have ended
            raise failed[0]                            # the fork server), the stop is the story

    def _hand_out(self, pending: list[tuple[int, Any]], size: int) -> None:
        """Fill the workers, starting new ones up to ``size``: first one job each (so that a
        short batch is spread over every worker), then up to :data:`DEPTH` while there are
        more jobs left than workers (at the end a file waiting behind another in one worker
        would leave another worker idle)."""
        for depth in range(1, DEPTH + 1):
            while pending and self.signals.signum is None and (depth == 1 or len(pending) >= size):
                worker = next((w for w in self.workers if len(w.jobs) < depth), None)
                if worker is None and len(self.workers) < size:
                    worker = _Worker(self.context, self.function, self.workers)
                    self.workers.append(worker)
                if worker is None:
                    break
                self._top_up(worker, pending, size, depth)

    def _top_up(self, worker: _Worker, pending: list[tuple[int, Any]], size: int, depth: int) -> None:
        """Give ``worker`` jobs from the front of ``pending`` until it holds ``depth``; beyond
        its first only while at least as many jobs are left as workers. The one place that
        decides how a worker is filled, for :meth:`_hand_out` and the workers' start."""
        while pending and self.signals.signum is None and len(worker.jobs) < depth and \
                (not worker.jobs or len(pending) >= size):
            worker.give(pending.pop(0))
            if len(worker.jobs) == 1:
                self.started(worker.jobs[0][0])

    def _collect(self, worker: _Worker, pending: list, tries: dict[int, int], retried: dict[int, str],
                 report: Callable[[Finished], None]) -> None:
        for result in worker.results():
            index, _ = worker.jobs.pop(0)
            if worker.jobs:
                self.started(worker.jobs[0][0])
            report(Finished(index, result, retried=retried.get(index)))
        if not worker.jobs or worker.process.is_alive():
            return
        # the worker died running its first job: a fresh worker tries it once more; the jobs
        # waiting behind it never started and go back to the queue as they were
        how = worker.how_it_died()
        self.workers.remove(worker)
        worker.conn.close()
        (index, job), *waiting = worker.jobs
        worker.jobs = []
        pending[:0] = waiting
        self.cleanup(job)
        tries[index] = tries.get(index, 0) + 1
        if self.signals.signum is not None:  # stopped by the same signal as the main process
            report(Finished(index, interrupted=True))
        elif tries[index] <= RETRIES:
            retried[index] = how
            pending.insert(0, (index, job))
        else:
            report(Finished(index, died=how))

    def _stop(self, pending: list[tuple[int, Any]], report: Callable[[Finished], None]) -> None:
        """Stop request: cancel the queue, abandon running jobs (SIGTERM, then SIGKILL)."""
        busy = [w for w in self.workers if w.jobs]
        for worker in busy:
            _signal(worker, signal.SIGTERM)
        deadline = time.monotonic() + GRACE_SECONDS
        for worker in busy:
            worker.process.join(max(0.0, deadline - time.monotonic()))
        for worker in busy:
            if worker.process.is_alive():
                _signal(worker, signal.SIGKILL)
                worker.process.join(1)
            for result in worker.results():  # finished before the stop reached it
                index, _ = worker.jobs.pop(0)
                report(Finished(index, result))
            if worker.jobs:  # the first was running; those behind it never started
                (index, job), *waiting = worker.jobs
                self.cleanup(job)
                report(Finished(index, interrupted=True))
                pending[:0] = waiting
            worker.jobs = []
        for index, _ in pending:
            report(Finished(index, cancelled=True))
        pending.clear()

    def kill_all(self) -> None:
        """Second signal: kill every worker and remove their temporary files, at once."""
        for worker in self.workers:
            _signal(worker, signal.SIGKILL)
        for worker in self.workers:
            if worker.jobs:
                worker.process.join(0.5)
                self.cleanup(worker.jobs[0][1])

    def close(self) -> None:
        for worker in self.workers:
            if not worker.jobs:
                try:
                    worker.conn.send(None)  # done: exit
                except OSError:
                    pass
        for worker in self.workers:
            worker.process.join(2)
            if worker.process.is_alive():
                _signal(worker, signal.SIGKILL)
                worker.process.join(1)
            worker.conn.close()
        self.workers.clear()
        self.signals.wakeup_fd = None
        self.signals.on_second = None
        os.close(self.wake_r)
        os.close(self.wake_w)


def context() -> Any:
    """The multiprocessing context of the workers (:data:`START_METHOD`): ``fork``, or a
    ``forkserver`` that imports :data:`PRELOAD` once and forks each worker from it (a worker
    starts in milliseconds, holding only its own pipe), else ``spawn``."""
    import multiprocessing  # noqa: PLC0415

    if START_METHOD == "fork":
        return multiprocessing.get_context("fork")
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    server = multiprocessing.get_context("forkserver")
    server.set_forkserver_preload(PRELOAD)
    return server


def _signal(worker: _Worker, signum: int) -> None:
    try:
        os.kill(worker.process.pid, signum)
    except (ProcessLookupError, TypeError):
        pass
