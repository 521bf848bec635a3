"""Regions ``diff`` ignores: rectangles, or an image of them (``--mask``).

A rectangle ``X,Y,W,H`` is in the pixels of the comparison at scale 1 (a raster's own
pixels, an SVG's width/height), so it covers the same part of the art at every
``--scale``; it is widened to whole pixels. A mask image is stretched to the comparison
size by nearest neighbour (it must have the same aspect ratio, within a pixel); its light
pixels (brightness over half, transparency counting as black) are ignored, its dark and
transparent ones compared. Ignored pixels count neither as different nor in the ratio.
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError, display_name
from ..limits import DEFAULT_MAX_DIFF_PIXELS

Rectangle = tuple[float, float, float, float]  # x, y, width, height


@dataclass(frozen=True)
class Mask:
    """What to ignore: rectangles and/or an image (its name and bytes)."""

    rectangles: tuple[Rectangle, ...] = ()
    image: bytes | None = None
    image_name: str = ""

    def __bool__(self) -> bool:
        return bool(self.rectangles) or self.image is not None


_NUMBER = r"\s*(\d+(?:\.\d*)?|\.\d+)\s*"


def parse_rectangle(text: str) -> Rectangle:
    """``"X,Y,W,H"`` (non-negative numbers, W and H over 0) → a rectangle."""
    match = re.fullmatch(",".join([_NUMBER] * 4), text)
    if not match:
        raise ParameterError(f"mask rectangle {text!r}: expected X,Y,W,H (non-negative numbers)")
    x, y, w, h = (float(v) for v in match.groups())
    if not (w > 0 and h > 0) or not all(math.isfinite(v) for v in (x, y, w, h)):
        raise ParameterError(f"mask rectangle {text!r}: its width and height must be over 0")
    return x, y, w, h


def read_mask_image(path: str | os.PathLike) -> Mask:
    """A mask image, read (decoded when it is used)."""
    from ..prepare.image import read_source  # noqa: PLC0415

    return Mask(image=read_source(path), image_name=display_name(path))


def ignored(mask: Mask, width: int, height: int, scale: float,
            max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> np.ndarray | None:
    """``(height, width)`` bool: the pixels of a comparison at ``scale`` that ``mask``
    ignores; None when it ignores nothing."""
    if not mask:
        return None
    out = np.zeros((height, width), dtype=bool)
    for x, y, w, h in mask.rectangles:
        c0, r0 = math.floor(x * scale), math.floor(y * scale)
        c1, r1 = math.ceil((x + w) * scale), math.ceil((y + h) * scale)
        out[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = True
    if mask.image is not None:
        out |= _image_mask(mask, width, height, max_pixels)
    return out if out.any() else None


def _image_mask(mask: Mask, width: int, height: int, max_pixels: int | None) -> np.ndarray:
    from PIL import Image  # noqa: PLC0415

    from ..prepare.image import load_image  # noqa: PLC0415

    assert mask.image is not None
    rgba = load_image(mask.image, max_pixels=max_pixels)
    h, w = rgba.shape[:2]
    if abs(width * h / w - height) > 1.0:
        raise InputError(f"mask {mask.image_name}: {w}x{h} does not have the shape of the {width}x{height} "
                         "comparison")
    light = np.zeros((h, w), dtype=bool)
    for r in range(0, h, 256):
        band = rgba[r : r + 256].astype(np.float64)
        y = band[..., 0] * 0.299 + band[..., 1] * 0.587 + band[..., 2] * 0.114
        light[r : r + 256] = y * band[..., 3] / 255.0 > 127.5
    if (w, h) == (width, height):
        return light
    return np.asarray(Image.fromarray(light).resize((width, height), Image.Resampling.NEAREST))
