"""File to file — an image file → an SVG, PNG or PDF file; an SVG file → PNG or PDF.

:func:`convert_file` and :func:`render_file` read one file and write another atomically
(:mod:`depixel.files.output`: never a partial file, never over their input). An input is read
once (:class:`InputFile`), with its identity at that moment; every output made from it carries
the stamp of the options and of that identity (:mod:`depixel.files.stamp`), which
:func:`output_status` compares; :func:`file_options` checks those options once for a batch.
:func:`convert_frames` writes the outputs of several frames of one input, all or none.
"""
from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from pathlib import Path

import numpy as np

from .. import validate
from ..api import FORMATS, SHADINGS, check_output_options, conversions
from ..colour import Colour, as_colour
from ..errors import InputError, OutputError, ParameterError, display_name
from ..limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS, check_rendered_frames
from ..params import Params
from ..prepare.image import load_frames, load_image, read_source
from ..prepare.inputs import AUTO, PixelSize, PreparedImage, lossy_format, parse_pixel_size, parse_transparent
from ..svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY
from . import output as outputs
from . import stamp as stamps
from .output import write_atomic


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
                 max_frames: int | None = DEFAULT_MAX_FRAMES) -> Path:
    """Convert one image file (one frame of it) to an SVG, PNG or PDF file; returns the output path.

    The output is written atomically and never replaces ``source``. SVG and PNG output have
    the smooth shading unless ``shading="flat"`` (:func:`depixel.api.convert_bytes`). The
    file carries the stamp of the options and
    of the input that made it (:mod:`depixel.files.stamp`), which :func:`output_status`
    compares. ``denoise=None`` denoises JPEG and lossy WebP files; ``on_prepared`` is called
    with what the preparation found (to report it). An input that changes while it is
    converted raises :class:`InputError` once the output is written (of the version read,
    stamped as such: never up to date).
    """
    options = file_options(output, params, fmt=fmt, stage=stage, scale=scale, frame=frame, background=background,
                           shading=shading, precision=precision, width=width, height=height, layout=layout,
                           simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                           transparent_everywhere=transparent_everywhere)
    result = convert_frames(InputFile.read(source), {int(frame): [(Path(output), options)]}, max_pixels=max_pixels,
                            max_output_pixels=max_output_pixels, max_frames=max_frames,
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
    #: outputs that became someone else's while they were converted: stamp.UNSTAMPED or EDITED
    kept: dict[Path, str] = dataclasses.field(default_factory=dict)
    seconds: dict[Path, float] = dataclasses.field(default_factory=dict)  # each output's share of the work
    sizes: dict[Path, int] = dataclasses.field(default_factory=dict)  # bytes of each output
    changed: bool = False  # the input changed during the conversion


def convert_frames(source: InputFile, targets: Mapping[int, Sequence[tuple[Path, dict]]], *, every_frame: bool = False,
                   max_pixels: int | None = DEFAULT_MAX_PIXELS,
                   max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS,
                   max_frames: int | None = DEFAULT_MAX_FRAMES, token: str | None = None, overwrite: bool = True,
                   on_prepared: Callable[[int, Path, PreparedImage], None] | None = None) -> Written:
    """Convert frames of an input read once, ``targets`` {frame: [(output, :func:`file_options`), ...]}
    (several outputs of a frame differ only in their format, and are made from one run of the
    pipeline), and write them, all or none: each is staged to its temporary file and they are
    renamed into place together once every one is made (a failure in frame k leaves no
    partial set). ``every_frame``: the input is an animation converted whole (its frames
    decoded in order, checked against ``max_frames`` and, in all, ``max_pixels``; PNG frames'
    pixels in all against ``max_output_pixels``, before each is converted). Without
    ``overwrite``, an output that became unstamped or edited while converting is kept.
    ``token``: the run's (:mod:`depixel.files.output`). The outputs are stamped with the
    input's identity as read; whether it changed meanwhile is in the result."""
    name = source.name
    frames = load_frames(source.data, max_pixels, max_frames=max_frames, name=name) if every_frame else \
        ((frame, load_image(source.data, max_pixels, frame, max_frames=max_frames, name=name)) for frame in targets)
    done = Written()
    staged: dict[Path, outputs.Staged | None] = {}  # None: a device, written in place
    pngs = sum(options["fmt"] == "png" for wanted in targets.values() for _, options in wanted)
    try:
        began, rendered, pngs_done = time.perf_counter(), 0, 0
        for frame, rgba in frames:
            if frame not in targets:
                continue
            wanted = targets[frame]
            for _, options in wanted:
                if options["fmt"] == "png" and pngs > 1:  # the PNGs' pixels in all, this one's size
                    each = _png_pixels(rgba.shape, options)  # for each of those still to come
                    check_rendered_frames(name, pngs, rendered + each * (pngs - pngs_done), max_output_pixels)
                    rendered, pngs_done = rendered + each, pngs_done + 1
            blobs = _converted(rgba, source, [options for _, options in wanted], max_pixels, max_output_pixels,
                               None if on_prepared is None else partial(on_prepared, frame, wanted[0][0]))
            protect = () if source.path is None else (source.path,)
            seconds = (time.perf_counter() - began) / len(wanted)
            for (target, _), blob in zip(wanted, blobs):
                staged[target] = outputs.stage(target, blob, protect=protect, token=token)
                done.sizes[target], done.seconds[target] = len(blob), seconds
            began = time.perf_counter()
        done.changed = source.changed()
        if not overwrite:
            done.kept = {target: now for target in staged
                         if (now := stamps.replaceable(target)) in (stamps.UNSTAMPED, stamps.EDITED)}
        done.written = [target for target in staged if target not in done.kept]
        outputs.commit([item for target in done.written if (item := staged.pop(target)) is not None])
    finally:
        outputs.discard([item for item in staged.values() if item is not None])
    return done


def _png_pixels(shape: tuple[int, ...], options: dict) -> int:
    """Pixels of the PNG of an input of ``shape`` with these options (as
    :func:`depixel.api.conversion_bytes` sizes it)."""
    height, width = shape[:2]
    scale = options["width"] / width if options["width"] else \
        options["height"] / height if options["height"] else options["scale"]
    return max(1, round(width * scale)) * max(1, round(height * scale))


def _converted(rgba: np.ndarray, source: InputFile, wanted: Sequence[dict], max_pixels: int | None,
               max_output_pixels: int | None, on_prepared: Callable[[PreparedImage], None] | None) -> list[bytes]:
    """The stamped bytes of each output of a frame: decoded pixels of ``source`` converted
    once with :func:`file_options` that differ only in their format (the file's own format
    says whether it is lossy: JPEG and lossy WebP are denoised unless ``denoise`` says
    otherwise)."""
    first = wanted[0]
    drafts = {options["fmt"]: stamps.text(options["stamp"], source.identity) for options in wanted}
    blobs = conversions(rgba, drafts, first["params"], stage=first["stage"], scale=first["scale"],
                        background=first["background"], title=None if source.path is None else source.path.name,
                        shading=first["shading"], name=source.name, precision=first["precision"],
                        width=first["width"], height=first["height"], max_pixels=max_pixels,
                        max_output_pixels=max_output_pixels, layout=first["layout"], simplify=first["simplify"],
                        pixel_size=first["pixel_size"], denoise=first["denoise"], transparent=first["transparent"],
                        transparent_everywhere=first["transparent_everywhere"], lossy=lossy_format(source.data),
                        on_prepared=on_prepared)
    return [stamps.embed(blobs[options["fmt"]], options["fmt"], options["stamp"], source.identity)
            for options in wanted]


def file_options(output: str | os.PathLike, params: Params = Params(), *, fmt: str | None = None,
                 stage: str = "optimized", scale: float = 1.0, frame: int = 0,
                 background: Colour | str | None = None, shading: str = "smooth", precision: int = DEFAULT_PRECISION,
                 width: int | None = None, height: int | None = None, layout: str = "stacked",
                 simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                 transparent: Colour | str | None = None, transparent_everywhere: bool = False) -> dict:
    """The checked options of :func:`convert_file` that decide the output's bytes, with
    their ``stamp``; the arguments of :func:`convert_frames` and :func:`output_status`."""
    if not isinstance(params, Params):
        raise ParameterError(f"params must be a depixel.Params, not {type(params).__name__}", parameter="params")
    validate.number("frame", frame, low=0, integer=True)
    validate.positive("scale", scale)
    check_output_options(stage, precision, layout, simplify)
    options = {"fmt": output_format(output, fmt), "stage": stage, "scale": float(scale), "frame": int(frame),
               "background": as_colour(background), "shading": validate.choice("shading", shading, SHADINGS),
               "precision": int(precision), "width": width, "height": height, "params": params,
               "layout": layout, "simplify": float(simplify), "pixel_size": parse_pixel_size(pixel_size),
               "denoise": denoise, "transparent": parse_transparent(transparent),
               "transparent_everywhere": validate.flag("transparent_everywhere", transparent_everywhere)}
    # only what changes the bytes: shading is for SVG and PNG (a PDF has the flat bands), and a
    # smooth PNG ignores the SVG's settings
    smooth_png = options["fmt"] == "png" and shading == "smooth"
    stamped = {**options, "params": dataclasses.asdict(params), "shading": shading if options["fmt"] != "pdf" else None,
               **({"precision": None, "layout": None, "simplify": None} if smooth_png else {})}
    if options["transparent"] is None:  # (an option added with the border flood fill: other stamps are unchanged)
        del stamped["transparent_everywhere"]
    stamp = stamps.options_stamp(**stamped)
    return {**options, "stamp": stamp}


def output_status(source: str | os.PathLike, output: str | os.PathLike, options: dict) -> str:
    """What the existing ``output`` is for a conversion of ``source`` with these
    :func:`file_options`: ``stamp.NEW``, ``CURRENT`` (made from this input with these
    options: up to date), ``STALE`` (depixel's, unchanged since: safe to replace),
    ``UNSTAMPED`` (not depixel's) or ``EDITED`` (changed since depixel wrote it)."""
    return stamps.status(source, output, options["stamp"])


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
    data = render(svg, fmt, scale=scale, width=width, height=height, background=colour,
                  name=display_name(source), max_output_pixels=max_output_pixels)
    write_atomic(output, data, protect=(Path(source),))
    return Path(output)


def read_input(path: str | os.PathLike) -> bytes:
    """The bytes of an input file, or an :class:`InputError` naming it."""
    return read_source(path)
