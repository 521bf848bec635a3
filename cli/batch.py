"""Converting many files: finding the inputs, naming the outputs, running them in parallel.

Every file is one :class:`Job`, converted by :func:`run_job` in a worker process
(:mod:`depixel_cli.pool`), in this process for ``-j 1``, or as a Dask task
(:mod:`depixel_cli.dask_batch`). A job never raises: it returns an :class:`Outcome` with
the files written, those already up to date and, on failure, a one-line reason, so one bad
file never stops the batch. Each file's output depends only on the file and the options,
so the results are the same whatever runs them.
"""
from __future__ import annotations

import glob
import os
import sys
import time
import traceback
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from depixel import api
from depixel import stamp as stamps
from depixel.errors import DepixelError, display_name
from depixel.image import frame_count, load_frames
from depixel.limits import PEAK_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES
from depixel.params import Params
from depixel.prepare import PreparedImage
from depixel.svg import DEFAULT_PRECISION, DEFAULT_SIMPLIFY

from .options import error_message

#: File extensions taken from folders and globs (explicitly named files are always tried).
IMAGE_SUFFIXES = frozenset({".png", ".gif", ".bmp", ".webp", ".tga", ".tif", ".tiff", ".ppm", ".pgm",
                            ".pbm", ".pcx", ".ico", ".jpg", ".jpeg", ".qoi"})


@dataclass(frozen=True)
class Options:
    """How to convert each file (the same for every job of a batch)."""

    params: Params
    fmt: str  # svg, png or pdf
    stage: str
    scale: float
    frames: str | int  # "first", "all" or a frame index
    background: tuple[int, int, int] | None
    max_pixels: int | None
    force: bool  # reconvert outputs that are up to date
    shading: str = "smooth"  # PNG: the paper's smooth renderer, or "flat" (the SVG rasterized)
    precision: int = DEFAULT_PRECISION  # decimals of SVG coordinates
    layout: str = "stacked"  # SVG: shapes stacked (each continues under those above) or cut out
    simplify: float = DEFAULT_SIMPLIFY  # SVG: tolerance of the curve simplification, pixels (0: exact)
    width: int | None = None  # output width in pixels (instead of scale)
    height: int | None = None
    max_output_pixels: int | None = None
    pixel_size: str | tuple[int, int] = "auto"  # input preparation (depixel/prepare.py)
    denoise: bool | None = None
    transparent: str | tuple[int, int, int] | None = None


@dataclass(frozen=True)
class Job:
    source: Path
    output: Path  # with frames="all", the name the frame names derive from
    options: Options
    frames: int = 1  # frames of the input, known when frames="all"


#: Outcome states: converted/up to date/failed are in ``written``/``up_to_date``/``error``.
DONE, INTERRUPTED, CANCELLED = "done", "interrupted", "cancelled"


@dataclass
class Outcome:
    source: Path
    output: Path | None = None  # the planned output (the base of the frame names)
    written: list[Path] = field(default_factory=list)
    up_to_date: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    prepared: list[dict] = field(default_factory=list)  # what preparing each frame found, when anything
    error: str | None = None
    traceback: str | None = None
    state: str = DONE  # or INTERRUPTED (running when stopped) or CANCELLED (never started)


def frame_targets(job: Job) -> list[tuple[int, Path]]:
    """(frame index, output path) of every output of a job."""
    opt = job.options
    if opt.frames == "all":
        return list(enumerate(api.frame_outputs(job.output, job.frames)))
    return [(0 if opt.frames == "first" else int(opt.frames), job.output)]


