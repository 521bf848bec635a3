"""Converting many files: the jobs, what one job does, and the report of a batch.

Every file is one :class:`Job`, converted by :func:`run_job` in a worker process
(:mod:`depixel_cli.pool`), in this process for ``-j 1``, or as a Dask task
(:mod:`depixel_cli.dask.batch`). A job never raises: it returns an :class:`Outcome` with
the files written, those already up to date, those kept (not depixel's, or edited since
depixel wrote them: never overwritten without ``--force``) and, on failure, a one-line
reason, so one bad file never stops the batch. Each file's output depends only on the file
and the options, so the results are the same whatever runs them.

Finding the inputs and naming the outputs is :mod:`depixel_cli.convert.inputs`; running the
jobs (how many workers, the run loop, the progress bar) is :mod:`depixel_cli.convert.run`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from depixel.errors import DepixelError, InputError, OutputError, display_name
from depixel.files import convert as files
from depixel.files import output as written
from depixel.files import stamp as stamps
from depixel.options import ConvertOptions
from depixel.prepare.image import ImageSource, frame_count
from depixel.prepare.inputs import PreparedImage

from ..options import error_message
from .tags import output_tags, tagged


@dataclass(frozen=True, eq=False)  # never compared: eq would cost ~1 ms a start to create
class Options:
    """How to convert each file (the same for every job of a batch): the library's options
    and what the batch adds."""

    convert: ConvertOptions  # what each output is made with (the stamp digests it)
    formats: tuple[str, ...]  # svg, png or pdf: one output of each per input (and frame)
    frames: str | int  # "first", "all" or a frame index
    force: bool  # reconvert outputs that are up to date, and overwrite those that are not depixel's or edited
    tag: str | None = None  # an Aseprite tag: its frames ("all") or the first it plays; with animate, the one played
    #: an output named by ``-o``: converted even when up to date; one that is not depixel's
    #: (or was edited) is an error without ``force``, not a note
    explicit: bool = False
    #: the run's token, in the name of every temporary file its jobs write, wherever they run
    #: (depixel.files.output): cleanup removes those names and no others
    token: str = field(default_factory=written.run_token)


@dataclass(frozen=True, eq=False)
class Job:
    source: Path
    output: Path  # its first output; for -o FILE with frames="all", the name the frame names derive from
    options: Options
    frames: int = 1  # frames of the input, known when frames="all"
    #: (frame, format, path, part) of every output, as named when planned (--out-dir, beside
    #: the input, --name; part: a sheet's sprite or an animation's tag, or None); empty for
    #: -o FILE, whose outputs derive from ``output``
    targets: tuple[tuple[int, str, Path, str | None], ...] = ()


#: Outcome states: converted/up to date/failed are in ``written``/``up_to_date``/``error``.
DONE, INTERRUPTED, CANCELLED = "done", "interrupted", "cancelled"


@dataclass(eq=False)
class Outcome:
    source: Path
    output: Path | None = None  # the planned output (the base of the frame names)
    written: list[Path] = field(default_factory=list)
    up_to_date: list[Path] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)  # existing outputs depixel did not write (no stamp)
    old: list[Path] = field(default_factory=list)  # those of ``kept`` stamped before edits could be told
    edited: list[Path] = field(default_factory=list)  # existing outputs changed since depixel wrote them
    planned: list[Path] = field(default_factory=list)  # --dry-run: the outputs that would be written
    seconds: dict[Path, float] = field(default_factory=dict)  # each written output's share of the work
    sizes: dict[Path, int] = field(default_factory=dict)  # bytes of each written output
    notes: list[str] = field(default_factory=list)
    prepared: list[dict] = field(default_factory=list)  # what preparing each frame found, when anything
    changed: str | None = None  # the input changed while converted: the one-line report
    error: str | None = None
    traceback: str | None = None
    state: str = DONE  # or INTERRUPTED (running when stopped) or CANCELLED (never started)


def current_traceback() -> str:
    """``traceback.format_exc()``, the module imported only when a job fails (~1 ms a start)."""
    import traceback  # noqa: PLC0415

    return traceback.format_exc()


def frame_targets(job: Job) -> list[tuple[int, str, Path, str | None]]:
    """(frame index, format, output path, sprite or tag) of every output of a job."""
    if job.targets:
        return list(job.targets)
    opt, fmt = job.options, job.options.formats[0]
    if opt.frames == "all":
        return [(frame, fmt, path, None) for frame, path in enumerate(files.frame_outputs(job.output, job.frames))]
    return [(0 if opt.frames == "first" else int(opt.frames), fmt, job.output, None)]


def chosen_frames(source: ImageSource, options: Options, name: str) -> list[int]:
    """The frames of ``source`` to convert: ``--frames first`` the first, ``N`` frame N,
    ``all`` every one (counted from the header, at most ``max_frames``); with ``--tag``, the
    frames of that Aseprite tag (``all``: each once, in the file's order; ``first``: the
    first it plays; an animation is one output: ``[0]``)."""
    if options.tag is not None and not options.convert.output.animate:
        from depixel.prepare.aseprite import is_aseprite, parse_aseprite, tag_frames  # noqa: PLC0415 (~15 ms)
        from depixel.prepare.image import read_source  # noqa: PLC0415

        data = read_source(source)
        if not is_aseprite(data):
            raise InputError(f"{name}: not an Aseprite file, so it has no tags for --tag")
        ase = parse_aseprite(data, name, None)
        played = tag_frames(ase, options.tag, name=name)  # (--frames all then checks every frame's limits)
        return sorted(set(played)) if options.frames == "all" else played[:1]
    if options.frames == "all":
        return list(range(frame_count(source, options.convert.limits.max_frames, name=name)))
    return [0 if options.frames == "first" else int(options.frames)]


def numbered(output: Path, frames: list[int]) -> list[Path]:
    """The outputs of ``frames`` named after ``output``: ``name-004.svg``, … (the frame
    numbers, at least 3 digits: :func:`depixel.files.convert.frame_outputs` for every frame);
    one frame keeps the plain name."""
    if len(frames) == 1:
        return [output]
    digits = max(3, len(str(max(frames))))
    return [output.with_name(f"{output.stem}-{frame:0{digits}d}{output.suffix}") for frame in frames]


def listed(job: Job) -> Job:
    """A ``-o FILE`` job with its frames known: counted (``--frames all``) or the tag's, which
    are named by :func:`numbered` (its outputs then planned like a batch's); with ``animate``,
    an output per tag (:func:`~depixel_cli.convert.tags.output_tags`)."""
    opt = job.options
    if job.targets:
        return job
    if opt.convert.output.animate:
        return replace(job, targets=output_tags(job.source, job.output, opt.tag, opt.formats[0], True,
                                                display_name(job.source)))
    if opt.tag is not None:
        frames = chosen_frames(job.source, opt, display_name(job.source))
        fmt = opt.formats[0]
        return replace(job, frames=len(frames), targets=tuple((frame, fmt, path, None) for frame, path in
                                                              zip(frames, numbered(job.output, frames))))
    if opt.frames == "all" and job.frames == 0:  # not counted when planned (a single -o)
        return replace(job, frames=frame_count(job.source, opt.convert.limits.max_frames))
    return job


def run_job(job: Job) -> Outcome:
    """Convert one file (every frame of it with ``frames="all"``, each decoded once, their
    outputs written all or none); outputs made from this input with the same options are
    left alone, and existing outputs that depixel did not write or that were edited are
    kept, unless ``force``. Never raises."""
    out = Outcome(job.source, job.output)
    opt = job.options
    try:
        job = listed(job)
        todo = _outputs_to_make(job, out)
        if todo:
            source = files.InputFile.read(job.source)
            result = files.convert_frames(
                source, todo, opt.convert, every_frame=opt.frames == "all", token=opt.token, overwrite=opt.force,
                on_prepared=lambda frame, target, prepared:
                    record_prepared(out, prepared, source=job.source, target=target))
            out.written, out.seconds, out.sizes = result.written, result.seconds, result.sizes
            out.notes.extend(note for note in result.notes if note not in out.notes)
            for target, now in result.kept.items():
                keep(out, target, now)
            if result.changed:
                out.changed = f"{display_name(job.source)}: {files.CHANGED}"
            if out.written:
                out.notes += frames_note(source.data, display_name(job.source), opt)
        if opt.explicit and (out.kept or out.edited):
            out.error = kept_lines(out)[0][1]
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


#: Why an existing output is kept, by what it is (a stamp.UNSTAMPED, OLD or EDITED output).
KEPT_BECAUSE = {"kept": "not written by depixel (it has no depixel stamp)",
                "old": "written by a depixel too old to tell whether it was edited since (its stamp has no "
                       "body digest)",
                "edited": "edited since depixel wrote it (it no longer matches its stamp)"}


def kept_line(kind: str, target: Path) -> str:
    """Why the output ``target`` was kept (``kind``: kept, old or edited) and what overwrites it."""
    return f"{display_name(target)}: {KEPT_BECAUSE[kind]}; kept, --force overwrites it"


def kept_lines(out: Outcome) -> list[tuple[str, str]]:
    """(kind, :func:`kept_line`) for every output of ``out`` that was kept (an old stamp's
    kind is kept, its line says why)."""
    return [(kind, kept_line("old" if target in out.old else kind, target))
            for kind, targets in (("kept", out.kept), ("edited", out.edited)) for target in targets]


def keep(out: Outcome, target: Path, now: str) -> None:
    """Record the existing output ``target`` as kept, by what it is (a stamp.KEPT status)."""
    if now == stamps.EDITED:
        out.edited.append(target)
    else:
        out.kept.append(target)
        if now == stamps.OLD:
            out.old.append(target)


def frames_note(data: bytes, name: str, options: Options) -> list[str]:
    """The note on the frames an output holds, when it is not what the input suggests: the
    first of an animation (without ``--frames``), the one frame of a still (``--animate``)."""
    if options.frames != "first" or options.tag is not None:  # (a tag's frames are chosen)
        return []
    n = frame_count(data, name=name)
    if options.convert.output.animate:
        return [f"{name}: a still image, written as its one frame (--animate)"] if n == 1 else []
    return [f"{name}: has {n} frames, converted the first (--frames all converts each, --animate plays them "
            "in one file)"] if n > 1 else []


def _outputs_to_make(job: Job, out: Outcome) -> list[files.Target]:
    """The outputs to convert; the others are added to ``out.up_to_date`` (made from this
    input with these options), ``out.kept`` (not depixel's, or stamped before edits could be
    told) or ``out.edited`` (changed since depixel wrote them)."""
    opt = job.options
    todo: list[files.Target] = []
    sheet = opt.convert.output.is_sheet
    for frame, fmt, path, part in frame_targets(job):
        target = files.file_target(path, opt.convert if sheet else tagged(opt.convert, part), fmt=fmt, frame=frame,
                                   sprite=part if sheet else None)
        if _same_file(path, job.source):  # said as the writer says it, before any work
            raise OutputError(f"{display_name(path)}: is the input file; refusing to overwrite it")
        now = stamps.NEW if opt.force else files.output_status(job.source, target)
        if now == stamps.CURRENT and not opt.explicit:
            out.up_to_date.append(path)
        elif now in stamps.KEPT:
            keep(out, path, now)
        else:
            todo.append(target)
    return todo


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def already_done(job: Job) -> Outcome | None:
    """The outcome of a job whose outputs are all up to date (checked here, without a
    worker: a rerun of an unchanged batch starts no process), else None."""
    if job.options.force or job.options.explicit or (job.options.frames == "all" and job.frames == 0):
        return None
    if not all(os.path.exists(target) for _, _, target, _ in frame_targets(job)):
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
    out.written = [target for _, _, target, _ in frame_targets(job) if written_since(target, begun)]
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
    targets = frame_targets(job) if job.options.frames != "all" or job.frames else [(0, "", job.output, None)]
    for _, _, target, _ in targets:
        written.remove_temporary(target, job.options.token)


def record_prepared(out: Outcome, prepared: PreparedImage, source: Path | str, target: Path | str) -> None:
    """Note what preparing a frame found (a one-line note and a --json entry), if anything."""
    line = prepared.describe(display_name(source), kept_hint=": --transparent-everywhere removes them too")
    if line is not None:
        if line not in out.notes:  # frames of an animation usually say the same: once
            out.notes.append(line)
        out.prepared.append({"input": str(source), "output": str(target), **prepared.summary()})



def category(outcome: Outcome) -> str:
    """What became of one input, as the summary counts it: failed, changed (during its
    conversion), edited, kept, converted (to convert, in a dry run), up to date; or its
    state when the batch was stopped (interrupted, cancelled)."""
    if outcome.error:
        return "failed"
    if outcome.state != DONE:
        return outcome.state
    for name, found in (("changed", outcome.changed), ("edited", outcome.edited), ("kept", outcome.kept),
                        ("converted", outcome.written or outcome.planned)):
        if found:
            return name
    return "up to date"


def summary(outcomes: list[Outcome], seconds: float, interrupted: bool = False, dry_run: bool = False) -> dict:
    """The ``--json`` report of a batch: counts, failures, and every output with its status
    (converted, up-to-date, kept, edited, changed, failed, interrupted or cancelled; in a dry
    run, to-convert), the written ones with their bytes and seconds."""
    failed = [o for o in outcomes if o.error]
    outputs: list[dict[str, object]] = []
    for o in outcomes:
        done = "changed" if o.changed else "converted"
        outputs += [{"output": str(p), "input": str(o.source), "status": done, "bytes": o.sizes.get(p),
                     "seconds": round(o.seconds.get(p, 0.0), 3), **({"reason": o.changed} if o.changed else {})}
                    for p in o.written]
        outputs += [{"output": str(p), "input": str(o.source), "status": "to-convert"} for p in o.planned]
        outputs += [{"output": str(p), "input": str(o.source), "status": "up-to-date"} for p in o.up_to_date]
        outputs += [{"output": str(p), "input": str(o.source), "status": kind,
                     "reason": KEPT_BECAUSE["old" if p in o.old else kind]}
                    for kind, targets in (("kept", o.kept), ("edited", o.edited)) for p in targets]
        if o.error or o.state != DONE:
            status = "failed" if o.error else o.state
            outputs.append({"output": None if o.output is None else str(o.output), "input": str(o.source),
                            "status": status})
    counts = [category(o) for o in outcomes]
    return {
        "files": len(outcomes),
        "ok": counts.count("converted"),
        "skipped": counts.count("up to date"),
        "kept": counts.count("kept"),
        "edited": counts.count("edited"),
        "changed": counts.count("changed"),
        "failed": [{"input": str(o.source), "error": o.error} for o in failed],
        "interrupted": interrupted,
        "not_done": sum(1 for o in outcomes if o.state != DONE),
        **({"dry_run": True} if dry_run else {}),
        "outputs": outputs,
        "prepared": [entry for o in outcomes for entry in o.prepared],
        "seconds": round(seconds, 3),
    }


def totals_line(outcomes: list[Outcome], seconds: float, interrupted: bool = False, dry_run: bool = False,
                extra: list[str] | None = None) -> str:
    """The summary line every batch ends with: ``N files: a converted, b up to date, c kept,
    d failed in S s``, with the edited, changed, abandoned and not started ones when there are,
    and ``extra`` parts (``--prune``'s ``N removed``) after the failed."""
    counts = [category(o) for o in outcomes]
    parts = [f"{counts.count('converted')} {'to convert' if dry_run else 'converted'}",
             f"{counts.count('up to date')} up to date", f"{counts.count('kept')} kept"]
    parts += [f"{counts.count(name)} {name}" for name in ("edited", "changed") if name in counts]
    parts.append(f"{counts.count('failed')} failed")
    parts += extra or []
    if interrupted or INTERRUPTED in counts or CANCELLED in counts:  # a --dask batch also stops without a signal
        parts.append(f"{counts.count(INTERRUPTED)} abandoned, {counts.count(CANCELLED)} not started"
                     + (" (interrupted)" if interrupted else ""))
    tail = " (dry run: nothing written)" if dry_run else ""
    files = "1 file" if len(outcomes) == 1 else f"{len(outcomes)} files"
    return f"{files}: {', '.join(parts)}{tail} in {seconds:.1f} s"
