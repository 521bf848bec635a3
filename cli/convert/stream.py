"""``depixel convert`` with ``-`` for stdin or stdout: converted in this process, all or none."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from depixel.errors import DepixelError, OutputError
from depixel.files import convert as files
from depixel.files import stamp as stamps
from depixel.prepare.animation import Animation, read_animation
from depixel.prepare.image import load_image, read_source

from ..options import error_message
from ..streams import write_stdout
from .batch import (
    Options,
    Outcome,
    chosen_frames,
    current_traceback,
    frames_note,
    keep,
    kept_lines,
    numbered,
    record_prepared,
)
from .sheets import converted
from .tags import output_tags, tagged


def convert_stream(source: str, output: str, options: Options) -> Outcome:
    """Convert stdin and/or to stdout (all in this process); never raises. Files written
    from stdin are stamped (without an input identity: never up to date) and, like any
    ``-o FILE``, overwrite only what depixel wrote unless ``--force``."""
    out = Outcome(Path(source))
    try:
        data = files.InputFile(None, read_source(sys.stdin.buffer)) if source == "-" else \
            files.InputFile.read(source)
        if output == "-":
            to_stdout(data, options, out)
        else:
            stream_to_files(data, Path(output), options, out)
        out.notes += frames_note(data.data, data.name, options)
    except DepixelError as exc:
        out.error, out.traceback = error_message(exc), current_traceback()
    return out


def to_stdout(source: files.InputFile, options: Options, out: Outcome) -> None:
    """``-o -``: one frame's SVG, PNG or PDF on stdout, unstamped."""
    frame = chosen_frames(source.data, options, source.name)[0]
    fmt, limits = options.formats[0], options.convert.limits
    image: np.ndarray | Animation
    if options.convert.output.animate:
        image = whole = read_animation(source.data, limits.max_pixels, max_frames=limits.max_frames, name=source.name)
        if whole.tags and options.tag is None:
            out.notes.append(f"{source.name}: has tags ({', '.join(repr(tag.name) for tag in whole.tags)}); -o - "
                             "plays every frame (--tag NAME plays one)")
    else:
        image = load_image(source.data, limits.max_pixels, frame, max_frames=limits.max_frames, name=source.name)
    blob = converted(image, source, fmt, options.convert, out)
    if fmt != "svg" and sys.stdout is not None and sys.stdout.isatty():
        raise OutputError(f"refusing to write binary {fmt.upper()} to a terminal")
    write_stdout(blob)


def stream_to_files(source: files.InputFile, output: Path, options: Options, out: Outcome) -> None:
    """stdin to ``-o FILE`` (every frame's file with ``--frames all``, every tag's with
    ``--animate``), all or none."""
    chosen = chosen_frames(source.data, options, source.name)
    frames = zip(chosen, numbered(output, chosen)) if options.frames == "all" else [(chosen[0], output)]
    fmt, animate = options.formats[0], options.convert.output.animate
    tags = output_tags(source.data, output, options.tag, fmt, animate, source.name) if animate else ()
    targets = [files.file_target(path, tagged(options.convert, tag), fmt=fmt) for _, _, path, tag in tags] or \
        [files.file_target(path, options.convert, fmt=fmt, frame=frame) for frame, path in frames]
    for target in targets:
        now = stamps.NEW if options.force else stamps.replaceable(target.path)
        if now in stamps.KEPT:
            keep(out, target.path, now)
    if out.kept or out.edited:
        out.error = kept_lines(out)[0][1]
        return
    result = files.convert_frames(source, targets, options.convert, every_frame=options.frames == "all",
                                  token=options.token, overwrite=options.force,
                                  on_prepared=lambda frame, target, prepared:
                                      record_prepared(out, prepared, source.name, target))
    out.written, out.seconds, out.sizes = result.written, result.seconds, result.sizes
    out.notes.extend(result.notes)
    for path, now in result.kept.items():
        keep(out, path, now)
    if out.kept or out.edited:
        out.error = kept_lines(out)[0][1]
