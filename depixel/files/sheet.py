"""A sprite sheet converted sprite by sprite → one SVG with a layer per sprite.

Each sprite is cut from the sheet and converted alone with :func:`depixel.convert` (so its
shapes never reach into a neighbour; their pipelines run together, some at a time, with the
bytes of each alone: :mod:`depixel.files.ahead`), then put back at its place as an Inkscape layer
(:mod:`depixel.svg.layers`). The sprites come from :mod:`depixel.prepare.sheet` (found on
the sheet, or a grid by size) or :mod:`depixel.prepare.sheet_json`.
"""
from __future__ import annotations

from collections.abc import Sequence

from ..api import convert
from ..errors import InputError, ParameterError
from ..limits import DEFAULT_MAX_PIXELS
from ..params import Params
from ..prepare.image import as_rgba
from ..prepare.sheet import Sprite
from ..svg.layers import Placed, compose_layers
from .ahead import converted_ahead


def convert_sheet(image, sprites: Sequence[Sprite], params: Params = Params(), *, scale: float = 1.0,
                  title: str | None = None, **convert_keywords) -> str:
    """Convert each of ``sprites`` (rectangles of ``image``, an array or PIL image of the
    sheet) alone → one SVG of the sheet's size, ``scale`` times, with one layer per sprite
    named after it. ``convert_keywords`` go to :func:`depixel.convert` for every sprite
    (``stage``, ``layout``, ``simplify``, ``shading``, ``max_pixels``…; not its size, which
    is the sheet's). The sprites' pixels in all count against ``max_pixels``."""
    for key in ("width", "height", "scale"):
        if key in convert_keywords:
            raise ParameterError(f"convert_sheet sizes the whole sheet: give scale, not {key} per sprite",
                                 parameter=key)
    rgba = as_rgba(image)
    height, width = rgba.shape[:2]
    if not sprites:
        raise ParameterError("convert_sheet: no sprites to convert", parameter="sprites")
    for sprite in sprites:
        if sprite.x < 0 or sprite.y < 0 or sprite.width < 1 or sprite.height < 1 or \
                sprite.x + sprite.width > width or sprite.y + sprite.height > height:
            raise ParameterError(f"sprite {sprite.name!r} at {sprite.x},{sprite.y} {sprite.width}x{sprite.height} "
                                 f"is not within the {width}x{height} sheet", parameter="sprites")
    max_pixels = convert_keywords.get("max_pixels", DEFAULT_MAX_PIXELS)
    total = sum(sprite.width * sprite.height for sprite in sprites)
    if max_pixels is not None and total > max_pixels:
        raise InputError(f"{len(sprites)} sprites are {total} pixels in all, over the limit of {max_pixels} "
                         "(the limit counts every sprite; raise it with max_pixels)", parameter="max_pixels")
    with converted_ahead([rgba[sprite.box] for sprite in sprites], params, **convert_keywords):  # one pass
        placed = [Placed(sprite.name, convert(rgba[sprite.box], params, **convert_keywords), sprite.x, sprite.y,
                         sprite.width, sprite.height) for sprite in sprites]
    return compose_layers(placed, width, height, scale=scale, title=title)
