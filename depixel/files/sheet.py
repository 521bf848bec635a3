"""A sprite sheet converted sprite by sprite → one SVG with a layer per sprite, of sprites
given by the caller.

:func:`depixel.convert` with ``sheet=`` or ``sheet_json=`` finds the sprites itself
(:func:`depixel.api.cut_sheet`); :func:`convert_sheet` takes them as made by hand or by
:mod:`depixel.prepare.sheet` and :mod:`depixel.prepare.sheet_json`. Each sprite is cut from
the sheet and converted alone (so its shapes never reach into a neighbour), then put back at
its place as an Inkscape layer (:func:`depixel.api.sheet_conversions`,
:mod:`depixel.svg.layers`).
"""
from __future__ import annotations

from collections.abc import Sequence

from ..api import sheet_conversions
from ..errors import ParameterError
from ..options import ConvertOptions
from ..params import Params
from ..prepare.image import as_rgba
from ..prepare.sheet import Sheet, Sprite


def convert_sheet(image, sprites: Sequence[Sprite], params: Params = Params(), *, scale: float = 1.0,
                  title: str | None = None, **convert_keywords) -> str:
    """Convert each of ``sprites`` (rectangles of ``image``, an array or PIL image of the
    sheet) alone → one SVG of the sheet's size, ``scale`` times, with one layer per sprite
    named after it. ``convert_keywords`` are :func:`depixel.convert`'s for every sprite
    (``stage``, ``layout``, ``simplify``, ``shading``, ``max_pixels``…; ``width`` and
    ``height`` size the whole sheet). The sprites count against ``max_frames`` and, in all,
    ``max_pixels``."""
    for key in ("sheet", "sheet_json"):
        if key in convert_keywords:
            raise ParameterError(f"convert_sheet takes the sprites and sizes the whole sheet: no {key}",
                                 parameter=key)
    options = ConvertOptions.build(params, scale=scale, **convert_keywords)
    rgba = as_rgba(image)
    height, width = rgba.shape[:2]
    if not sprites:
        raise ParameterError("convert_sheet: no sprites to convert", parameter="sprites")
    for sprite in sprites:
        if sprite.x < 0 or sprite.y < 0 or sprite.width < 1 or sprite.height < 1 or \
                sprite.x + sprite.width > width or sprite.y + sprite.height > height:
            raise ParameterError(f"sprite {sprite.name!r} at {sprite.x},{sprite.y} {sprite.width}x{sprite.height} "
                                 f"is not within the {width}x{height} sheet", parameter="sprites")
    sheet = Sheet(tuple(sprites), None, None, f"{len(sprites)} sprites given")
    return sheet_conversions(rgba, sheet, {"svg": None}, options, title=title)["svg"].decode("utf-8")
