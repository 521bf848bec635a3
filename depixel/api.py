"""Python API: convert pixel art in memory or file to file, without the command line.

In memory, :func:`convert` takes an image (numpy array or PIL image) and returns SVG text;
:func:`convert_bytes` returns the bytes of an SVG, PNG or PDF file. On disk,
:func:`convert_file` and :func:`render_file` read one file and write another atomically
(never a partial file, never over their input). PNG and PDF go through cairosvg, which is
imported only when one of them is asked for (:mod:`depixel.raster`).
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from . import stamp as stamps
from . import validate
from .errors import OutputError, ParameterError, RenderError, display_name
from .image import ImageSource, as_rgba, check_indexable, check_pixels, load_image, read_source
from .limits import DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from .outlines import LAYOUTS
from .output import write_atomic
from .params import Params
from .pipeline import STAGES, depixelize
from .prepare import (
    AUTO,
    PixelSize,
    PreparedImage,
    lossy_format,
    overlay_raster,
    overlay_svg,
    parse_pixel_size,
    parse_transparent,
    pil_lossy,
    prepare,
)
from .svg import DEFAULT_PRECISION, DEFAULT_SIMPLIFY, MAX_SIMPLIFY, to_svg

#: Output formats, chosen from the file extension or given explicitly.
FORMATS = ("svg", "png", "pdf")
#: how PNG output is shaded: "smooth" is the paper's renderer (§3.5, depixel.shading),
#: "flat" rasterizes the SVG (per-cell flat fills) through cairosvg
SHADINGS = ("smooth", "flat")

Colour = tuple[int, int, int]


def parse_colour(text: str) -> Colour:
    """``#rgb``, ``#rrggbb``, ``rgb(...)`` or a CSS name such as ``white`` → an RGB triple."""
    from PIL import ImageColor  # noqa: PLC0415

    try:
        rgb = ImageColor.getrgb(text.strip())
    except (ValueError, AttributeError):
        raise ParameterError(f"unknown colour {text!r} (use #rgb, #rrggbb or a name like white)",
                             parameter="background") from None
    return int(rgb[0]), int(rgb[1]), int(rgb[2])


def _colour(value: Colour | str | None) -> Colour | None:
    """A background argument (None, a colour name or an RGB triple of 0-255 integers) as RGB."""
    if value is None or isinstance(value, str):
        return None if value is None else parse_colour(value)
    try:
        rgb = tuple(value)
    except TypeError:
        rgb = ()
    if len(rgb) != 3:
        raise ParameterError(f"background must be a colour name or an (r, g, b) triple, not {value!r}",
                             parameter="background")
    r, g, b = (int(validate.number("background", c, low=0, high=255, integer=True)) for c in rgb)
    return r, g, b


def _pixels(image, name: str = "<image>", max_pixels: int | None = DEFAULT_MAX_PIXELS) -> None:
    """Refuse what is not an image in memory (a file name gets a pointer to the file
    functions) and images over ``max_pixels``, before any conversion copies them."""
    if isinstance(image, (str, os.PathLike)):
        raise ParameterError(f"{display_name(image)}: convert takes pixels (a numpy array or a PIL image), "
                             "not a file name; use depixel.convert_file(path, output) or "
                             "depixel.api.load(path)", parameter="image")
    if isinstance(image, (bytes, bytearray, memoryview)):
        raise ParameterError("convert takes pixels (a numpy array or a PIL image), not file bytes; "
                             "decode them with depixel.api.load(data)", parameter="image")
    size = image.size if hasattr(image, "mode") and hasattr(image, "size") else np.shape(image)[1::-1]
    if len(size) == 2:
        check_pixels(name, int(size[0]), int(size[1]), validate.limit("max_pixels", max_pixels))
        check_indexable(name, int(size[0]), int(size[1]))


def _scale(shape: tuple[int, ...], scale: float, width: int | None, height: int | None) -> float:
    """The scale that gives ``width`` (or ``height``) pixels, else ``scale``."""
    validate.positive("scale", scale)
    if width is not None and height is not None:
        raise ParameterError("give width or height, not both (the other follows the aspect ratio)",
                             parameter="width")
    for key, value, size in (("width", width, shape[1]), ("height", height, shape[0])):
        if value is not None:
            return validate.number(key, value, low=1, integer=True) / size
    return float(scale)