def run_job(job: Job) -> Outcome:
    """Convert one file (every frame of it with ``frames="all"``, each decoded once); outputs
    that are newer than the input and carry the same options stamp are left alone unless
    ``force``. Never raises."""
    out = Outcome(job.source, job.output)
    opt = job.options
    try:
        if opt.frames == "all" and job.frames == 0:  # not counted when planned (a single -o)
            job = Job(job.source, job.output, opt, frame_count(job.source))
        todo = _outputs_to_make(job, out)
        if todo:
            frames = load_frames(job.source, opt.max_pixels) if opt.frames == "all" else \
                [(frame, api.load(job.source, frame=frame, max_pixels=opt.max_pixels)) for frame in todo]
            for frame, rgba in frames:
                if frame in todo:
                    target, options = todo[frame]
                    api.write_converted(rgba, job.source, target, options, max_pixels=opt.max_pixels,
                                        max_output_pixels=opt.max_output_pixels,
                                        on_prepared=partial(record_prepared, out, source=job.source, target=target))
                    out.written.append(target)
        if opt.frames == "first" and out.written and (n := frame_count(job.source)) > 1:
            out.notes.append(f"{display_name(job.source)}: has {n} frames, converted the first "
                             "(--frames all converts each)")
    except DepixelError as exc:
        out.error, out.traceback = error_message(exc), traceback.format_exc()
    except MemoryError:
        out.error = f"{display_name(job.source)}: not enough memory to convert it"
    except OSError as exc:  # e.g. a name too long to look up
        out.error = f"{display_name(job.output)}: cannot write ({exc.strerror or exc})"
        out.traceback = traceback.format_exc()
    except Exception as exc:  # a bug: still one line, the traceback with --debug
        out.error = f"{display_name(job.source)}: internal error ({type(exc).__name__}: {exc})"
        out.traceback = traceback.format_exc()
    return out


def _outputs_to_make(job: Job, out: Outcome) -> dict[int, tuple[Path, dict]]:
    """{frame: (output, file options)} of the outputs not up to date; the others are added
    to ``out.up_to_date``."""
    opt = job.options
    todo = {}
    for frame, target in frame_targets(job):
        options = api.file_options(target, opt.params, fmt=opt.fmt, stage=opt.stage, scale=opt.scale,
                                   frame=frame, background=opt.background, shading=opt.shading,
                                   precision=opt.precision, width=opt.width, height=opt.height,
                                   layout=opt.layout, simplify=opt.simplify, pixel_size=opt.pixel_size,
                                   denoise=opt.denoise, transparent=opt.transparent)
        if not opt.force and api.is_up_to_date(job.source, target, options):
            out.up_to_date.append(target)
        else:
            todo[frame] = (target, options)
    return todo


def already_done(job: Job) -> Outcome | None:
    """The outcome of a job whose outputs are all up to date (checked here, without a
    worker: a rerun of an unchanged batch starts no process), else None."""
    if job.options.force or (job.options.frames == "all" and job.frames == 0):
        return None
    out = Outcome(job.source, job.output)
    try:
        return None if _outputs_to_make(job, out) else out
    except (DepixelError, OSError):
        return None  # the job itself will report it


def _abandoned(job: Job, begun: int) -> Outcome:
    """The outcome of a job stopped while running: the outputs it completed (renamed into
    place, with their stamp, since ``begun``) are listed as written; with all of them done,
    the job is simply done."""
    out = Outcome(job.source, job.output, state=INTERRUPTED)
    if job.options.frames == "all" and job.frames == 0:
        return out
    for _, target in frame_targets(job):
        try:
            if target.stat().st_mtime_ns >= begun and stamps.read(target) is not None:
                out.written.append(target)
        except OSError:
            pass
    if len(out.written) == len(frame_targets(job)):
        out.state = DONE
    return out


def remove_temporary_files(job: Job) -> None:
    """Remove what an abandoned job may have left: the atomic writer's temporary files of
    each of its outputs (``.NAME.XXXXXXXX.tmp`` beside it)."""
    for _, target in frame_targets(job) if job.options.frames != "all" or job.frames else [(0, job.output)]:
        try:
            real = Path(os.path.realpath(target))
            for leftover in real.parent.glob(glob.escape(f".{real.name[:64]}.") + "*.tmp"):
                leftover.unlink(missing_ok=True)
        except (OSError, ValueError):
            pass


def record_prepared(out: Outcome, prepared: PreparedImage, source: Path | str, target: Path | str) -> None:
    """Note what preparing a frame found (a one-line note and a --json entry), if anything."""
    line = prepared.describe(display_name(source))
    if line is not None:
        if line not in out.notes:  # frames of an animation usually say the same: once
            out.notes.append(line)
        out.prepared.append({"input": str(source), "output": str(target), **prepared.summary()})


# --- finding inputs and naming outputs --------------------------------------------------------

