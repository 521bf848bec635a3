"""File to file — an image file → an SVG, PNG or PDF file; an SVG file → PNG or PDF.

:func:`convert_file` and :func:`render_file` read one file and write another atomically
(:mod:`depixel.files.output`: never a partial file, never over their input). A converted
file carries the stamp of the options that made it (:mod:`depixel.files.stamp`), which
:func:`is_up_to_date` compares; :func:`file_options` checks those options once for a batch.
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import validate
from ..api import FORMATS, SHADINGS, check_output_options, conversion_bytes, load
from ..colour import Colour, as_colour
from ..errors import OutputError, ParameterError, display_name
from ..limits import DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from ..params import Params
from ..prepare.image import read_source
from ..prepare.inputs import AUTO, PixelSize, PreparedImage, lossy_format, parse_pixel_size, parse_transparent
from ..svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY
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
                 transparent: Colour | str | None = None,
                 on_prepared: Callable[[PreparedImage], None] | None = None) -> Path:
    """Convert one image file (one frame of it) to an SVG, PNG or PDF file; returns the output path.

    The output is written atomically and never replaces ``source``. PNG output uses the
    smooth renderer unless ``shading="flat"``. The file carries the stamp of the options that
    made it (:mod:`depixel.files.stamp`), which :func:`is_up_to_date` compares. ``denoise=None``
    denoises JPEG and lossy WebP files; ``on_prepared`` is called with what the preparation
    found (to report it).
    """
    options = file_options(output, params, fmt=fmt, stage=stage, scale=scale, frame=frame, background=background,
                           shading=shading, precision=precision, width=width, height=height, layout=layout,
                           simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent)
    rgba = load(source, frame=frame, max_pixels=max_pixels)
    write_converted(rgba, source, output, options, max_pixels=max_pixels, max_output_pixels=max_output_pixels,
                    on_prepared=on_prepared)
    return Path(output)


def file_options(output: str | os.PathLike, params: Params = Params(), *, fmt: str | None = None,
                 stage: str = "optimized", scale: float = 1.0, frame: int = 0,
                 background: Colour | str | None = None, shading: str = "smooth", precision: int = DEFAULT_PRECISION,
                 width: int | None = None, height: int | None = None, layout: str = "stacked",
                 simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                 transparent: Colour | str | None = None) -> dict:
    """The checked options of :func:`convert_file` that decide the output's bytes, with
    their ``stamp``; the arguments of :func:`write_converted` and :func:`is_up_to_date`."""
    if not isinstance(params, Params):
        raise ParameterError(f"params must be a depixel.Params, not {type(params).__name__}", parameter="params")
    validate.number("frame", frame, low=0, integer=True)
    validate.positive("scale", scale)
    check_output_options(stage, precision, layout, simplify)
    options = {"fmt": output_format(output, fmt), "stage": stage, "scale": float(scale), "frame": int(frame),
               "background": as_colour(background), "shading": validate.choice("shading", shading, SHADINGS),
               "precision": int(precision), "width": width, "height": height, "params": params,
               "layout": layout, "simplify": float(simplify), "pixel_size": parse_pixel_size(pixel_size),
               "denoise": denoise, "transparent": parse_transparent(transparent)}
    # only what changes the bytes: shading is for PNG, which ignores the SVG's settings when smooth
    smooth_png = options["fmt"] == "png" and shading == "smooth"
    stamp = stamps.options_stamp(**{**options, "params": dataclasses.asdict(params),
                                    "shading": shading if options["fmt"] == "png" else None,
                                    **({"precision": None, "layout": None, "simplify": None} if smooth_png else {})})
    return {**options, "stamp": stamp}


def write_converted(rgba: np.ndarray, source: str | os.PathLike, output: str | os.PathLike, options: dict, *,
                    max_pixels: int | None = DEFAULT_MAX_PIXELS,
                    max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS,
                    on_prepared: Callable[[PreparedImage], None] | None = None, token: str | None = None) -> None:
    """Convert decoded pixels of ``source`` with :func:`file_options` and write ``output``
    atomically (the file's own format says whether it is lossy: JPEG and lossy WebP are
    denoised unless ``denoise`` says otherwise). ``token``: the run's, in the name of the
    temporary file (:func:`depixel.files.output.write_atomic`)."""
    blob = conversion_bytes(rgba, options["fmt"], options["params"], stage=options["stage"], scale=options["scale"],
                          background=options["background"], title=Path(source).name, shading=options["shading"],
                          name=display_name(source), precision=options["precision"], width=options["width"],
                          height=options["height"], max_pixels=max_pixels, max_output_pixels=max_output_pixels,
                          layout=options["layout"], simplify=options["simplify"], pixel_size=options["pixel_size"],
                          denoise=options["denoise"], transparent=options["transparent"],
                          lossy=lossy_format(read_source(source)), keywords=f"{stamps.KEY}:{options['stamp']}",
                            on_prepared=on_prepared)
    write_atomic(output, stamps.embed(blob, options["fmt"], options["stamp"]), protect=(Path(source),), token=token)


def is_up_to_date(source: str | os.PathLike, output: str | os.PathLike, options: dict) -> bool:
    """True when ``output`` is newer than ``source`` and was made with these :func:`file_options`."""
    return stamps.up_to_date(source, output, options["stamp"])


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
