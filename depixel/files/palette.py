"""Palettes of files: an Aseprite input's own palette names its swatches, and the colours of
a conversion written as a GIMP palette (``--export-palette``, docs/palettes.md).
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import display_name
from ..options import ConvertOptions
from ..prepare.animation import read_animation
from ..prepare.image import ImageSource, Pixels, load_image, read_source
from ..prepare.inputs import lossy_format
from ..svg.swatches import Style, shared_names
from .output import write_atomic

if TYPE_CHECKING:
    from ..prepare.gpl import Palette


def with_input_palette(options: ConvertOptions, data: bytes, name: str = "<input>") -> ConvertOptions:
    """``options`` with the palette of an Aseprite input (``data``) naming the swatches when
    there are swatches and no palette does (its bytes' identity is in the stamp: nothing
    else to digest). The Aseprite and GIMP palette modules load only then: a plain conversion,
    the usual one, does not pay for them."""
    if not options.output.swatches or options.output.palette is not None:
        return options
    from ..prepare.aseprite_format import is_aseprite, parse_aseprite  # noqa: PLC0415
    from ..prepare.gpl import Palette  # noqa: PLC0415

    if not is_aseprite(data):
        return options

    entries = parse_aseprite(data, name, options.limits.max_pixels).palette
    palette = Palette(entries, alpha=any(entry.rgba[3] != 255 for entry in entries))
    return replace(options, output=replace(options.output, palette=palette))


def palette_of(image: Pixels, options: ConvertOptions = ConvertOptions(), *, title: str | None = None,
               lossy: str | None = None) -> Palette:
    """The colours a conversion of ``image`` (pixels) with ``options`` fills its shapes with
    (its palette map applied), in the order and with the names of its swatches
    (:mod:`depixel.svg.swatches`)."""
    return file_palette([image], options, title=title, lossy=lossy)


def file_palette(images: Sequence[Pixels], options: ConvertOptions = ConvertOptions(), *,
                 title: str | None = None, lossy: str | None = None) -> Palette:
    """:func:`palette_of` several images converted into one file (an animation's frames, a
    sheet's sprites), whose swatches are named from the colours of all."""
    from ..api import prepared_input  # noqa: PLC0415

    limit, output = options.limits.max_pixels, options.output
    pixels = [prepared_input(image, options.prepare, lossy=lossy, max_pixels=limit).rgba for image in images]
    return shared_names(pixels, Style(palette=output.palette, palette_map=output.palette_map), title)


def export_palette(source: ImageSource, output: str | os.PathLike, options: ConvertOptions = ConvertOptions(),
                   *, frame: int = 0) -> Path:
    """Write the palette of a conversion of image file ``source`` (frame ``frame``; every frame
    with ``animate``, every sprite with a sheet: the file's swatches) with ``options``
    (:func:`palette_of`) as a GIMP palette file ``output``, atomically."""
    path = Path(source) if isinstance(source, (str, os.PathLike)) else None
    name = "<input>" if path is None else display_name(path)
    data = read_source(source)
    options = with_input_palette(options, data, name)
    limits, out = options.limits, options.output
    images: list[np.ndarray]
    if out.animate:
        images = list(read_animation(data, limits.max_pixels, max_frames=limits.max_frames, name=name).frames)
    else:
        images = [load_image(data, limits.max_pixels, frame, max_frames=limits.max_frames, name=name)]
    if out.is_sheet:
        from ..prepare.sheet import sheet_of  # noqa: PLC0415

        images = [images[0][sprite.box] for sprite in sheet_of(images[0], out.sheet, out.sheet_json, name).sprites]
    palette = file_palette(images, options, title=None if path is None else path.stem, lossy=lossy_format(data))
    protect = () if path is None else (path,)
    from ..prepare.gpl import format_gpl  # noqa: PLC0415

    write_atomic(output, format_gpl(palette), protect=protect)
    return Path(output)