def expand_inputs(args: list[str], recursive: bool,
                  exclude: Path | None = None) -> tuple[list[tuple[Path, Path]], list[tuple[str, str]]]:
    """Files to convert as (path, path relative to its folder or glob base), and the
    arguments that gave none as (argument, message).

    A folder contributes the images directly in it (all its subfolders with ``recursive``),
    a glob its matches; hidden files and anything under ``exclude`` (the output folder) are
    left out. A file named twice is converted once.
    """
    found: list[tuple[Path, Path]] = []
    problems: list[tuple[str, str]] = []
    seen: set[Path] = set()

    def add(path: Path, rel: Path) -> None:
        key = path.resolve()
        if key not in seen:
            seen.add(key)
            found.append((path, rel))

    def wanted(path: Path, base: Path) -> bool:
        rel = path.relative_to(base)
        hidden = any(part.startswith(".") for part in rel.parts)
        # the output folder, when it lies inside an input folder, is not an input
        excluded = exclude is not None and exclude.resolve() in path.resolve().parents and \
            exclude.resolve() != base.resolve()
        return path.is_file() and path.suffix.lower() in IMAGE_SUFFIXES and not hidden and not excluded

    for arg in args:
        path = Path(arg)
        if path.is_dir():
            files = sorted(f for f in path.glob("**/*" if recursive else "*") if wanted(f, path))
            if not files:
                hint = "" if recursive else " (-r looks in subfolders)"
                problems.append((arg, f"{display_name(arg)}: no images in this folder{hint}"))
            for f in files:
                add(f, f.relative_to(path))
        elif glob.has_magic(arg) and not path.exists():
            base = _glob_base(arg)
            matches = sorted(Path(m) for m in glob.glob(arg, recursive=True))
            files = [m for m in matches if wanted(m, base)]
            if not files:
                problems.append((arg, f"{display_name(arg)}: no image matches"))
            for f in files:
                add(f, f.relative_to(base))
        else:
            add(path, Path(path.name))
    return found, problems


