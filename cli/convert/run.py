"""Converting many files, the last step: running the jobs, ``-j`` processes at a time
(:mod:`depixel_cli.pool`), with a progress bar, and choosing ``-j auto`` from the cores and
the memory.

Its own module because the scheduling (worker count, interrupts, progress) is apart from
what one job does (:mod:`depixel_cli.convert.batch`).
"""
from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import cast

from depixel.errors import display_name
from depixel.files.output import remove_created
from depixel.limits import PEAK_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES

from .batch import (
    CANCELLED,
    Job,
    Outcome,
    abandoned,
    already_done,
    claim_outputs_of_the_dead,
    remove_temporary_files,
    run_job,
)

#: The largest image (pixels, from its header) the main process converts itself while its
#: workers start: ~65 MB at PEAK_BYTES_PER_PIXEL, so a batch holds little more memory than
#: its workers, which ``-j auto`` counted.
LOCAL_MAX_PIXELS = 256 * 256


def run(jobs: list[Job], workers: int, report, signals, progress: Progress | None = None) -> list[Outcome]:
    """Run the jobs, ``workers`` processes at a time (this process for one; with more, this
    process converts files too while the workers start), until done or stopped by
    ``signals``; ``report(outcome)`` is called as each one ends. Returns the outcomes in the
    order of ``jobs``; after a stop, the unfinished ones are INTERRUPTED or CANCELLED."""
    from ..pool import Finished, Interrupted, Meanwhile, run_jobs  # noqa: PLC0415

    outcomes: dict[int, Outcome] = {}
    begun = time.time_ns()

    def finished(done: Finished) -> None:
        job = jobs[done.index]
        if done.interrupted:
            outcome = abandoned(job, begun)
        elif done.cancelled:
            outcome = Outcome(job.source, job.output, state=CANCELLED)
        elif done.died:
            outcome = Outcome(job.source, job.output,
                              error=f"{display_name(job.source)}: worker process died ({done.died}), also when retried")
        else:
            outcome = done.result
            if done.retried:
                claim_outputs_of_the_dead(outcome, begun)
                outcome.notes.append(f"{display_name(job.source)}: worker process died ({done.retried}); "
                                     "converted on the retry")
        outcomes[done.index] = outcome
        report(outcome)

    def started(index: int) -> None:
        if progress is not None:
            progress.current(jobs[index].source)

    for index, job in enumerate(jobs):
        if (done := already_done(job)) is not None:
            finished(Finished(index, done))
    todo = [i for i in range(len(jobs)) if i not in outcomes]

    def here(job: Job) -> Outcome | None:
        """Convert in this process; None when a signal abandoned the file (cleaned up)."""
        signals.raising = True  # a signal now abandons the file at once (the writer removes its temporary file)
        try:
            return run_job(job)
        except Interrupted:
            remove_temporary_files(job)
            remove_created()
            return None
        finally:
            signals.raising = False

    def one_by_one(indices: list[int]) -> None:
        """Convert ``jobs[i]`` for each of ``indices`` in this process, in turn."""
        for index in indices:
            if signals.signum is not None:
                finished(Finished(index, cancelled=True))
                continue
            started(index)
            result = here(jobs[index])
            finished(Finished(index, interrupted=True) if result is None else Finished(index, result))

    if len(todo) <= 1:  # (one file: no pack, and none of their modules)
        one_by_one(todo)
        return [outcomes[i] for i in range(len(jobs))]
    from .packs import packs, run_pack  # noqa: PLC0415

    if workers <= 1:
        for pack in packs(len(todo)):
            with ahead_of([jobs[todo[i]] for i in pack], signals):
                one_by_one([todo[i] for i in pack])
    else:
        signals.raising = False
        # each worker takes packs of files (their pipelines in one pass, cli/convert/packs.py),
        # small enough that the last ones keep every worker busy
        groups = [[todo[i] for i in pack] for pack in packs(len(todo), workers)]
        alone: list[int] = []  # files of a pack whose worker died on every try: each again alone

        def unpacked(done: Finished) -> None:  # run_jobs numbers the packs
            group = groups[done.index]
            if done.died and len(group) > 1:
                alone.extend(group)
                return
            for k, index in enumerate(group):
                finished(Finished(index, None if done.result is None else done.result[k], done.died, done.retried,
                                  done.interrupted, done.cancelled))

        def clean(pack: tuple[Job, ...]) -> None:
            for job in pack:
                remove_temporary_files(job)

        def here_all(pack: tuple[Job, ...]) -> list[Outcome] | None:
            with ahead_of(list(pack), signals):
                outcomes = [here(job) for job in pack]
            return None if None in outcomes else cast("list[Outcome]", outcomes)

        # while the fork server imports depixel, this process converts small files itself
        run_jobs([tuple(jobs[i] for i in group) for group in groups], workers, run_pack, unpacked, signals,
                 cleanup=clean, started=lambda i: started(groups[i][0]),
                 meanwhile=Meanwhile(here_all, lambda pack: all(map(small, pack))))
        if alone:  # a file that kills its worker fails alone
            def renumbered(done: Finished) -> None:  # run_jobs numbers the jobs of ``alone``
                finished(Finished(alone[done.index], done.result, done.died, done.retried, done.interrupted,
                                  done.cancelled))

            run_jobs([jobs[i] for i in alone], workers, run_job, renumbered, signals, cleanup=remove_temporary_files,
                     started=lambda i: started(alone[i]))
    return [outcomes[i] for i in range(len(jobs))]


