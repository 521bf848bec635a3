"""Colours: the hqx YUV space the paper compares in, and the colour arguments users give.

The paper compares colours in YUV (§3.2, after hqx). Colours are converted once, to float64
on a 0-255 scale, with the hqx formula (documented in docs/colour.md)::

    Y =  0.299 R + 0.587 G + 0.114 B
    U = -0.169 R - 0.331 G + 0.500 B
    V =  0.500 R - 0.419 G - 0.081 B
"""
from __future__ import annotations

import numpy as np

from . import validate
from .errors import ParameterError

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


def as_colour(value: Colour | str | None) -> Colour | None:
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


_YUV_MATRIX = np.array(
    [[0.299, 0.587, 0.114], [-0.169, -0.331, 0.5], [0.5, -0.419, -0.081]], dtype=np.float64
)


def rgb_to_yuv(rgb: np.ndarray) -> np.ndarray:
    """hqx YUV of an ``(..., 3)`` RGB array on a 0-255 scale → ``(..., 3) float64``."""
    return rgb[..., :3].astype(np.float64) @ _YUV_MATRIX.T
