"""Python API: convert pixel art in memory or file to file, without the command line.

In memory, :func:`convert` takes an image (numpy array or PIL image) and returns SVG text;
:func:`convert_bytes` returns the bytes of an SVG, PNG or PDF file. On disk,
:func:`convert_file` and :func:`render_file` read one file and write another atomically
(never a partial file, never over their input). PNG and PDF go through cairosvg, which is
imported only when one of them is asked for (:mod:`depixel.raster`).
"""
from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .errors import OutputError, display_name
from .image import DEFAULT_MAX_PIXELS, ImageSource, as_rgba, frame_count, load_image, read_source
from .output import write_atomic
from .params import Params
from .pipeline import depixelize
from .prepare import AUTO, PixelSize, PreparedImage, lossy_format, overlay_raster, overlay_svg, pil_lossy, prepare
from .svg import to_svg

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
        raise ValueError(f"unknown colour {text!r} (use #rgb, #rrggbb or a name like white)") from None
    return int(rgb[0]), int(rgb[1]), int(rgb[2])


def flatten(image, colour: Colour | str) -> np.ndarray:
    """Composite an image over an opaque colour → ``(H, W, 4) uint8`` with alpha 255.

    Useful before converting art whose semi-transparent edges should blend into a known
    background instead of becoming separate translucent shapes.
    """
    rgb = np.array(parse_colour(colour) if isinstance(colour, str) else colour, dtype=np.int64)
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
    rgba = load_image(source, max_pixels=max_pixels, frame=frame)
    return rgba if background is None else flatten(rgba, background)


def convert(image, params: Params = Params(), *, stage: str = "optimized", scale: float = 1.0,
            background: Colour | str | None = None, title: str | None = None, precision: int = 3,
            pixel_size: PixelSize = AUTO, denoise: bool | None = None,
            transparent: Colour | str | None = None) -> str:
    """Depixelize an image (``(H, W[, C])`` array, PIL image or :class:`PreparedImage`) → SVG text.

    ``scale`` sets the SVG's width/height as a multiple of the input's size; the viewBox
    is in art pixels. ``stage`` stops the pipeline early ("cells", "splines"; "splines" is
    the result without the §3.4 optimization). ``precision`` is the number of decimals of
    the SVG's coordinates. ``pixel_size``, ``denoise`` and ``transparent`` prepare the
    input first (:func:`depixel.prepare.prepare`): upscaled art is converted at 1× and laid
    exactly over the input.
    """
    prepared = prepare_input(image, background=background, pixel_size=pixel_size, denoise=denoise,
                             transparent=transparent)
    result = depixelize(prepared.rgba, params, stage=stage)
    svg = to_svg(result.vector, scale=scale, precision=precision, title=title)
    return overlay_svg(svg, prepared, scale)


def prepare_input(image, *, background: Colour | str | None = None, pixel_size: PixelSize = AUTO,
                  denoise: bool | None = None, transparent: Colour | str | None = None,
                  lossy: str | None = None) -> PreparedImage:
    """:func:`depixel.prepare.prepare` after flattening over ``background`` (when given);
    a :class:`PreparedImage` is returned as it is."""
    if isinstance(image, PreparedImage):
        return image
    if background is not None:
        lossy = lossy or pil_lossy(image)
        image = flatten(image, background)
    return prepare(image, pixel_size=pixel_size, denoise=denoise, transparent=transparent, lossy=lossy)


def encode(svg: str, fmt: str = "svg", *, name: str = "<svg>") -> bytes:
    """SVG text → the bytes of an ``fmt`` file (SVG as UTF-8, PNG/PDF rendered at the SVG's size)."""
    if fmt == "svg":
        return svg.encode("utf-8")
    from .raster import render  # noqa: PLC0415 (cairosvg only when PNG/PDF is asked for)

    return render(svg, fmt, name=name)


