"""File to file — an image file → an SVG, PNG or PDF file; an SVG file → PNG or PDF.

:func:`convert_file` and :func:`render_file` read one file and write another atomically
(:mod:`depixel.files.output`: never a partial file, never over their input). An input is read
once (:class:`InputFile`), with its identity at that moment; every output made from it carries
the stamp of the options and of that identity (:mod:`depixel.files.stamp`), which
:func:`output_status` compares; a :class:`Target` is one output to make, with the digest of its
options (:func:`options_digest`). :func:`convert_frames` writes the outputs of several frames of
one input, all or none; a sprite sheet's targets are its layered file or one sprite each
(``Target.sprite``).
"""
from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterable, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .. import validate
from ..api import FORMATS, check_animated_format, conversions, sheet_conversions
from ..colour import Colour, as_colour
from ..errors import InputError, OutputError, ParameterError, display_name
from ..frozen import stamp_fields
from ..limits import (
    DEFAULT_MAX_FRAMES,
    DEFAULT_MAX_OUTPUT_PIXELS,
    DEFAULT_MAX_PIXELS,
    check_rendered_frames,
    check_sprites,
)
from ..options import ConvertOptions
from ..params import Params
from ..prepare.animation import Animation, read_animation
from ..prepare.image import load_frames, load_image, read_source
from ..prepare.inputs import AUTO, PixelSize, PreparedImage, lossy_format
from ..svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY
from . import output as outputs
from . import stamp as stamps
from .output import write_atomic

if TYPE_CHECKING:
    from ..prepare.sheet_json import SheetJson