def _output_options(stage: str, precision: int, layout: str = "stacked", simplify: float = DEFAULT_SIMPLIFY) -> None:
    validate.choice("stage", stage, STAGES)
    validate.number("precision", precision, low=0, high=12, integer=True)
    validate.choice("layout", layout, LAYOUTS)
    validate.number("simplify", simplify, low=0, high=MAX_SIMPLIFY)


def flatten(image, colour: Colour | str) -> np.ndarray:
    """Composite an image over an opaque colour → ``(H, W, 4) uint8`` with alpha 255.

    Useful before converting art whose semi-transparent edges should blend into a known
    background instead of becoming separate translucent shapes.
    """
    rgb = np.array(_colour(colour), dtype=np.int64)
    _pixels(image, max_pixels=None)
    rgba = as_rgba(image).astype(np.int64)
    alpha = rgba[..., 3:4]
    out = np.empty(rgba.shape, np.uint8)
    out[..., :3] = (rgba[..., :3] * alpha + rgb * (255 - alpha) + 127) // 255
    out[..., 3] = 255
    return out


def load(source: ImageSource, *, frame: int = 0, background: Colour | str | None = None,
         max_pixels: int | None = DEFAULT_MAX_PIXELS) -> np.ndarray:
    """Read an image file (path, bytes or binary file) → ``(H, W, 4) uint8`` RGBA,
    flattened over ``background`` when given."""
    colour = _colour(background)
    rgba = load_image(source, max_pixels=max_pixels, frame=frame)
    return rgba if colour is None else flatten(rgba, colour)


def convert(image, params: Params = Params(), *, stage: str = "optimized", scale: float = 1.0,
            background: Colour | str | None = None, title: str | None = None, precision: int = DEFAULT_PRECISION,
            width: int | None = None, height: int | None = None,
            max_pixels: int | None = DEFAULT_MAX_PIXELS, layout: str = "stacked",
            simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
            transparent: Colour | str | None = None) -> str:
    """Depixelize an image (``(H, W[, C])`` array, PIL image or :class:`PreparedImage`) → SVG text.

    ``scale`` sets the SVG's width/height as a multiple of the input's size (or ``width`` or
    ``height`` in pixels, the other following); the viewBox is in art pixels. ``stage``
    stops the pipeline early ("cells", "splines"; "splines" is the result without the §3.4
    optimization). ``precision`` is the number of decimals of the SVG's coordinates.
    ``layout`` is "stacked" (every shape continues under the shapes drawn above it) or
    "cutout" (shapes that tile the image); ``simplify`` is the tolerance in pixels within
    which fewer curves replace the exact spline (0: the exact spline; docs/svg.md).
    ``pixel_size``, ``denoise`` and ``transparent`` prepare the input first
    (:func:`depixel.prepare.prepare`, docs/inputs.md): upscaled art is converted at 1× and
    laid exactly over the input. Images over ``max_pixels`` pixels are refused (``None``:
    no limit).
    """
    prepared, scale = _prepare(image, params, stage, precision, background, scale, width, height, max_pixels,
                               layout=layout, simplify=simplify, pixel_size=pixel_size, denoise=denoise,
                               transparent=transparent)
    vector = depixelize(prepared.rgba, params, stage=stage).vector  # the other stages' products are freed here
    svg = to_svg(vector, scale=scale, precision=precision, title=title, layout=layout, simplify=simplify)
    return overlay_svg(svg, prepared, scale)


