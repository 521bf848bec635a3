"""Python API in memory: convert pixel art without the command line.

:func:`convert` takes an image (numpy array or PIL image) and returns SVG text;
:func:`convert_bytes` returns the bytes of an SVG, PNG or PDF file. PNG and PDF go through
cairosvg, which is imported only when one of them is asked for (:mod:`depixel.render.raster`).
File to file (:func:`~depixel.files.convert.convert_file`, :func:`~depixel.files.convert.render_file`)
is :mod:`depixel.files.convert`.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping

import numpy as np

from . import validate
from .colour import Colour, as_colour
from .errors import ParameterError, RenderError, display_name
from .limits import DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from .params import Params
from .pipeline import STAGES, depixelize
from .prepare.image import ImageSource, as_rgba, check_indexable, check_pixels, image_array, load_image
from .prepare.inputs import AUTO, PixelSize, PreparedImage, pil_lossy, prepare
from .render.overlay import overlay_raster, overlay_svg
from .svg.outlines import LAYOUTS
from .svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY, MAX_SIMPLIFY, SHADINGS, SIGMA_RATIO, to_svg

#: Output formats, chosen from the file extension or given explicitly.
FORMATS = ("svg", "png", "pdf")

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
    size = image.size if hasattr(image, "mode") and hasattr(image, "size") else image_array(image).shape[1::-1]
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


def check_output_options(stage: str, precision: int, layout: str = "stacked",
                         simplify: float = DEFAULT_SIMPLIFY) -> None:
    """Refuse an unknown stage or layout and a precision or simplify tolerance out of range."""
    validate.choice("stage", stage, STAGES)
    validate.number("precision", precision, low=0, high=12, integer=True)
    validate.choice("layout", layout, LAYOUTS)
    validate.number("simplify", simplify, low=0, high=MAX_SIMPLIFY)


def flatten(image, colour: Colour | str) -> np.ndarray:
    """Composite an image over an opaque colour → ``(H, W, 4) uint8`` with alpha 255.

    Useful before converting art whose semi-transparent edges should blend into a known
    background instead of becoming separate translucent shapes.
    """
    rgb = np.array(as_colour(colour), dtype=np.int64)
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
    colour = as_colour(background)
    rgba = load_image(source, max_pixels=max_pixels, frame=frame)
    return rgba if colour is None else flatten(rgba, colour)


def convert(image, params: Params = Params(), *, stage: str = "optimized", scale: float = 1.0,
            background: Colour | str | None = None, title: str | None = None, precision: int = DEFAULT_PRECISION,
            width: int | None = None, height: int | None = None,
            max_pixels: int | None = DEFAULT_MAX_PIXELS, layout: str = "stacked",
            simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
            transparent: Colour | str | None = None, transparent_everywhere: bool = False,
            shading: str = "smooth") -> str:
    """Depixelize an image (``(H, W[, C])`` array, PIL image or :class:`PreparedImage`) → SVG text.

    ``scale`` sets the SVG's width/height as a multiple of the input's size (or ``width`` or
    ``height`` in pixels, the other following); the viewBox is in art pixels. ``stage``
    stops the pipeline early ("cells", "splines"; "splines" is the result without the §3.4
    optimization). ``precision`` is the number of decimals of the SVG's coordinates.
    ``layout`` is "stacked" (every shape continues under the shapes drawn above it) or
    "cutout" (shapes that tile the image); ``simplify`` is the tolerance in pixels within
    which fewer curves replace the exact spline (0: the exact spline; docs/svg.md).
    ``shading="smooth"`` blends the tones of each shaded region with a filter (paper §3.5,
    σ from ``params.shading_sigma``); ``"flat"`` draws them as flat bands.
    ``pixel_size``, ``denoise``, ``transparent`` and ``transparent_everywhere`` prepare the input first
    (:func:`depixel.prepare.inputs.prepare`, docs/inputs.md): upscaled art is converted at 1× and
    laid exactly over the input. Images over ``max_pixels`` pixels are refused (``None``:
    no limit).
    """
    prepared, scale = _prepare(image, params, stage, precision, background, scale, width, height, max_pixels,
                               layout=layout, simplify=simplify, pixel_size=pixel_size, denoise=denoise,
                               transparent=transparent, transparent_everywhere=transparent_everywhere)
    _check_page("svg", prepared, scale, width, height, "<image>")
    validate.choice("shading", shading, SHADINGS)
    vector = depixelize(prepared.rgba, params, stage=stage).vector  # the other stages' products are freed here
    svg = to_svg(vector, scale=scale, precision=precision, title=title, layout=layout, simplify=simplify,
                 shading=shading, sigma=SIGMA_RATIO * params.shading_sigma)
    return overlay_svg(svg, prepared, scale)


def prepare_input(image, *, background: Colour | str | None = None, pixel_size: PixelSize = AUTO,
                  denoise: bool | None = None, transparent: Colour | str | None = None,
                  transparent_everywhere: bool = False, lossy: str | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`depixel.prepare.inputs.prepare` after flattening over ``background`` (when given);
    a :class:`PreparedImage` is returned as it is. ``lossy`` names the lossy format the
    pixels came from ("JPEG"; a PIL image says so itself), which turns denoising on."""
    if isinstance(image, PreparedImage):
        return image
    colour = as_colour(background)
    validate.flag("transparent_everywhere", transparent_everywhere)
    _pixels(image, max_pixels=max_pixels)
    lossy = lossy or pil_lossy(image)
    rgba = as_rgba(image) if colour is None else flatten(image, colour)
    return prepare(rgba, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                   transparent_everywhere=transparent_everywhere, lossy=lossy)


