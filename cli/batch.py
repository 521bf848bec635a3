"""Converting many files: finding the inputs, naming the outputs, running a process pool.

Every file is one :class:`Job`, converted by :func:`run_job` in a worker process (or in this
process for ``-j 1`` or a single file). A job never raises: it returns an :class:`Outcome`
with the files written, those skipped and, on failure, a one-line reason, so one bad file
never stops the batch. Each file's output depends only on the file and the options, so
the results are the same whatever ``-j`` is.
"""
from __future__ import annotations

import glob
import os
import sys
import traceback
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from depixel import api
from depixel.errors import DepixelError, display_name
from depixel.image import frame_count
from depixel.params import Params
from depixel.prepare import PreparedImage

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
    force: bool  # replace existing outputs
    shading: str = "smooth"  # PNG: the paper's smooth renderer, or "flat" (the SVG rasterized)
    precision: int = 3  # decimals of SVG coordinates
    pixel_size: str | tuple[int, int] = "auto"  # input preparation (depixel/prepare.py)
    denoise: bool | None = None
    transparent: str | tuple[int, int, int] | None = None


@dataclass(frozen=True)
class Job:
    source: Path
    output: Path
    options: Options


@dataclass
class Outcome:
    source: Path
    written: list[Path] = field(default_factory=list)
    skipped: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    prepared: list[dict] = field(default_factory=list)  # what preparing each frame found, when anything
    error: str | None = None
    traceback: str | None = None


def run_job(job: Job) -> Outcome:
    """Convert one file (every frame of it with ``frames="all"``); never raises."""
    out = Outcome(job.source)
    opt = job.options
    try:
        if opt.frames == "all":
            n = frame_count(job.source)
            targets = list(enumerate(api.frame_outputs(job.output, n)))
        else:
            targets = [(0 if opt.frames == "first" else int(opt.frames), job.output)]
        for frame, target in targets:
            if target.exists() and not opt.force:
                out.skipped.append(target)
                continue
            api.convert_file(job.source, target, opt.params, fmt=opt.fmt, stage=opt.stage, scale=opt.scale,
                             frame=frame, background=opt.background, shading=opt.shading,
                             max_pixels=opt.max_pixels, precision=opt.precision, pixel_size=opt.pixel_size,
                             denoise=opt.denoise, transparent=opt.transparent,
                             on_prepared=partial(record_prepared, out, source=job.source, target=target))
            out.written.append(target)
        if opt.frames == "first" and out.written and (n := frame_count(job.source)) > 1:
            out.notes.append(f"{display_name(job.source)}: has {n} frames, converted the first (--frames all converts each)")
    except DepixelError as exc:
        out.error, out.traceback = error_message(exc), traceback.format_exc()
    except Exception as exc:  # a bug: still one line, the traceback with --debug
        out.error = f"{display_name(job.source)}: internal error ({type(exc).__name__}: {exc})"
        out.traceback = traceback.format_exc()
    return out


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

    Inputs whose output would be another input or another input's output fail here.
    """
    inputs = {p.resolve() for p, _ in found}
    owner: dict[Path, Path] = {}
    jobs, failed = [], []
    for path, rel in found:
        output = out_dir / rel.with_suffix("." + options.fmt)
        key = output.resolve()
        if key in inputs:
            failed.append(Outcome(path, error=f"{display_name(path)}: output {display_name(output)} "
                                              "would overwrite an input"))
        elif key in owner:
            failed.append(Outcome(path, error=f"{display_name(path)}: output {display_name(output)} is "
                                              f"already the output of {display_name(owner[key])}"))
        else:
            owner[key] = path
            jobs.append(Job(path, output, options))
    return jobs, failed


def make_folders(jobs: list[Job]) -> tuple[list[Job], list[Outcome]]:
    """Create the output folders; jobs whose folder cannot be made fail."""
    ready, failed = [], []
    for job in jobs:
        try:
            job.output.parent.mkdir(parents=True, exist_ok=True)
            ready.append(job)
        except OSError as exc:
            failed.append(Outcome(job.source, error=f"{display_name(job.output.parent)}: cannot create folder ({exc.strerror or exc})"))
    return ready, failed


# --- running ------------------------------------------------------------------------------------

def run(jobs: list[Job], workers: int, report) -> list[Outcome]:
    """Run the jobs, ``workers`` at a time; ``report(outcome)`` is called as each one ends.

    Returns the outcomes in the order of ``jobs``.
    """
    outcomes: dict[int, Outcome] = {}
    if workers <= 1 or len(jobs) <= 1:
        for i, job in enumerate(jobs):
            outcomes[i] = run_job(job)
            report(outcomes[i])
        return [outcomes[i] for i in range(len(jobs))]

    from concurrent.futures import ProcessPoolExecutor, as_completed  # noqa: PLC0415
    from concurrent.futures.process import BrokenProcessPool  # noqa: PLC0415

    with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
        futures = {pool.submit(run_job, job): i for i, job in enumerate(jobs)}
        try:
            for future in as_completed(futures):
                i = futures[future]
                try:
                    outcomes[i] = future.result()
                except BrokenProcessPool:
                    outcomes[i] = Outcome(jobs[i].source, error=f"{display_name(jobs[i].source)}: worker process died")
                report(outcomes[i])
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return [outcomes[i] for i in range(len(jobs))]


class Progress:
    """A tqdm bar on stderr for two or more files when stderr is a terminal; messages above it."""

    def __init__(self, total: int) -> None:
        self.bar = None
        if total >= 2 and sys.stderr.isatty():
            from tqdm import tqdm  # noqa: PLC0415

            self.bar = tqdm(total=total, unit="file", file=sys.stderr, dynamic_ncols=True, leave=False)

    def message(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(f"depixel: {text}", file=sys.stderr)
        else:
            print(f"depixel: {text}", file=sys.stderr, flush=True)

    def step(self) -> None:
        if self.bar is not None:
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def default_jobs() -> int:
    return os.cpu_count() or 1


def summary(outcomes: list[Outcome], seconds: float) -> dict:
    """The ``--json`` report of a batch."""
    failed = [o for o in outcomes if o.error]
    return {
        "files": len(outcomes),
        "ok": sum(1 for o in outcomes if not o.error and o.written),
        "skipped": sum(1 for o in outcomes if not o.error and o.skipped and not o.written),
        "failed": [{"input": str(o.source), "error": o.error} for o in failed],
        "outputs": [str(p) for o in outcomes for p in o.written],
        "prepared": [entry for o in outcomes for entry in o.prepared],
        "seconds": round(seconds, 3),
    }