def prepare_input(image, *, background: Colour | str | None = None, pixel_size: PixelSize = AUTO,
                  denoise: bool | None = None, transparent: Colour | str | None = None,
                  lossy: str | None = None, max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`depixel.prepare.prepare` after flattening over ``background`` (when given);
    a :class:`PreparedImage` is returned as it is. ``lossy`` names the lossy format the
    pixels came from ("JPEG"; a PIL image says so itself), which turns denoising on."""
    if isinstance(image, PreparedImage):
        return image
    colour = _colour(background)
    _pixels(image, max_pixels=max_pixels)
    lossy = lossy or pil_lossy(image)
    rgba = as_rgba(image) if colour is None else flatten(image, colour)
    return prepare(rgba, pixel_size=pixel_size, denoise=denoise, transparent=transparent, lossy=lossy)


def _prepare(image, params, stage, precision, background, scale, width, height, max_pixels,
             name: str = "<image>", layout: str = "stacked", simplify: float = DEFAULT_SIMPLIFY,
             pixel_size: PixelSize = AUTO, denoise: bool | None = None, transparent: Colour | str | None = None,
             lossy: str | None = None) -> tuple[PreparedImage, float]:
    """Check every argument of a conversion → the prepared 1× art and the scale to write at
    (relative to the input's size)."""
    if not isinstance(params, Params):
        raise ParameterError(f"params must be a depixel.Params, not {type(params).__name__}", parameter="params")
    _output_options(stage, precision, layout, simplify)
    if not isinstance(image, PreparedImage):
        _pixels(image, name, max_pixels)
    prepared = prepare_input(image, background=background, pixel_size=pixel_size, denoise=denoise,
                             transparent=transparent, lossy=lossy, max_pixels=None)
    w, h = prepared.input_size
    return prepared, _scale((h, w), scale, width, height)


def encode(svg: str, fmt: str = "svg", *, name: str = "<svg>", keywords: str | None = None) -> bytes:
    """SVG text → the bytes of an ``fmt`` file (SVG as UTF-8, PNG/PDF rendered at the SVG's size)."""
    validate.choice("format", fmt, FORMATS)
    if fmt == "svg":
        return svg.encode("utf-8")
    from .raster import render  # noqa: PLC0415 (cairosvg only when PNG/PDF is asked for)

    return render(svg, fmt, name=name, keywords=keywords)


def convert_bytes(image, fmt: str = "svg", params: Params = Params(), *, stage: str = "optimized",
                  scale: float = 1.0, background: Colour | str | None = None, title: str | None = None,
                  shading: str = "smooth", name: str = "<image>", precision: int = DEFAULT_PRECISION,
                  width: int | None = None, height: int | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS,
                  max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS, layout: str = "stacked",
                  simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                  transparent: Colour | str | None = None) -> bytes:
    """Like :func:`convert`, returning the bytes of an SVG, PNG or PDF file.

    PNG output is rendered with the paper's smooth shading unless ``shading="flat"``, which
    rasterizes the SVG instead (SVG and PDF are always the vector result). A PNG of more
    than ``max_output_pixels`` pixels is refused before it is rendered.
    """
    return _convert_bytes(image, fmt, params, stage=stage, scale=scale, background=background, title=title,
                          shading=shading, name=name, precision=precision, width=width, height=height,
                          max_pixels=max_pixels, max_output_pixels=max_output_pixels, layout=layout,
                          simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent)


def _convert_bytes(image, fmt, params, *, stage, scale, background, title, shading, name, precision,
                   width, height, max_pixels, max_output_pixels, layout, simplify, pixel_size=AUTO,
                   denoise=None, transparent=None, lossy=None, stamp: str | None = None,
                   on_prepared: Callable[[PreparedImage], None] | None = None) -> bytes:
    """:func:`convert_bytes`, with the options ``stamp`` written into the file when given."""
    validate.choice("format", fmt, FORMATS)
    validate.choice("shading", shading, SHADINGS)
    max_output_pixels = validate.limit("max_output_pixels", max_output_pixels)
    prepared, scale = _prepare(image, params, stage, precision, background, scale, width, height, max_pixels, name,
                               layout, simplify, pixel_size, denoise, transparent, lossy)
    if on_prepared is not None:
        on_prepared(prepared)
    if fmt == "png":
        size = max(1, round(prepared.input_size[0] * scale)), max(1, round(prepared.input_size[1] * scale))
        if max_output_pixels is not None and size[0] * size[1] > max_output_pixels:
            raise RenderError(f"{name}: a {size[0]}x{size[1]} PNG is {size[0] * size[1]} pixels, over the "
                              f"limit of {max_output_pixels} (raise it with max_output_pixels)",
                              parameter="max_output_pixels")
    vector = depixelize(prepared.rgba, params, stage=stage).vector
    if fmt == "png" and shading == "smooth":
        import io  # noqa: PLC0415

        from PIL import Image  # noqa: PLC0415

        from .shading import render_smooth  # noqa: PLC0415

        # rendered at the art's grid, then laid over the input like the SVG
        pixels = render_smooth(vector, scale * max(prepared.pixel_size), params=params)
        buffer = io.BytesIO()
        Image.fromarray(overlay_raster(pixels, prepared, scale), "RGBA").save(buffer, format="PNG")
        blob = buffer.getvalue()
    else:
        svg = to_svg(vector, scale=scale, precision=precision, title=title, layout=layout, simplify=simplify)
        svg = overlay_svg(svg, prepared, scale)
        keywords = None if stamp is None else f"{stamps.KEY}:{stamp}"
        blob = encode(svg, fmt, name=name, keywords=keywords)
    return blob if stamp is None else stamps.embed(blob, fmt, stamp)


def output_format(path: str | os.PathLike, fmt: str | None = None) -> str:
    """The output format: the file extension (svg, png or pdf), or ``fmt`` for a name without
    one of those extensions (``-``, ``/dev/stdout``, ``out.tmp``). A known extension that
    disagrees with ``fmt`` is refused: SVG text in a file named ``.png`` helps nobody."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if fmt is not None:
        _check_format(fmt)
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
    made it (:mod:`depixel.stamp`), which :func:`is_up_to_date` compares. ``denoise=None``
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
    _output_options(stage, precision, layout, simplify)
    options = {"fmt": output_format(output, fmt), "stage": stage, "scale": float(scale), "frame": int(frame),
               "background": _colour(background), "shading": validate.choice("shading", shading, SHADINGS),
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
                    on_prepared: Callable[[PreparedImage], None] | None = None) -> None:
    """Convert decoded pixels of ``source`` with :func:`file_options` and write ``output``
    atomically (the file's own format says whether it is lossy: JPEG and lossy WebP are
    denoised unless ``denoise`` says otherwise)."""
    blob = _convert_bytes(rgba, options["fmt"], options["params"], stage=options["stage"], scale=options["scale"],
                          background=options["background"], title=Path(source).name, shading=options["shading"],
                          name=display_name(source), precision=options["precision"], width=options["width"],
                          height=options["height"], max_pixels=max_pixels, max_output_pixels=max_output_pixels,
                          layout=options["layout"], simplify=options["simplify"], pixel_size=options["pixel_size"],
                          denoise=options["denoise"], transparent=options["transparent"],
                          lossy=lossy_format(read_source(source)), stamp=options["stamp"], on_prepared=on_prepared)
    write_atomic(output, blob, protect=(Path(source),))


def is_up_to_date(source: str | os.PathLike, output: str | os.PathLike, options: dict) -> bool:
    """True when ``output`` is newer than ``source`` and was made with these :func:`file_options`."""
    return stamps.up_to_date(source, output, options["stamp"])


def render_file(source: str | os.PathLike, output: str | os.PathLike, *, fmt: str | None = None,
                scale: float | None = None, width: int | None = None, height: int | None = None,
                background: Colour | str | None = None,
                max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS) -> Path:
    """Render an SVG file to PNG or PDF (``scale`` × its size, or ``width``/``height`` pixels).

    A PNG of more than ``max_output_pixels`` pixels is refused before it is allocated."""
    from .raster import render  # noqa: PLC0415

    fmt = output_format(output, fmt)
    if fmt == "svg":
        raise OutputError(f"{display_name(output)}: render writes PNG or PDF, not SVG", parameter="fmt")
    colour = _colour(background)
    svg = read_input(source)
    data = render(svg, fmt, scale=scale, width=width, height=height, background=colour,
                  name=display_name(source), max_output_pixels=max_output_pixels)
    write_atomic(output, data, protect=(Path(source),))
    return Path(output)


def read_input(path: str | os.PathLike) -> bytes:
    """The bytes of an input file, or an :class:`InputError` naming it."""
    return read_source(path)


def _check_format(fmt: str) -> str:
    return validate.choice("format", fmt, FORMATS)