def output_format(path: str | os.PathLike, fmt: str | None = None) -> str:
    """The output format: the file extension (svg, png or pdf), or ``fmt`` for a name without
    one of those extensions (``-``, ``/dev/stdout``, ``out.tmp``). A known extension that
    disagrees with ``fmt`` is refused: SVG text in a file named ``.png`` helps nobody."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if fmt is not None:
        validate.choice("format", fmt, FORMATS)
        if suffix in FORMATS and suffix != fmt:
            raise OutputError(f"{display_name(path)}: the name says {suffix.upper()} but the format is "
                              f"{fmt.upper()}; name it .{fmt} (or drop the format)", parameter="fmt")
        return fmt
    if suffix not in FORMATS:
        raise OutputError(f"{display_name(path)}: cannot tell the output format from the extension "
                             f"(use .svg, .png or .pdf, or give the format)", parameter="fmt")
    return suffix


def frame_outputs(output: str | os.PathLike, n_frames: int) -> list[Path]:
    """Output names for every frame of an animation: ``name-000.svg``, ``name-001.svg``, …;
    a still image (one frame) keeps the plain name."""
    out = Path(output)
    if n_frames == 1:
        return [out]
    digits = max(3, len(str(n_frames - 1)))
    return [out.with_name(f"{out.stem}-{i:0{digits}d}{out.suffix}") for i in range(n_frames)]


def convert_file(source: str | os.PathLike, output: str | os.PathLike, params: Params = Params(), *,
                 fmt: str | None = None, stage: str = "optimized", scale: float = 1.0, frame: int = 0,
                 background: Colour | str | None = None, shading: str = "smooth",
                 max_pixels: int | None = DEFAULT_MAX_PIXELS, precision: int = DEFAULT_PRECISION,
                 width: int | None = None, height: int | None = None,
                 max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS, layout: str = "stacked",
                 simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                 transparent: Colour | str | None = None, transparent_everywhere: bool = False,
                 on_prepared: Callable[[PreparedImage], None] | None = None,
                 max_frames: int | None = DEFAULT_MAX_FRAMES, animate: bool = False, sheet: str | None = None,
                 sheet_json: SheetJson | str | None = None, tag: str | None = None) -> Path:
    """Convert one image file (one frame of it) to an SVG, PNG or PDF file; returns the output path.

    The output is written atomically and never replaces ``source``. SVG and PNG output have
    the smooth shading unless ``shading="flat"`` (:func:`depixel.api.convert_bytes`). The
    file carries the stamp of the options and
    of the input that made it (:mod:`depixel.files.stamp`), which :func:`output_status`
    compares. ``denoise=None`` denoises JPEG and lossy WebP files; ``on_prepared`` is called
    with what the preparation found (to report it). An input that changes while it is
    converted raises :class:`InputError` once the output is written (of the version read,
    stamped as such: never up to date). ``animate=True`` writes every frame of an animated
    GIF, APNG, WebP or Aseprite file into one animated SVG or PNG (docs/animation.md); a
    still image is its one frame; ``frame`` must then stay 0; ``tag`` plays one tag of an
    Aseprite file as Aseprite plays it (None: every frame). ``sheet``/``sheet_json`` write
    a sprite sheet with a layer per sprite (:func:`depixel.convert`); the stamp digests the
    JSON's content.
    """
    options = ConvertOptions.build(params, stage=stage, scale=scale, background=background, shading=shading,
                                   precision=precision, width=width, height=height, layout=layout, simplify=simplify,
                                   pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                                   transparent_everywhere=transparent_everywhere, max_pixels=max_pixels,
                                   max_output_pixels=max_output_pixels, max_frames=max_frames, animate=animate,
                                   sheet=sheet, sheet_json=sheet_json, tag=tag)
    target = file_target(output, options, fmt=fmt, frame=frame)
    result = convert_frames(InputFile.read(source), [target], options,
                            on_prepared=None if on_prepared is None else lambda frame, target, p: on_prepared(p))
    if result.changed:
        raise InputError(f"{display_name(source)}: {CHANGED}")
    return Path(output)


#: How an input that changed while it was converted is reported.
CHANGED = "changed during conversion (the output is of the version read; the next run converts it again)"


@dataclasses.dataclass(frozen=True, eq=False)
class InputFile:
    """An input read once for a conversion: its bytes and, for a file, its identity as read."""

    path: Path | None  # None: standard input
    data: bytes
    identity: stamps.Identity | None = None
    key: tuple[int, int, int, int] | None = None  # device, inode, size, mtime (ns) of the path before the read

    @classmethod
    def read(cls, path: str | os.PathLike) -> InputFile:
        """Read ``path`` (an :class:`InputError` naming it if it cannot be)."""
        try:
            before = os.stat(path)
        except (OSError, ValueError):
            before = None  # read_source says why
        data = read_source(path)
        if before is None:
            raise InputError(f"{display_name(path)}: cannot read (it vanished while read)")
        identity = stamps.Identity(before.st_size, before.st_mtime_ns, stamps.digest(data))
        return cls(Path(path), data, identity, _key(before))

    @property
    def name(self) -> str:
        return "<stdin>" if self.path is None else display_name(self.path)

    def changed(self) -> bool:
        """Whether the file at the path is no longer the one read (rewritten or replaced)."""
        if self.path is None:
            return False
        try:
            return _key(os.stat(self.path)) != self.key
        except (OSError, ValueError):
            return True


def _key(st: os.stat_result) -> tuple[int, int, int, int]:
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


@dataclasses.dataclass(eq=False)
class Written:
    """What :func:`convert_frames` did."""

    written: list[Path] = dataclasses.field(default_factory=list)
    #: outputs that became someone else's while they were converted: stamp.UNSTAMPED, EDITED or OLD
    kept: dict[Path, str] = dataclasses.field(default_factory=dict)
    seconds: dict[Path, float] = dataclasses.field(default_factory=dict)  # each output's share of the work
    sizes: dict[Path, int] = dataclasses.field(default_factory=dict)  # bytes of each output
    changed: bool = False  # the input changed during the conversion
    notes: list[str] = dataclasses.field(default_factory=list)  # what was found (a sheet's sprites), each once


class Target(NamedTuple):  # (a NamedTuple: ~0.05 ms to define at each start, a dataclass ~0.5 ms)
    """One output file to make: where, in which format, of which frame (and which sprite of
    a sheet), and the digest of the options that make it (:func:`options_digest`: its
    stamp's OPTIONS)."""

    path: Path
    fmt: str  # svg, png or pdf
    frame: int
    digest: str
    sprite: str | None = None  # one sprite of a sheet (its name); None: the whole image (a sheet: a layer each)
    tag: str | None = None  # the Aseprite tag an animation plays (its options' tag); None: every frame


def file_target(output: str | os.PathLike, options: ConvertOptions, *, fmt: str | None = None,
                frame: int = 0, sprite: str | None = None) -> Target:
    """The :class:`Target` ``output`` (its format from its extension, or ``fmt``) of frame
    ``frame`` (of its sprite ``sprite``, with a sheet's options) converted with ``options``."""
    fmt = output_format(output, fmt)
    frame = int(validate.number("frame", frame, low=0, integer=True))
    check_animated_format(fmt, options)
    if frame and options.output.animate:
        raise ParameterError(f"animate writes every frame into one file; frame={frame} picks one: give one of them",
                             parameter="frame")
    if sprite is not None and not options.output.is_sheet:
        raise ParameterError("a sprite's output needs the sheet's options (sheet or sheet_json)", parameter="sprite")
    return Target(Path(output), fmt, frame, options_digest(options, fmt, frame, sprite), sprite, options.output.tag)


def options_digest(options: ConvertOptions, fmt: str, frame: int, sprite: str | None = None) -> str:
    """The stamp's OPTIONS of an output (:func:`depixel.files.stamp.options_stamp`): depixel's
    version, the output's format, frame and sprite (when one), the paper's parameters and every
    field of the prepare and output options (:func:`depixel.frozen.stamp_fields`: a new field
    is digested unless its metadata says when to leave it out), less what this format does
    not use."""
    output = stamp_fields(options.output)
    if fmt == "pdf":
        output["shading"] = None  # a PDF has the flat bands
    elif fmt == "png" and options.output.shading == "smooth":  # the smooth renderer ignores the SVG's settings
        output.update(precision=None, layout=None, simplify=None)
    mine = {} if sprite is None else {"sprite": sprite}
    return stamps.options_stamp(fmt=fmt, frame=frame, params=dataclasses.asdict(options.params),
                                **output, **stamp_fields(options.prepare), **mine)


def convert_frames(source: InputFile, targets: Sequence[Target], options: ConvertOptions, *,
                   every_frame: bool = False, token: str | None = None, overwrite: bool = True,
                   on_prepared: Callable[[int, Path, PreparedImage], None] | None = None) -> Written:
    """Convert frames of an input read once with ``options`` to ``targets`` (several outputs
    of a frame differ only in their format, and are made from one run of the pipeline), and
    write them, all or none: each is staged to its temporary file and they are renamed into
    place together once every one is made (a failure in frame k leaves no partial set).
    ``every_frame``: the input is an animation converted whole (its frames decoded in order,
    checked against ``max_frames`` and, in all, ``max_pixels``; PNG frames' pixels in all
    against ``max_output_pixels``, before each is converted). With ``options.output.animate``
    the targets (of frame 0) each hold every frame, or their tag's (``Target.tag``: the file
    is read once for all its tags; :func:`depixel.api.animated`), within the same limits. Without ``overwrite``, an
    output that became unstamped or edited while converting is kept. ``token``: the run's
    (:mod:`depixel.files.output`). The outputs are stamped with the input's identity as read;
    whether it changed meanwhile is in the result."""
    name, limits = source.name, options.limits
    by_frame: dict[int, list[Target]] = {}
    for target in targets:
        by_frame.setdefault(target.frame, []).append(target)
    frames = decoded_frames(source, by_frame, options, every_frame)
    done = Written()
    staged: dict[Path, outputs.Staged | None] = {}  # None: a device, written in place
    pngs = sum(target.fmt == "png" and target.sprite is None for target in targets)  # (a sheet's sprites': _converted)
    try:
        began, rendered, pngs_done = time.perf_counter(), 0, 0
        for frame, rgba in frames:
            if frame not in by_frame:
                continue
            wanted = by_frame[frame]
            for target in wanted:
                if target.fmt == "png" and target.sprite is None and pngs > 1 and isinstance(rgba, np.ndarray):
                    height, width = rgba.shape[:2]  # the PNGs' pixels in all, this one's for each still to come
                    scale = options.output.scale_for(width, height)
                    each = max(1, round(width * scale)) * max(1, round(height * scale))
                    check_rendered_frames(name, pngs, rendered + each * (pngs - pngs_done), limits.max_output_pixels)
                    rendered, pngs_done = rendered + each, pngs_done + 1
            blobs = _converted(rgba, source, wanted, options,
                               None if on_prepared is None else partial(on_prepared, frame, wanted[0].path),
                               done.notes)
            protect = () if source.path is None else (source.path,)
            seconds = (time.perf_counter() - began) / len(wanted)
            for target, blob in zip(wanted, blobs):
                staged[target.path] = outputs.stage(target.path, blob, protect=protect, token=token)
                done.sizes[target.path], done.seconds[target.path] = len(blob), seconds
            began = time.perf_counter()
        done.changed = source.changed()
        if not overwrite:
            done.kept = {path: now for path in staged
                         if (now := stamps.replaceable(path)) in stamps.KEPT}
        done.written = [path for path in staged if path not in done.kept]
        outputs.commit([item for path in done.written if (item := staged.pop(path)) is not None])
    finally:
        outputs.discard([item for item in staged.values() if item is not None])
    return done


def decoded_frames(source: InputFile, frames: Iterable[int], options: ConvertOptions,
                   every_frame: bool = False) -> Iterable[tuple[int, np.ndarray | Animation]]:
    """What a conversion of ``source`` with ``options`` decodes, ``(index, (H, W, 4) uint8
    RGBA)`` a frame: ``frames``, each decoded from the start, or with ``every_frame`` all of
    them in order (checked against the limits in all); with ``options.output.animate`` the
    whole :class:`Animation` as frame 0. A file that cannot be decoded raises
    :class:`InputError` (``--dry-run`` decodes them to report it as the conversion would)."""
    name, limits = source.name, options.limits
    if options.output.animate:
        return [(0, read_animation(source.data, limits.max_pixels, max_frames=limits.max_frames, name=name))]
    if every_frame:
        return load_frames(source.data, limits.max_pixels, max_frames=limits.max_frames, name=name)
    return ((frame, load_image(source.data, limits.max_pixels, frame, max_frames=limits.max_frames, name=name))
            for frame in frames)


def _converted(rgba: np.ndarray | Animation, source: InputFile, wanted: Sequence[Target], options: ConvertOptions,
               on_prepared: Callable[[PreparedImage], None] | None, notes: list[str]) -> list[bytes]:
    """The stamped bytes of each output of a frame (or of an animation): decoded pixels of
    ``source`` converted once (the file's own format says whether it is lossy: JPEG and lossy
    WebP are denoised unless ``denoise`` says otherwise). A sheet is cut once: its layered
    outputs and each sprite's (its crop converted with the sheet's options left out) are made
    from it, and what was found is added to ``notes``."""
    title = None if source.path is None else source.path.name
    lossy = lossy_format(source.data)
    if not options.output.is_sheet or isinstance(rgba, Animation):  # (the options refuse animate with a sheet)
        by_tag: dict[tuple[str | None, str], bytes] = {}
        for tag in dict.fromkeys(target.tag for target in wanted):  # an animation's tags, each played apart
            drafts = {t.fmt: stamps.text(t.digest, source.identity) for t in wanted if t.tag == tag}
            tagged = options if tag == options.output.tag else \
                dataclasses.replace(options, output=dataclasses.replace(options.output, tag=tag))
            played = conversions(rgba, drafts, tagged, name=source.name, title=title, lossy=lossy,
                                 on_prepared=on_prepared)
            by_tag.update(((tag, fmt), blob) for fmt, blob in played.items())
        return [stamps.embed(by_tag[t.tag, t.fmt], t.fmt, t.digest, source.identity) for t in wanted]
    from ..prepare.sheet import sheet_of  # noqa: PLC0415 (~10 ms of imports: only for a sheet)

    sheet = sheet_of(rgba, options.output.sheet, options.output.sheet_json, source.name)
    if (line := f"{source.name}: {sheet.description}") not in notes:
        notes.append(line)
    by_name = {sprite.name: sprite for sprite in sheet.sprites}
    groups: dict[str | None, dict[str, Target]] = {}
    for target in wanted:
        groups.setdefault(target.sprite, {})[target.fmt] = target
    chosen = [by_name[name] for name in groups if name in by_name]
    if len(chosen) < len(groups) - (None in groups):
        missing = next(name for name in groups if name is not None and name not in by_name)
        raise InputError(f"{source.name}: has no sprite {missing!r} (any more); its sprites: "
                         f"{', '.join(by_name)}")
    limits = options.limits
    check_sprites(source.name, len(chosen), sum(s.width * s.height for s in chosen), limits.max_pixels,
                  limits.max_frames)
    pngs = [by_name[target.sprite] for target in wanted if target.fmt == "png" and target.sprite is not None]
    if len(pngs) > 1:  # the sprites' PNGs in all, as an animation's frames' are
        rendered = 0
        for sprite in pngs:
            scale = options.output.scale_for(sprite.width, sprite.height)
            rendered += max(1, round(sprite.width * scale)) * max(1, round(sprite.height * scale))
        check_rendered_frames(source.name, len(pngs), rendered, limits.max_output_pixels)
    alone = dataclasses.replace(options, output=dataclasses.replace(options.output, sheet=None, sheet_json=None))
    made: dict[tuple[str | None, str], bytes] = {}
    for name, targets in groups.items():
        drafts = {fmt: stamps.text(target.digest, source.identity) for fmt, target in targets.items()}
        if name is None:
            blobs = sheet_conversions(rgba, sheet, drafts, options, name=source.name, title=title, lossy=lossy,
                                      on_prepared=on_prepared)
        else:
            blobs = conversions(rgba[by_name[name].box], drafts, alone, name=f"{source.name} sprite {name}",
                                title=name, lossy=lossy, on_prepared=on_prepared)
        made.update(((name, fmt), blob) for fmt, blob in blobs.items())
    return [stamps.embed(made[target.sprite, target.fmt], target.fmt, target.digest, source.identity)
            for target in wanted]


def output_status(source: str | os.PathLike, target: Target) -> str:
    """What the existing output ``target`` is for a conversion of ``source``: ``stamp.NEW``,
    ``CURRENT`` (made from this input with these options: up to date), ``STALE`` (depixel's,
    unchanged since: safe to replace), ``UNSTAMPED`` (not depixel's), ``EDITED`` (changed
    since depixel wrote it) or ``OLD`` (stamped before edits could be told)."""
    return stamps.status(source, target.path, target.digest)


def render_file(source: str | os.PathLike, output: str | os.PathLike, *, fmt: str | None = None,
                scale: float | None = None, width: int | None = None, height: int | None = None,
                background: Colour | str | None = None,
                max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS) -> Path:
    """Render an SVG file to PNG or PDF (``scale`` × its size, or ``width``/``height`` pixels).

    A PNG of more than ``max_output_pixels`` pixels is refused before it is allocated."""
    from ..render.raster import render  # noqa: PLC0415

    fmt = output_format(output, fmt)
    if fmt == "svg":
        raise OutputError(f"{display_name(output)}: render writes PNG or PDF, not SVG", parameter="fmt")
    colour = as_colour(background)
    svg = read_input(source)
    data = render(svg, fmt, scale=scale, size=(width, height), background=colour,
                  name=display_name(source), max_output_pixels=max_output_pixels)
    write_atomic(output, data, protect=(Path(source),))
    return Path(output)


def read_input(path: str | os.PathLike) -> bytes:
    """The bytes of an input file, or an :class:`InputError` naming it."""
    return read_source(path)
