"""Python API in memory: convert pixel art without the command line.

:func:`convert` takes an image (numpy array or PIL image) and returns SVG text;
:func:`convert_bytes` returns the bytes of an SVG, PNG, PDF or EPS file; with ``animate=True`` both
take an :class:`~depixel.prepare.animation.Animation` too
(:func:`~depixel.render.animation.animated`). PNG, PDF and EPS go through cairosvg, which is
imported only when one of them is asked for (:mod:`depixel.render.raster`).
File to file (:func:`~depixel.files.convert.convert_file`, :func:`~depixel.files.convert.render_file`)
is :mod:`depixel.files.convert`. The keyword functions make one
:class:`~depixel.options.ConvertOptions` of their keywords and pass it to :func:`conversions`.
A sprite sheet (``sheet=`` or ``sheet_json=``) is cut into its sprites (:func:`cut_sheet`), each
converted alone and put back at its place (:func:`sheet_conversions`).
"""
from __future__ import annotations

import io
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from . import validate
from .colour import Colour
from .errors import ParameterError
from .limits import (
    DEFAULT_MAX_FRAMES,
    DEFAULT_MAX_OUTPUT_PIXELS,
    DEFAULT_MAX_PIXELS,
    check_frames_pixels,
    check_sprites,
)
from .options import ConvertOptions, OutputOptions, PrepareOptions
from .params import Params
from .pipeline import ahead, depixelize
from .prepare.animation import Animation
from .prepare.image import Pixels, as_rgba, check_pixels_given
from .prepare.inputs import AUTO, PixelSize, PreparedImage, flatten, load, pil_lossy, prepare
from .render.overlay import overlay_raster, overlay_svg
from .svg.swatches import Style
from .svg.writer import DEFAULT_PRECISION, DEFAULT_SIMPLIFY, SHADINGS, SIGMA_RATIO, to_svg

if TYPE_CHECKING:  # a sheet's modules are imported when a sheet is converted (~10 ms of every start)
    from .prepare.gpl import PaletteMapSource, PaletteSource
    from .prepare.sheet import Sheet
    from .prepare.sheet_json import SheetJson

#: Output formats, chosen from the file extension or given explicitly.
FORMATS = ("svg", "png", "pdf", "eps")
__all__ = ["FORMATS", "SHADINGS", "conversions", "convert", "convert_bytes", "cut_sheet", "encode",
           "flatten", "load", "prepare_input", "prepared_input", "sheet_conversions"]