def _glob_base(pattern: str) -> Path:
    """The folder part of a glob before its first wildcard ("icons/**/*.png" → icons)."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts[:-1]:
        if glob.has_magic(part):
            break
        fixed.append(part)
    return Path(*fixed) if fixed else Path(".")


def plan(found: list[tuple[Path, Path]], out_dir: Path, options: Options) -> tuple[list[Job], list[Outcome]]:
    """One job per input, its output under ``out_dir`` at the same relative place.

    With ``frames="all"`` the frames of each input are counted here, so the names compared
    are the real ones (an animation gives ``name-000.svg``, … and a still image
    ``name.svg``). Inputs whose outputs would be another input or another input's output
    fail here; the first input (in the order given) keeps the name.
    """
    inputs = {p.resolve() for p, _ in found}
    owner: dict[Path, Path] = {}
    jobs, failed = [], []
    for path, rel in found:
        output = out_dir / rel.with_suffix("." + options.fmt)
        n_frames = 1
        if options.frames == "all":
            try:
                n_frames = frame_count(path)
            except DepixelError as exc:
                failed.append(Outcome(path, output, error=error_message(exc)))
                continue
        job = Job(path, output, options, n_frames)
        keys = [target.resolve() for _, target in frame_targets(job)]
        clash = next((k for k in keys if k in inputs or k in owner), None)
        if clash is not None:
            shown = display_name(out_dir / clash.relative_to(out_dir.resolve())) if clash.is_relative_to(
                out_dir.resolve()) else display_name(clash)
            reason = "would overwrite an input" if clash in inputs else \
                f"is already the output of {display_name(owner[clash])}"
            failed.append(Outcome(path, output, error=f"{display_name(path)}: output {shown} {reason}"))
            continue
        owner.update((k, path) for k in keys)
        jobs.append(job)
    return jobs, failed


def make_folders(jobs: list[Job]) -> tuple[list[Job], list[Outcome]]:
    """Create the output folders; jobs whose folder cannot be made fail."""
    ready, failed = [], []
    for job in jobs:
        try:
            job.output.parent.mkdir(parents=True, exist_ok=True)
            ready.append(job)
        except OSError as exc:
            failed.append(Outcome(job.source, job.output,
                                  error=f"{display_name(job.output.parent)}: cannot create folder "
                                        f"({exc.strerror or exc})"))
    return ready, failed


# --- running ------------------------------------------------------------------------------------

def run(jobs: list[Job], workers: int, report, signals, progress: Progress | None = None) -> list[Outcome]:
    """Run the jobs, ``workers`` processes at a time (this process for one), until done or
    stopped by ``signals``; ``report(outcome)`` is called as each one ends. Returns the
    outcomes in the order of ``jobs``; after a stop, the unfinished ones are INTERRUPTED or
    CANCELLED."""
    from .pool import Finished, Interrupted, run_jobs  # noqa: PLC0415

    outcomes: dict[int, Outcome] = {}
    begun = time.time_ns()

    def finished(done: Finished) -> None:
        job = jobs[done.index]
        if done.interrupted:
            outcome = _abandoned(job, begun)
        elif done.cancelled:
            outcome = Outcome(job.source, job.output, state=CANCELLED)
        elif done.died:
            outcome = Outcome(job.source, job.output,
                              error=f"{display_name(job.source)}: worker process died ({done.died}), also when retried")
        else:
            outcome = done.result
            if done.retried:
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
    if workers <= 1 or len(todo) <= 1:
        for index in todo:
            job = jobs[index]
            if signals.signum is not None:
                finished(Finished(index, cancelled=True))
                continue
            started(index)
            signals.raising = True  # a signal now abandons the file at once (the writer removes its temporary file)
            try:
                result = run_job(job)
            except Interrupted:
                result = None
            finally:
                signals.raising = False
            if result is None:
                remove_temporary_files(job)
                finished(Finished(index, interrupted=True))
            else:
                finished(Finished(index, result))
    else:
        signals.raising = False

        def renumbered(done: Finished) -> None:  # run_jobs numbers the jobs of ``todo``
            finished(Finished(todo[done.index], done.result, done.died, done.retried, done.interrupted,
                              done.cancelled))

        run_jobs([jobs[i] for i in todo], workers, run_job, renumbered, signals, cleanup=remove_temporary_files,
                 started=lambda i: started(todo[i]))
    return [outcomes[i] for i in range(len(jobs))]


class Progress:
    """A tqdm bar on stderr for two or more files when stderr is a terminal, showing the file
    being converted; messages print above it. A terminal that reports no width (a pty
    under ``script``) gets an 80-column bar."""

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
    from PIL import Image  # noqa: PLC0415

    best, where = 0, None
    for job in jobs:
        try:
            with Image.open(job.source) as img:
                pixels = img.size[0] * img.size[1]
        except Exception:  # unreadable: the job reports it
            continue
        if pixels > best:
            best, where = pixels, job.source
    return best, where


def auto_jobs(jobs: list[Job], memory: int | None = None) -> tuple[int, str | None]:
    """``-j auto``: one worker per core, but no more than the available memory holds when
    each converts the largest image (PEAK_BYTES_PER_PIXEL per pixel, measured). Returns the
    count and, when memory is what limits it, a note saying so."""
    count = max(1, min(cores(), len(jobs)))
    if count == 1:
        return 1, None
    memory = available_memory() if memory is None else memory
    pixels, where = largest_image(jobs)
    if memory is None or where is None:
        return count, None
    need = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * pixels
    fits = max(1, memory // need)
    if fits >= count:
        return count, None
    return fits, (f"-j auto: {fits} worker{'s' if fits > 1 else ''}, not {count}: converting "
                  f"{display_name(where)} ({pixels} pixels) takes about {need / 2**30:.1f} GiB and "
                  f"{memory / 2**30:.1f} GiB is available")


def summary(outcomes: list[Outcome], seconds: float, interrupted: bool = False) -> dict:
    """The ``--json`` report of a batch: counts, failures, and every output with its status
    (converted, up-to-date, failed, interrupted or cancelled)."""
    failed = [o for o in outcomes if o.error]
    outputs: list[dict[str, str | None]] = []
    for o in outcomes:
        outputs += [{"output": str(p), "input": str(o.source), "status": "converted"} for p in o.written]
        outputs += [{"output": str(p), "input": str(o.source), "status": "up-to-date"} for p in o.up_to_date]
        if o.error or o.state != DONE:
            status = "failed" if o.error else o.state
            outputs.append({"output": None if o.output is None else str(o.output), "input": str(o.source),
                            "status": status})
    return {
        "files": len(outcomes),
        "ok": sum(1 for o in outcomes if not o.error and o.written),
        "skipped": sum(1 for o in outcomes if not o.error and o.up_to_date and not o.written),
        "failed": [{"input": str(o.source), "error": o.error} for o in failed],
        "interrupted": interrupted,
        "not_done": sum(1 for o in outcomes if o.state != DONE),
        "outputs": outputs,
        "prepared": [entry for o in outcomes for entry in o.prepared],
        "seconds": round(seconds, 3),
    }
