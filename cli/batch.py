"""Converting many files: the jobs, what one job does, and the report of a batch.

Every file is one :class:`Job`, converted by :func:`run_job` in a worker process
(:mod:`depixel_cli.pool`), in this process for ``-j 1``, or as a Dask task
(:mod:`depixel_cli.dask_batch`). A job never raises: it returns an :class:`Outcome` with
the files written, those already up to date and, on failure, a one-line reason, so one bad
file never stops the batch. Each file's output depends only on the file and the options,
so the results are the same whatever runs them.

Finding the inputs and naming the outputs is :mod:`depixel_cli.batch_inputs`; running the
jobs (how many workers, the run loop, the progress bar) is :mod:`depixel_cli.batch_run`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from depixel import api
from depixel.errors import DepixelError, display_name
from depixel.files import convert as files
from depixel.files import output as written
from depixel.files import stamp as stamps
from depixel.params import Params
from depixel.prepare.image import frame_count, load_frames
from depixel.prepare.inputs import PreparedImage
from depixel.svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY

from .options import error_message


@dataclass(frozen=True, eq=False)  # never compared: eq would cost ~1 ms a start to create
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
    pixel_size: str | tuple[int, int] = "auto"  # input preparation (depixel/prepare/inputs.py)
    denoise: bool | None = None
    transparent: str | tuple[int, int, int] | None = None
    #: the run's token, in the name of every temporary file its jobs write, wherever they run
    #: (depixel.files.output): cleanup removes those names and no others
    token: str = field(default_factory=written.run_token)


@dataclass(frozen=True, eq=False)
class Job:
    source: Path
    output: Path  # with frames="all", the name the frame names derive from
    options: Options
    frames: int = 1  # frames of the input, known when frames="all"


#: Outcome states: converted/up to date/failed are in ``written``/``up_to_date``/``error``.
DONE, INTERRUPTED, CANCELLED = "done", "interrupted", "cancelled"


@dataclass(eq=False)
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


def current_traceback() -> str:
    """``traceback.format_exc()``, the module imported only when a job fails (~1 ms a start)."""
    import traceback  # noqa: PLC0415

    return traceback.format_exc()


def frame_targets(job: Job) -> list[tuple[int, Path]]:
    """(frame index, output path) of every output of a job."""
    opt = job.options
    if opt.frames == "all":
        return list(enumerate(files.frame_outputs(job.output, job.frames)))
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
                    files.write_converted(rgba, job.source, target, options, max_pixels=opt.max_pixels,
                                        max_output_pixels=opt.max_output_pixels, token=opt.token,
                                        on_prepared=partial(record_prepared, out, source=job.source, target=target))
                    out.written.append(target)
        if opt.frames == "first" and out.written and (n := frame_count(job.source)) > 1:
            out.notes.append(f"{display_name(job.source)}: has {n} frames, converted the first "
                             "(--frames all converts each)")
    except DepixelError as exc:
        out.error, out.traceback = error_message(exc), current_traceback()
    except MemoryError:
        out.error = f"{display_name(job.source)}: not enough memory to convert it"
    except OSError as exc:  # e.g. a name too long to look up
        out.error = f"{display_name(job.output)}: cannot write ({exc.strerror or exc})"
        out.traceback = current_traceback()
    except Exception as exc:  # a bug: still one line, the traceback with --debug
        out.error = f"{display_name(job.source)}: internal error ({type(exc).__name__}: {exc})"
        out.traceback = current_traceback()
    return out


def _outputs_to_make(job: Job, out: Outcome) -> dict[int, tuple[Path, dict]]:
    """{frame: (output, file options)} of the outputs not up to date; the others are added
    to ``out.up_to_date``."""
    opt = job.options
    todo = {}
    for frame, target in frame_targets(job):
        options = files.file_options(target, opt.params, fmt=opt.fmt, stage=opt.stage, scale=opt.scale,
                                   frame=frame, background=opt.background, shading=opt.shading,
                                   precision=opt.precision, width=opt.width, height=opt.height,
                                   layout=opt.layout, simplify=opt.simplify, pixel_size=opt.pixel_size,
                                   denoise=opt.denoise, transparent=opt.transparent)
        if not opt.force and files.is_up_to_date(job.source, target, options):
            out.up_to_date.append(target)
        else:
            todo[frame] = (target, options)
    return todo


def already_done(job: Job) -> Outcome | None:
    """The outcome of a job whose outputs are all up to date (checked here, without a
    worker: a rerun of an unchanged batch starts no process), else None."""
    if job.options.force or (job.options.frames == "all" and job.frames == 0):
        return None
    if not all(os.path.exists(target) for _, target in frame_targets(job)):
        return None  # not made yet (a first run): no options stamp to compute (~0.5 ms a file)
    out = Outcome(job.source, job.output)
    try:
        return None if _outputs_to_make(job, out) else out
    except (DepixelError, OSError):
        return None  # the job itself will report it


def written_since(target: Path, begun: int) -> bool:
    """Whether ``target`` was renamed into place, with its options stamp, at or after
    ``begun`` (``time.time_ns()``): an output this batch completed."""
    try:
        return target.stat().st_mtime_ns >= begun and stamps.read(target) is not None
    except OSError:
        return False


def abandoned(job: Job, begun: int) -> Outcome:
    """The outcome of a job stopped while running: the outputs it completed (renamed into
    place, with their stamp, since ``begun``) are listed as written; with all of them done,
    the job is simply done."""
    out = Outcome(job.source, job.output, state=INTERRUPTED)
    if job.options.frames == "all" and job.frames == 0:
        return out
    out.written = [target for _, target in frame_targets(job) if written_since(target, begun)]
    if len(out.written) == len(frame_targets(job)):
        out.state = DONE
    return out


def claim_outputs_of_the_dead(outcome: Outcome, begun: int) -> None:
    """A retried job's outcome: the outputs its retry found up to date but that were written
    since ``begun`` were completed by the worker that died (killed after the rename, before it
    reported), so this batch converted them: listed as written, not as skipped."""
    claimed = [target for target in outcome.up_to_date if written_since(target, begun)]
    outcome.up_to_date = [target for target in outcome.up_to_date if target not in claimed]
    outcome.written.extend(claimed)


def remove_temporary_files(job: Job) -> None:
    """Remove what an abandoned job may have left: the temporary files this run's processes
    made for each of its outputs (``.NAME.depixel-PID-TOKEN.tmp`` with this run's token,
    :mod:`depixel.files.output`), and no other file."""
    for _, target in frame_targets(job) if job.options.frames != "all" or job.frames else [(0, job.output)]:
        written.remove_temporary(target, job.options.token)


def record_prepared(out: Outcome, prepared: PreparedImage, source: Path | str, target: Path | str) -> None:
    """Note what preparing a frame found (a one-line note and a --json entry), if anything."""
    line = prepared.describe(display_name(source))
    if line is not None:
        if line not in out.notes:  # frames of an animation usually say the same: once
            out.notes.append(line)
        out.prepared.append({"input": str(source), "output": str(target), **prepared.summary()})



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