def convert(image: Pixels | PreparedImage, params: Params = Params(), *, stage: str = "optimized", scale: float = 1.0,
            background: Colour | str | None = None, title: str | None = None, precision: int = DEFAULT_PRECISION,
            width: int | None = None, height: int | None = None,
            max_pixels: int | None = DEFAULT_MAX_PIXELS, layout: str = "stacked",
            simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
            transparent: Colour | str | None = None, transparent_everywhere: bool = False,
            shading: str = "smooth", animate: bool = False, sheet: str | None = None,
            sheet_json: SheetJson | str | None = None, max_frames: int | None = DEFAULT_MAX_FRAMES,
            tag: str | None = None, swatches: bool = False, palette: PaletteSource | None = None,
            palette_map: PaletteMapSource | None = None) -> str:
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
    ``swatches`` makes every colour an Inkscape swatch, named from ``palette`` (a ``.gpl``
    or ``.aseprite`` file, or a :class:`~depixel.prepare.gpl.Palette`); ``palette_map``
    (``"FROM.gpl:TO.gpl"``, a pair of palettes or a :class:`~depixel.prepare.gpl.PaletteMap`)
    swaps the colours of the output, the shapes staying those of the art's own colours
    (docs/palettes.md).
    ``pixel_size``, ``denoise``, ``transparent`` and ``transparent_everywhere`` prepare the input first
    (:func:`depixel.prepare.inputs.prepare`, docs/inputs.md): upscaled art is converted at 1× and
    laid exactly over the input. Images over ``max_pixels`` pixels are refused (``None``:
    no limit; an animation's frames count in all). ``animate=True`` converts an
    :class:`~depixel.prepare.animation.Animation` (:func:`depixel.read_animation`) into one
    animated SVG, a layer a frame (docs/animation.md); a still image is its one frame;
    ``tag`` plays one tag of an Aseprite file's animation (:meth:`Animation.tagged`).
    ``sheet`` ("auto", or a grid "32x32+2@1,1") or ``sheet_json`` (the path,
    bytes or decoded object of an Aseprite or TexturePacker JSON) take the image as a sprite
    sheet: each sprite is converted alone and is one layer of the SVG, at its place
    (:func:`cut_sheet`; its sprites count against ``max_frames`` and, in all, ``max_pixels``).
    """
    options = ConvertOptions.build(params, stage=stage, scale=scale, background=background, precision=precision,
                                   width=width, height=height, max_pixels=max_pixels, layout=layout,
                                   simplify=simplify, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                                   transparent_everywhere=transparent_everywhere, shading=shading, animate=animate,
                                   sheet=sheet, sheet_json=sheet_json, max_frames=max_frames, tag=tag,
                                   swatches=swatches, palette=palette, palette_map=palette_map)
    return conversions(image, {"svg": None}, options, title=title)["svg"].decode("utf-8")


def prepare_input(image: Pixels | PreparedImage, *, background: Colour | str | None = None,
                  pixel_size: PixelSize = AUTO, denoise: bool | None = None, transparent: Colour | str | None = None,
                  transparent_everywhere: bool = False, lossy: str | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`depixel.prepare.inputs.prepare` after flattening over ``background`` (when given);
    a :class:`PreparedImage` is returned as it is. ``lossy`` names the lossy format the
    pixels came from ("JPEG"; a PIL image says so itself), which turns denoising on."""
    options = PrepareOptions(background=background, pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                             transparent_everywhere=transparent_everywhere)
    return prepared_input(image, options, lossy=lossy, max_pixels=max_pixels)


def prepared_input(image: Pixels | PreparedImage, options: PrepareOptions, *, lossy: str | None = None,
                   max_pixels: int | None = DEFAULT_MAX_PIXELS) -> PreparedImage:
    """:func:`prepare_input` with its options made: the image checked against ``max_pixels``
    (None: not checked), then prepared; a :class:`PreparedImage` is returned as it is."""
    if isinstance(image, PreparedImage):
        return image
    check_pixels_given(image, max_pixels=max_pixels)
    return prepare(image, options, lossy=lossy or pil_lossy(image))


def encode(svg: str, fmt: str = "svg", *, name: str = "<svg>", keywords: str | None = None) -> bytes:
    """SVG text → the bytes of an ``fmt`` file (SVG as UTF-8, PNG/PDF rendered at the SVG's size)."""
    validate.choice("format", fmt, FORMATS)
    if fmt == "svg":
        return svg.encode("utf-8")
    from .render.raster import render  # noqa: PLC0415 (cairosvg only when PNG/PDF is asked for)

    return render(svg, fmt, name=name, keywords=keywords)


def convert_bytes(image: Pixels | PreparedImage, fmt: str = "svg", params: Params = Params(), *,
                  stage: str = "optimized", scale: float = 1.0, background: Colour | str | None = None,
                  title: str | None = None, shading: str = "smooth", name: str = "<image>",
                  precision: int = DEFAULT_PRECISION, width: int | None = None, height: int | None = None,
                  max_pixels: int | None = DEFAULT_MAX_PIXELS,
                  max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS, layout: str = "stacked",
                  simplify: float = DEFAULT_SIMPLIFY, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
                  transparent: Colour | str | None = None, transparent_everywhere: bool = False,
                  animate: bool = False, sheet: str | None = None, sheet_json: SheetJson | str | None = None,
                  max_frames: int | None = DEFAULT_MAX_FRAMES, tag: str | None = None, swatches: bool = False,
                  palette: PaletteSource | None = None, palette_map: PaletteMapSource | None = None) -> bytes:
    """Like :func:`convert`, returning the bytes of an SVG, PNG, PDF or EPS file.

    ``shading="smooth"`` renders PNG output with the paper's smooth renderer and gives the
    SVG its smooth-shading filter; ``"flat"`` draws flat colour bands (the SVG without the
    filter; PNG that SVG rasterized). A PDF or EPS has the flat bands (cairosvg draws no filters).
    A PNG of more than ``max_output_pixels`` pixels is refused before it is rendered.
    ``animate=True``: an animation's SVG, or its PNG as an animated PNG (APNG) of the frames'
    renders (their pixels in all within ``max_output_pixels``); no PDF or EPS; ``tag``: one
    tag's, as :func:`convert`. A sheet's PNG is each sprite's PNG at its place.
    """
    options = ConvertOptions.build(params, stage=stage, scale=scale, background=background, shading=shading,
                                   precision=precision, width=width, height=height, max_pixels=max_pixels,
                                   max_output_pixels=max_output_pixels, layout=layout, simplify=simplify,
                                   pixel_size=pixel_size, denoise=denoise, transparent=transparent,
                                   transparent_everywhere=transparent_everywhere, animate=animate, sheet=sheet,
                                   sheet_json=sheet_json, max_frames=max_frames, tag=tag, swatches=swatches,
                                   palette=palette, palette_map=palette_map)
    return conversions(image, {fmt: None}, options, name=name, title=title)[fmt]


def conversions(image: Pixels | PreparedImage | Animation, formats: Mapping[str, str | None],
                options: ConvertOptions, *, name: str = "<image>", title: str | None = None,
                lossy: str | None = None,
                on_prepared: Callable[[PreparedImage], None] | None = None) -> dict[str, bytes]:
    """One conversion written in several formats, ``{format: its PDF keywords}`` → ``{format:
    bytes}``: the input is prepared and depixelized once, then each format is made from the
    same vector image (``depixel convert --format svg,png``). ``name`` names the image in
    messages, ``title`` is the SVG's title, ``lossy`` the lossy format the pixels came from
    (:func:`prepared_input`); ``on_prepared`` is told what the preparation found. With
    ``options.output.animate``, ``image`` may be an :class:`Animation`: each format holds
    every frame (:func:`~depixel.render.animation.animated`); an animation of one frame, or a still, is that frame.
    With ``options.output.tag``, the Animation's tag is played (:meth:`Animation.tagged`)."""
    for fmt in formats:
        validate.choice("format", fmt, FORMATS)
        options.output.check_format(fmt)
    if options.output.tag is not None:
        if not isinstance(image, Animation):
            raise ParameterError("tag plays a tag of an Aseprite file: give the Animation depixel.read_animation(path) "
                                 "reads (it holds the file's tags)", parameter="tag")
        image = image.tagged(options.output.tag, name=name)
    if isinstance(image, Animation):
        if not options.output.animate:
            raise ParameterError("an Animation is converted whole with animate=True (or convert one of its "
                                 "frames, animation.frames[0])", parameter="animate")
        if len(image.frames) > 1:
            from .render.animation import animated  # noqa: PLC0415

            still = replace(options, output=replace(options.output, animate=False, tag=None))
            frames: dict[bytes, PreparedImage] = {}  # with --swatches: prepared first, named from all
            if options.output.swatches and "svg" in formats:
                n, (height, width) = len(image.frames), image.frames[0].shape[:2]
                check_frames_pixels(name, n, n * width * height, options.limits.max_pixels)
                for frame in image.frames:
                    if (key := frame.tobytes()) not in frames:
                        frames[key] = prepared_input(frame, options.prepare, lossy=lossy, max_pixels=None)
                still = _named_alike(list(frames.values()), still)

            def convert_frame(frame: np.ndarray, made: dict[str, None]) -> dict[str, bytes]:
                return conversions(frames.get(frame.tobytes(), frame), made, still, name=name, title=title,
                                   lossy=lossy, on_prepared=on_prepared)

            with _in_passes(image.frames, still, formats, lossy):  # the frames' pipelines together
                return animated(image, formats, options, convert_frame, name=name)
        image = image.frames[0]
    elif options.output.animate and int(getattr(image, "n_frames", 1)) > 1:
        raise ParameterError("a PIL image is one frame: read an animated file with depixel.read_animation(path) "
                             "(Pillow composites some GIF and APNG frames otherwise than browsers)",
                             parameter="image")
    params, output, limits = options.params, options.output, options.limits
    if not isinstance(image, PreparedImage):
        check_pixels_given(image, name, limits.max_pixels)
    if output.is_sheet:
        if isinstance(image, PreparedImage):
            raise ParameterError("a sheet is cut from its pixels: give the image, not a PreparedImage",
                                 parameter="sheet")
        from .prepare.sheet import sheet_of  # noqa: PLC0415 (~10 ms of imports: only for a sheet)

        rgba = as_rgba(image)
        sheet = sheet_of(rgba, output.sheet, output.sheet_json, name)
        return sheet_conversions(rgba, sheet, formats, options, name=name, title=title,
                                 lossy=lossy or pil_lossy(image), on_prepared=on_prepared)
    prepared = prepared_input(image, options.prepare, lossy=lossy, max_pixels=None)
    scale = output.scale_for(*prepared.input_size)
    if on_prepared is not None:
        on_prepared(prepared)
    if "png" in formats:
        validate.png_size(prepared.input_size, scale, limits.max_output_pixels, name)
    for fmt in formats:
        _check_page(fmt, prepared.input_size, scale, output, name)
    if "eps" in formats:
        validate.opaque(name, prepared.rgba, output.palette_map)
    vector = depixelize(prepared.rgba, params, stage=output.stage).vector  # the other stages' products are freed
    style = Style(SIGMA_RATIO * params.shading_sigma, output.swatches, output.palette, output.palette_map)
    blobs: dict[str, bytes] = {}
    svgs: dict[tuple[str, bool], str] = {}  # by shading and swatches: PDF, EPS and a flat PNG are drawn flat
    for fmt, keywords in formats.items():
        if fmt == "png" and output.shading == "smooth":
            from PIL import Image  # noqa: PLC0415

            from .render.shading import render_smooth  # noqa: PLC0415

            # rendered at the art's grid, then laid over the input like the SVG
            swapped = None if output.palette_map is None else output.palette_map.apply(vector.rgba)
            pixels = render_smooth(vector, scale * max(prepared.pixel_size), params=params, colours=swapped)
            buffer = io.BytesIO()
            Image.fromarray(overlay_raster(pixels, prepared, scale), "RGBA").save(buffer, format="PNG")
            blobs[fmt] = buffer.getvalue()
        else:
            drawn = (output.shading, output.swatches) if fmt == "svg" else ("flat", False)  # swatches: SVG only
            if drawn not in svgs:
                svg = to_svg(vector, scale=scale, precision=output.precision, title=title, layout=output.layout,
                             simplify=output.simplify, shading=drawn[0], style=replace(style, swatches=drawn[1]))
                svgs[drawn] = overlay_svg(svg, prepared, scale)
            blobs[fmt] = encode(svgs[drawn], fmt, name=name, keywords=keywords)
    return blobs


def cut_sheet(image: Pixels, sheet: str | None = None, *, sheet_json: SheetJson | str | None = None,
              max_pixels: int | None = DEFAULT_MAX_PIXELS, name: str = "<image>") -> Sheet:
    """The sprites of a sprite sheet (an array or PIL image, checked against ``max_pixels``):
    found on it (``sheet="auto"``, the default without ``sheet_json``: cells between gutters of
    transparency or of one background colour, else the boxes of connected sprites), a grid
    by cell size (``"32x32"``, ``"32x32+2"``, ``"32x32+2,4@1,1"``: gutters, first corner),
    or those an Aseprite or TexturePacker JSON file places (``sheet_json``: its path, bytes
    or decoded object). A :class:`~depixel.prepare.sheet.Sheet`: ``sprites`` (each ``name``,
    ``x``, ``y``, ``width``, ``height``, ``box``: ``rgba[sprite.box]`` is its crop), and one
    line that says what was found, ``description``."""
    check_pixels_given(image, name, validate.limit("max_pixels", max_pixels))
    output = OutputOptions(sheet=sheet if sheet is not None or sheet_json is not None else "auto",
                           sheet_json=sheet_json)
    from .prepare.sheet import sheet_of  # noqa: PLC0415

    return sheet_of(as_rgba(image), output.sheet, output.sheet_json, name)


def sheet_conversions(rgba: np.ndarray, sheet: Sheet, formats: Mapping[str, str | None], options: ConvertOptions,
                      *, name: str = "<image>", title: str | None = None, lossy: str | None = None,
                      on_prepared: Callable[[PreparedImage], None] | None = None) -> dict[str, bytes]:
    """:func:`conversions` of a sprite sheet: each of ``sheet``'s sprites converted alone, its
    crop prepared and depixelized on its own (its shapes never reach into a neighbour), and
    put back at its place. The SVG holds one Inkscape layer per sprite
    (:func:`depixel.svg.layers.compose_layers`; with swatches, one set named from all the
    sprites' colours), the PDF and EPS the same drawn flat, the PNG each sprite's PNG at its
    place. The sheet's size sets the scale (``options.output``); its sprites count against
    ``max_frames`` and, in all, ``max_pixels``."""
    from .render.raster import paste_pngs  # noqa: PLC0415
    from .svg.layers import Placed, compose_layers  # noqa: PLC0415

    output, limits = options.output, options.limits
    height, width = rgba.shape[:2]
    check_sprites(name, len(sheet.sprites), sum(s.width * s.height for s in sheet.sprites), limits.max_pixels,
                  limits.max_frames)
    scale = output.scale_for(width, height)
    if "png" in formats:
        validate.png_size((width, height), scale, limits.max_output_pixels, name)
    for fmt in formats:
        _check_page(fmt, (width, height), scale, output, name)
    alone = replace(options, output=replace(output, scale=scale, width=None, height=None, sheet=None,
                                            sheet_json=None))
    prepared = [prepared_input(rgba[sprite.box], options.prepare, lossy=lossy, max_pixels=None)
                for sprite in sheet.sprites]
    for sprite, image in zip(sheet.sprites, prepared) if "eps" in formats else ():
        validate.opaque(f"{name} sprite {sprite.name}", image.rgba, output.palette_map)
    if output.swatches and "svg" in formats:
        alone = _named_alike(prepared, alone)
    runs: dict[tuple[str, bool], dict[str, None]] = {}  # by how the SVG is drawn: the formats of one run
    for fmt in formats:
        runs.setdefault(_drawn(fmt, output), {})["png" if fmt == "png" else "svg"] = None
    layers: dict[tuple[str, bool], list[Placed]] = {drawn: [] for drawn in runs}
    pngs: list[tuple[int, int, bytes]] = []
    with _in_passes(prepared, alone, formats, lossy):  # the sprites' pipelines together
        for sprite, image in zip(sheet.sprites, prepared):
            for n, (drawn, made) in enumerate(runs.items()):
                drawing = replace(alone, output=replace(alone.output, shading=drawn[0], swatches=drawn[1]))
                blobs = conversions(image, made, drawing, name=f"{name} sprite {sprite.name}",
                                    on_prepared=None if n else on_prepared)
                if "svg" in blobs:
                    svg = blobs["svg"].decode("utf-8")
                    layers[drawn].append(Placed(sprite.name, svg, sprite.x, sprite.y, sprite.width, sprite.height))
                if "png" in blobs:
                    pngs.append((round(sprite.x * scale), round(sprite.y * scale), blobs["png"]))
    done: dict[str, bytes] = {}
    for fmt, keywords in formats.items():
        if fmt == "png":
            done[fmt] = paste_pngs(pngs, (max(1, round(width * scale)), max(1, round(height * scale))))
        else:
            svg = compose_layers(layers[_drawn(fmt, output)], width, height, scale=scale, title=title,
                                 precision=output.precision)
            done[fmt] = encode(svg, fmt, name=name, keywords=keywords)
    return done


def _drawn(fmt: str, output: OutputOptions) -> tuple[str, bool]:
    """How a format's SVG is drawn, (shading, swatches): a PDF or EPS flat, without swatches
    (a PNG ignores them: it shares the SVG's run)."""
    return ("flat", False) if fmt in ("pdf", "eps") else (output.shading, output.swatches)


def _named_alike(prepared: Sequence[PreparedImage], options: ConvertOptions) -> ConvertOptions:
    """``options`` naming the swatches of one file's documents (an animation's frames, a sheet's
    sprites: ``prepared``) from the colours of all: one colour, one swatch id in all of them."""
    from .svg.swatches import shared_names  # noqa: PLC0415

    output = options.output
    names = shared_names([p.rgba for p in prepared], Style(palette=output.palette, palette_map=output.palette_map))
    return replace(options, output=replace(output, palette=names))


def _in_passes(images, options: ConvertOptions, formats: Iterable[str], lossy: str | None) -> ExitStack:
    """:func:`passes` of ``images`` prepared as :func:`conversions` will prepare each (an image
    that cannot be prepared is left to its conversion, which reports it)."""
    prepared = []
    for image in images:
        try:
            prepared.append(prepared_input(image, options.prepare, lossy=lossy, max_pixels=None).rgba)
        except Exception:  # its conversion reports it
            continue
    return passes(prepared, options, formats)


def passes(prepared: Sequence[np.ndarray], options: ConvertOptions, formats: Iterable[str]) -> ExitStack:
    """Within it, the conversions of the ``prepared`` pixels with these options run their
    pipelines together, some at a time (:func:`depixel.pipeline.ahead`), and, where one of
    ``formats`` is drawn from the SVG, simplify their outlines together
    (:func:`depixel.svg.passes.shapes_ahead`): each output the bytes it has alone (a batch's
    files, a sheet's sprites, an animation's frames)."""
    from .svg.passes import shapes_ahead  # noqa: PLC0415

    stack = ExitStack()
    output = options.output
    then = None
    if any(fmt != "png" or output.shading == "flat" for fmt in formats):  # (a smooth PNG is no SVG)
        then = stack.enter_context(shapes_ahead(output.layout, 10.0**-output.precision, output.simplify))
    stack.enter_context(ahead(prepared, options.params, output.stage, then=then))
    return stack


def _check_page(fmt: str, size: tuple[int, int], scale: float, output: OutputOptions, name: str) -> None:
    """Refuse an SVG, PDF or EPS page readers cannot show (:func:`depixel.validate.page_size`),
    naming what set its size."""
    w, h = size
    validate.page_size(fmt, w * scale, h * scale, name, output.size_parameter)