def convert_bytes(image, fmt: str = "svg", params: Params = Params(), *, stage: str = "optimized",
                  scale: float = 1.0, background: Colour | str | None = None, title: str | None = None,
                  shading: str = "smooth", name: str = "<image>", precision: int = 3,
                  pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                  transparent: Colour | str | None = None) -> bytes:
    """Like :func:`convert`, returning the bytes of an SVG, PNG or PDF file.

    PNG output is rendered with the paper's smooth shading unless ``shading="flat"``, which
    rasterizes the SVG instead (SVG and PDF are always the vector result).
    """
    _check_format(fmt)
    if shading not in SHADINGS:
        raise ValueError(f"unknown shading {shading!r}; choose one of {', '.join(SHADINGS)}")
    prepared = prepare_input(image, background=background, pixel_size=pixel_size, denoise=denoise,
                             transparent=transparent)
    if fmt == "png" and shading == "smooth":
        import io  # noqa: PLC0415

        from PIL import Image  # noqa: PLC0415

        from .shading import render_smooth  # noqa: PLC0415

        vector = depixelize(prepared.rgba, params, stage=stage).vector
        # rendered at the art's grid, then laid over the input like the SVG
        pixels = render_smooth(vector, scale * max(prepared.pixel_size), params=params)
        buffer = io.BytesIO()
        Image.fromarray(overlay_raster(pixels, prepared, scale), "RGBA").save(buffer, format="PNG")
        return buffer.getvalue()
    svg = convert(prepared, params, stage=stage, scale=scale, title=title, precision=precision)
    return encode(svg, fmt, name=name)


def output_format(path: str | os.PathLike, fmt: str | None = None) -> str:
    """The output format: ``fmt`` if given, else the file extension (svg, png or pdf)."""
    if fmt is not None:
        return _check_format(fmt)
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise OutputError(f"{display_name(path)}: cannot tell the output format from the extension "
                          f"(use .svg, .png or .pdf)")
    return suffix


def frame_outputs(output: str | os.PathLike, n_frames: int) -> list[Path]:
    """Output names for every frame of an animation: ``name-000.svg``, ``name-001.svg``, …"""
    out = Path(output)
    digits = max(3, len(str(n_frames - 1)))
    return [out.with_name(f"{out.stem}-{i:0{digits}d}{out.suffix}") for i in range(n_frames)]


def convert_file(source: str | os.PathLike, output: str | os.PathLike, params: Params = Params(), *,
                 fmt: str | None = None, stage: str = "optimized", scale: float = 1.0, frame: int = 0,
                 background: Colour | str | None = None, shading: str = "smooth",
                 max_pixels: int | None = DEFAULT_MAX_PIXELS, precision: int = 3,
                 pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                 transparent: Colour | str | None = None,
                 on_prepared: Callable[[PreparedImage], None] | None = None) -> Path:
    """Convert one image file (one frame of it) to an SVG, PNG or PDF file; returns the output path.

    The output is written atomically and never replaces ``source``. PNG output uses the
    smooth renderer unless ``shading="flat"``. ``denoise=None`` denoises JPEG and lossy
    WebP files; ``on_prepared`` is called with what the preparation found (to report it).
    """
    fmt = output_format(output, fmt)
    rgba = load(source, frame=frame, max_pixels=max_pixels)
    prepared = prepare_input(rgba, background=background, pixel_size=pixel_size, denoise=denoise,
                             transparent=transparent, lossy=lossy_format(read_source(source)))
    if on_prepared is not None:
        on_prepared(prepared)
    blob = convert_bytes(prepared, fmt, params, stage=stage, scale=scale, title=Path(source).name,
                         shading=shading, name=display_name(source), precision=precision)
    write_atomic(output, blob, protect=(Path(source),))
    return Path(output)


def render_file(source: str | os.PathLike, output: str | os.PathLike, *, fmt: str | None = None,
                scale: float | None = None, width: int | None = None,
                background: Colour | str | None = None) -> Path:
    """Render an SVG file to PNG or PDF (``scale`` × its size, or ``width`` pixels wide)."""
    from .raster import render  # noqa: PLC0415

    fmt = output_format(output, fmt)
    if fmt == "svg":
        raise OutputError(f"{display_name(output)}: render writes PNG or PDF, not SVG")
    svg = read_input(source)
    colour = parse_colour(background) if isinstance(background, str) else background
    data = render(svg, fmt, scale=scale, width=width, background=colour, name=display_name(source))
    write_atomic(output, data, protect=(Path(source),))
    return Path(output)


def read_input(path: str | os.PathLike) -> bytes:
    """The bytes of an input file, or an :class:`InputError` naming it."""
    return read_source(path)


def _check_format(fmt: str) -> str:
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    return fmt