def _prepare(image, params, stage, precision, background, scale, width, height, max_pixels,
             name: str = "<image>", layout: str = "stacked", simplify: float = DEFAULT_SIMPLIFY,
             pixel_size: PixelSize = AUTO, denoise: bool | None = None, transparent: Colour | str | None = None,
             lossy: str | None = None, transparent_everywhere: bool = False) -> tuple[PreparedImage, float]:
    """Check every argument of a conversion → the prepared 1× art and the scale to write at
    (relative to the input's size)."""
    if not isinstance(params, Params):
        raise ParameterError(f"params must be a depixel.Params, not {type(params).__name__}", parameter="params")
    check_output_options(stage, precision, layout, simplify)
    if not isinstance(image, PreparedImage):
        _pixels(image, name, max_pixels)
    prepared = prepare_input(image, background=background, pixel_size=pixel_size, denoise=denoise,
                             transparent=transparent, transparent_everywhere=transparent_everywhere, lossy=lossy,
                             max_pixels=None)
    w, h = prepared.input_size
    return prepared, _scale((h, w), scale, width, height)


def _check_page(fmt: str, prepared: PreparedImage, scale: float, width: int | None, height: int | None,
                name: str) -> None:
    """Refuse an SVG or PDF page readers cannot show (:func:`depixel.validate.page_size`),
    naming what set its size."""
    parameter = "width" if width is not None else "height" if height is not None else "scale"
    w, h = prepared.input_size
    validate.page_size(fmt, w * scale, h * scale, name, parameter)


def encode(svg: str, fmt: str = "svg", *, name: str = "<svg>", keywords: str | None = None) -> bytes:
    """SVG text → the bytes of an ``fmt`` file (SVG as UTF-8, PNG/PDF rendered at the SVG's size)."""
    validate.choice("format", fmt, FORMATS)
    if fmt == "svg":
        return svg.encode("utf-8")
    from .render.raster import render  # noqa: PLC0415 (cairosvg only when PNG/PDF is asked for)

    return render(svg, fmt, name=name, keywords=keywords)


