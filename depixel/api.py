"""Python API in memory: convert pixel art without the command line.

:func:`convert` takes an image (numpy array or PIL image) and returns SVG text;
:func:`convert_bytes` returns the bytes of an SVG, PNG or PDF file. PNG and PDF go through
cairosvg, which is imported only when one of them is asked for (:mod:`depixel.render.raster`).
File to file (:func:`~depixel.files.convert.convert_file`, :func:`~depixel.files.convert.render_file`)
is :mod:`depixel.files.convert`. The keyword functions make one
:class:`~depixel.options.ConvertOptions` of their keywords and pass it to :func:`conversions`.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping

import numpy as np

from . import validate
from .colour import Colour, as_colour
from .errors import ParameterError, RenderError, display_name
from .limits import DEFAULT_MAX_OUTPUT_PIXELS, DEFAULT_MAX_PIXELS
from .options import ConvertOptions, OutputOptions, PrepareOptions
from .params import Params
from .pipeline import depixelize
from .prepare.backdrop import over_colour
from .prepare.image import ImageSource, as_rgba, check_indexable, check_pixels, image_array, load_image
from .prepare.inputs import AUTO, PixelSize, PreparedImage, pil_lossy, prepare
from .render.overlay import overlay_raster, overlay_svg
from .svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY, SHADINGS, SIGMA_RATIO, to_svg

#: Output formats, chosen from the file extension or given explicitly.
FORMATS = ("svg", "png", "pdf")
__all__ = ["FORMATS", "SHADINGS", "conversions", "convert", "convert_bytes", "encode", "flatten", "load",
           "prepare_input", "prepared_input"]


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


def flatten(image, colour: Colour | str) -> np.ndarray:
    """Composite an image over an opaque colour → ``(H, W, 4) uint8`` with alpha 255.

    Useful before converting art whose semi-transparent edges should blend into a known
    background instead of becoming separate translucent shapes.
    """
    rgb = as_colour(colour)
    if rgb is None:
        raise ParameterError("background must be a colour name or an (r, g, b) triple, not None",
                             parameter="background")
    _pixels(image, max_pixels=None)
    return over_colour(as_rgba(image), rgb)


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
    options = ConvertOptions.build(params, stage=stage, scale=scale, background=background, precision=precision,
                                   width=width, height=height, max_pixels=max_pixels, layout=layout,
                                   simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                                   transparent_everywhere=transparent_everywhere, shading=shading)
    return conversions(image, {"svg": None}, options, title=title)["svg"].decode("utf-8")


def prepare_input(image, *, background: Colour | str | None = None, pixel_size: PixelSize = AUTO,
                  denoise: bool | None = None, transparent: Colour | str | None = None,
                  transparent_everywhere: bool = False, lossy: str | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`depixel.prepare.inputs.prepare` after flattening over ``background`` (when given);
    a :class:`PreparedImage` is returned as it is. ``lossy`` names the lossy format the
    pixels came from ("JPEG"; a PIL image says so itself), which turns denoising on."""
    options = PrepareOptions(background=background, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                             transparent_everywhere=transparent_everywhere)
    return prepared_input(image, options, lossy=lossy, max_pixels=max_pixels)


def prepared_input(image, options: PrepareOptions, *, lossy: str | None = None,
                   max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`prepare_input` with its options made: the image checked against ``max_pixels``
    (None: not checked), then prepared; a :class:`PreparedImage` is returned as it is."""
    if isinstance(image, PreparedImage):
        return image
    _pixels(image, max_pixels=max_pixels)
    return prepare(image, options, lossy=lossy or pil_lossy(image))


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
    options = ConvertOptions.build(params, stage=stage, scale=scale, background=background, shading=shading,
                                   precision=precision, width=width, height=height, max_pixels=max_pixels,
                                   max_output_pixels=max_output_pixels, layout=layout, simplify=simplify,
                                   pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                                   transparent_everywhere=transparent_everywhere)
    return conversions(image, {fmt: None}, options, name=name, title=title)[fmt]


def conversions(image, formats: Mapping[str, str | None], options: ConvertOptions, *, name: str = "<image>",
                title: str | None = None, lossy: str | None = None,
                on_prepared: Callable[[PreparedImage], None] | None = None) -> dict[str, bytes]:
    """One conversion written in several formats, ``{format: its PDF keywords}`` → ``{format:
    bytes}``: the input is prepared and depixelized once, then each format is made from the
    same vector image (``depixel convert --format svg,png``). ``name`` names the image in
    messages, ``title`` is the SVG's title, ``lossy`` the lossy format the pixels came from
    (:func:`prepared_input`); ``on_prepared`` is told what the preparation found."""
    for fmt in formats:
        validate.choice("format", fmt, FORMATS)
    params, output, limits = options.params, options.output, options.limits
    if not isinstance(image, PreparedImage):
        _pixels(image, name, limits.max_pixels)
    prepared = prepared_input(image, options.prepare, lossy=lossy, max_pixels=None)
    scale = output.scale_for(*prepared.input_size)
    if on_prepared is not None:
        on_prepared(prepared)
    if "png" in formats:
        _check_png_size(prepared, scale, limits.max_output_pixels, name)
    for fmt in formats:
        _check_page(fmt, prepared, scale, output, name)
    vector = depixelize(prepared.rgba, params, stage=output.stage).vector  # the other stages' products are freed
    blobs: dict[str, bytes] = {}
    svgs: dict[str, str] = {}  # by shading: an SVG is smooth unless flat; PDF and a flat PNG are drawn flat
    for fmt, keywords in formats.items():
        if fmt == "png" and output.shading == "smooth":
            import io  # noqa: PLC0415

            from PIL import Image  # noqa: PLC0415

            from .render.shading import render_smooth  # noqa: PLC0415

            # rendered at the art's grid, then laid over the input like the SVG
            pixels = render_smooth(vector, scale * max(prepared.pixel_size), params=params)
            buffer = io.BytesIO()
            Image.fromarray(overlay_raster(pixels, prepared, scale), "RGBA").save(buffer, format="PNG")
            blobs[fmt] = buffer.getvalue()
        else:
            drawn = output.shading if fmt == "svg" else "flat"
            if drawn not in svgs:
                svg = to_svg(vector, scale=scale, precision=output.precision, title=title, layout=output.layout,
                             simplify=output.simplify, shading=drawn, sigma=SIGMA_RATIO * params.shading_sigma)
                svgs[drawn] = overlay_svg(svg, prepared, scale)
            blobs[fmt] = encode(svgs[drawn], fmt, name=name, keywords=keywords)
    return blobs


def _check_png_size(prepared: PreparedImage, scale: float, max_output_pixels: int | None, name: str) -> None:
    """Refuse a PNG of more than ``max_output_pixels`` pixels before it is rendered."""
    width, height = (max(1, round(side * scale)) for side in prepared.input_size)
    if max_output_pixels is not None and width * height > max_output_pixels:
        shown = validate.shown
        raise RenderError(f"{name}: a {shown(width)}x{shown(height)} PNG is {shown(width * height)} pixels, over "
                          f"the limit of {max_output_pixels} (raise it with max_output_pixels)",
                          parameter="max_output_pixels")


def _check_page(fmt: str, prepared: PreparedImage, scale: float, output: OutputOptions, name: str) -> None:
    """Refuse an SVG or PDF page readers cannot show (:func:`depixel.validate.page_size`),
    naming what set its size."""
    w, h = prepared.input_size
    validate.page_size(fmt, w * scale, h * scale, name, output.size_parameter)