class Progress:
    """A tqdm bar on stderr for two or more files when stderr is a terminal, showing the file
    being converted; messages print above it. A terminal that reports no width (a pty
    under ``script``) gets an 80-column bar. Without tqdm's monitor thread: workers are
    forked from this process (:mod:`depixel_cli.pool`), which must then have no other
    thread, and the bar is redrawn as each file begins anyway."""

    def __init__(self, total: int) -> None:
        self.bar = None
        if total >= 2 and sys.stderr.isatty():
            from tqdm import tqdm  # noqa: PLC0415

            try:
                columns, lines = os.get_terminal_size(sys.stderr.fileno())
            except OSError:
                columns = lines = 0
            # tqdm draws nothing on a terminal of 0 columns or 0 lines: assume 80x24 there
            size = {"dynamic_ncols": True} if columns > 0 else {"ncols": 80}
            tqdm.monitor_interval = 0
            self.bar = tqdm(total=total, unit="file", file=sys.stderr, leave=False, nrows=lines or 24, **size)

    def message(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(f"depixel: {text}", file=sys.stderr)
        else:
            print(f"depixel: {text}", file=sys.stderr, flush=True)

    def current(self, path: Path) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(display_name(path.name), refresh=True)

    def step(self) -> None:
        if self.bar is not None:
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Repeats:
    """An error that is the same for every input (a read-only output folder, a full disk,
    cairo missing) is printed once, with the count at the end (:meth:`lines`), not once a
    file: an error that does not name its input once its output's name is taken out, and
    then reads like one printed before, is counted instead of printed. Errors about an input
    (not an image, too large) name it, and are all printed; ``--json`` lists every one."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}

    def first(self, outcome: Outcome) -> bool:
        """Whether to print ``outcome``'s error (it is not a repeat)."""
        text = str(outcome.error)
        if outcome.output is not None:
            text = text.replace(display_name(outcome.output), display_name(outcome.output.parent / "…"))
        if display_name(outcome.source) in text:
            return True
        self.counts[text] = self.counts.get(text, 0) + 1
        return self.counts[text] == 1

    def lines(self) -> list[str]:
        """One line for each error printed once that more files had."""
        return [f"error: {n - 1} more file{'s' if n > 2 else ''} failed the same way: {text}"
                for text, n in self.counts.items() if n > 1]


@contextmanager
def ahead_of(pack: list[Job], signals) -> Iterator[None]:
    """:func:`packed`: the pack's pipelines in one pass first (a signal abandons the pass at
    once; then no job finds its result ahead, and they are cancelled)."""
    from ..pool import Interrupted  # noqa: PLC0415
    from .packs import packed  # noqa: PLC0415

    with ExitStack() as stack:
        if len(pack) > 1 and signals.signum is None:
            signals.raising = True
            try:
                stack.enter_context(packed(pack))
            except Interrupted:
                pass
            finally:
                signals.raising = False
        yield


def small(job: Job) -> bool:
    """Whether the main process may convert ``job`` itself: at most LOCAL_MAX_PIXELS."""
    size = header_size(job.source)
    return size is not None and size[0] * size[1] <= LOCAL_MAX_PIXELS


def header_size(path: Path) -> tuple[int, int] | None:
    """An input's width and height from its header, None when it is not a regular file
    (opened only then: a named pipe would wait for a writer) or not an image."""
    from PIL import Image  # noqa: PLC0415

    from depixel.prepare.image import open_input  # noqa: PLC0415

    try:
        with open_input(path, display_name(path), regular=True) as fh, Image.open(fh) as img:
            return img.size
    except Exception:  # unreadable: the job reports it
        return None


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def available_memory() -> int | None:
    """Bytes of memory available to new processes (Linux MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo", "rb") as fh:
            for line in fh:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def largest_image(jobs: list[Job]) -> tuple[int, Path | None]:
    """Pixels of the largest input (from the headers, nothing decoded) and its path."""
    best, where = 0, None
    for job in jobs:
        size = header_size(job.source)
        if size is not None and size[0] * size[1] > best:
            best, where = size[0] * size[1], job.source
    return best, where


def auto_jobs(jobs: list[Job], memory: int | None = None, asked: int | None = None) -> tuple[int, str | None]:
    """``-j auto`` (``asked`` None): one worker per core; ``-j N``: N. Either way no more
    workers than files, nor than the available memory holds when each converts the largest
    image (PEAK_BYTES_PER_PIXEL per pixel, measured), or a pass of as many such images as a
    pack's pass holds: an explicit count is capped by the same estimate. Returns the count
    and, when memory is what limits it, a note saying so."""
    count = max(1, min(cores() if asked is None else asked, len(jobs)))
    if count == 1:
        return 1, None
    memory = available_memory() if memory is None else memory
    pixels, where = largest_image(jobs)
    if memory is None or where is None:
        return count, None
    from depixel.pipeline import PASS_IMAGES, PASS_PIXELS  # noqa: PLC0415

    # a worker converts a pack's images in one pass, which holds them all at once
    need = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * max(pixels, min(PASS_PIXELS, PASS_IMAGES * pixels))
    fits = max(1, memory // need)
    if fits >= count:
        return count, None
    return fits, (f"-j {'auto' if asked is None else asked}: {fits} worker{'s' if fits > 1 else ''}, not {count}: "
                  f"converting {display_name(where)} ({pixels} pixels) takes about {need / 2**30:.1f} GiB and "
                  f"{memory / 2**30:.1f} GiB is available")