def convert_bytes(image, fmt: str = "svg", params: Params = Params(), *, stage: str = "optimized",
                  scale: float = 1.0, background: Colour | str | None = None, title: str | None = None,
                  shading: str = "smooth", name: str = "<image>", precision: int = DEFAULT_PRECISION,
                  width: int | None = None, height: int | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS,
                  max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS, layout: str = "stacked",
                  simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                  transparent: Colour | str | None = None, transparent_everywhere: bool = False) -> bytes:
    """Like :func:`convert`, returning the bytes of an SVG, PNG or PDF file.

    ``shading="smooth"`` renders PNG output with the paper's smooth renderer and gives the
    SVG its smooth-shading filter; ``"flat"`` draws flat colour bands (the SVG without the
    filter; PNG that SVG rasterized). A PDF has the flat bands (cairosvg draws no filters).
    A PNG of more than ``max_output_pixels`` pixels is refused before it is rendered.
    """
    return conversion_bytes(image, fmt, params, stage=stage, scale=scale, background=background, title=title,
                            shading=shading, name=name, precision=precision, width=width, height=height,
                            max_pixels=max_pixels, max_output_pixels=max_output_pixels, layout=layout,
                            simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                            transparent_everywhere=transparent_everywhere)


def conversion_bytes(image, fmt, params, *, keywords: str | None = None, **options) -> bytes:
    """:func:`convert_bytes` with what a file conversion adds (:mod:`depixel.files.convert`): the
    ``lossy`` format the pixels came from, the PDF ``keywords`` (its options stamp) and a
    callback told what the preparation found (the options of :func:`conversions`)."""
    return conversions(image, {fmt: keywords}, params, **options)[fmt]


def conversions(image, formats: Mapping[str, str | None], params, *, stage, scale, background, title, shading, name,
                precision, width, height, max_pixels, max_output_pixels, layout, simplify, pixel_size=AUTO,
                denoise=None, transparent=None, transparent_everywhere=False, lossy=None,
                on_prepared: Callable[[PreparedImage], None] | None = None) -> dict[str, bytes]:
    """One conversion written in several formats, ``{format: its PDF keywords}`` → ``{format:
    bytes}``: the input is prepared and depixelized once, then each format is made from the
    same vector image (``depixel convert --format svg,png``)."""
    for fmt in formats:
        validate.choice("format", fmt, FORMATS)
    validate.choice("shading", shading, SHADINGS)
    max_output_pixels = validate.limit("max_output_pixels", max_output_pixels)
    prepared, scale = _prepare(image, params, stage, precision, background, scale, width, height, max_pixels, name,
                               layout, simplify, pixel_size, denoise, transparent, lossy, transparent_everywhere)
    if on_prepared is not None:
        on_prepared(prepared)
    if "png" in formats:
        size = max(1, round(prepared.input_size[0] * scale)), max(1, round(prepared.input_size[1] * scale))
        if max_output_pixels is not None and size[0] * size[1] > max_output_pixels:
            shown = validate.shown
            raise RenderError(f"{name}: a {shown(size[0])}x{shown(size[1])} PNG is {shown(size[0] * size[1])} "
                              f"pixels, over the limit of {max_output_pixels} (raise it with max_output_pixels)",
                              parameter="max_output_pixels")
    for fmt in formats:
        _check_page(fmt, prepared, scale, width, height, name)
    vector = depixelize(prepared.rgba, params, stage=stage).vector
    blobs: dict[str, bytes] = {}
    svgs: dict[str, str] = {}  # by shading: an SVG is smooth unless flat; PDF and a flat PNG are drawn flat
    for fmt, keywords in formats.items():
        if fmt == "png" and shading == "smooth":
            import io  # noqa: PLC0415

            from PIL import Image  # noqa: PLC0415

            from .render.shading import render_smooth  # noqa: PLC0415

            # rendered at the art's grid, then laid over the input like the SVG
            pixels = render_smooth(vector, scale * max(prepared.pixel_size), params=params)
            buffer = io.BytesIO()
            Image.fromarray(overlay_raster(pixels, prepared, scale), "RGBA").save(buffer, format="PNG")
            blobs[fmt] = buffer.getvalue()
        else:
            drawn = shading if fmt == "svg" else "flat"
            if drawn not in svgs:
                svgs[drawn] = overlay_svg(to_svg(vector, scale=scale, precision=precision, title=title, layout=layout,
                                                 simplify=simplify, shading=drawn,
                                                 sigma=SIGMA_RATIO * params.shading_sigma), prepared, scale)
            blobs[fmt] = encode(svgs[drawn], fmt, name=name, keywords=keywords)
    return blobs
