"""Output over the input — a conversion of the 1× art → laid exactly over the upscaled input.

Art saved upscaled is converted at 1× (:mod:`depixel.prepare.pixelgrid`); its SVG or render
then gets the input's size and the viewBox that covers the input's pixels, partial blocks at
the edges cut and non-square pixels stretched.
"""
from __future__ import annotations

import re

import numpy as np

from ..prepare.inputs import PreparedImage
from ..svg.svgtext import numbers


def overlay_svg(svg: str, prepared: PreparedImage, scale: float = 1.0) -> str:
    """Give an SVG of the 1× art the input's size × ``scale`` and the viewBox that lays it
    exactly over the input (partial blocks at the edges cut, non-square pixels stretched).
    Unchanged when the input was not upscaled."""
    if not prepared.upscaled:
        return svg
    width, height = numbers(np.array([prepared.input_size[0] * scale, prepared.input_size[1] * scale]), 3).tolist()
    box = numbers(np.array([prepared.viewbox()]), 6).tolist()[0]
    head = re.search(r"<svg\b[^>]*>", svg)
    if head is None:
        raise ValueError("not an SVG document: no <svg> element")
    # the writer's own size and viewBox are replaced; everything else in the tag is kept
    tag = re.sub(r"""\s(?:width|height|viewBox|preserveAspectRatio)\s*=\s*("[^"]*"|'[^']*')""", "",
                 head.group(0))
    size = f' width="{width}" height="{height}" viewBox="{box}"'
    if prepared.pixel_size[0] != prepared.pixel_size[1]:
        size += ' preserveAspectRatio="none"'  # non-square art pixels: stretch, do not letterbox
    closing = 2 if tag.endswith("/>") else 1
    return svg[: head.start()] + tag[:-closing] + size + tag[-closing:] + svg[head.end():]


def overlay_raster(pixels: np.ndarray, prepared: PreparedImage, scale: float) -> np.ndarray:
    """Crop and resample an ``(H, W, 4) uint8`` render of the whole 1× grid (any uniform
    scale) to the input's size × ``scale``, laid over the input like :func:`overlay_svg`."""
    if not prepared.upscaled:
        return pixels
    from PIL import Image  # noqa: PLC0415

    gh, gw = prepared.rgba.shape[:2]
    per_x, per_y = pixels.shape[1] / gw, pixels.shape[0] / gh  # render pixels per art pixel
    x, y, w, h = prepared.viewbox()
    box = (x * per_x, y * per_y, (x + w) * per_x, (y + h) * per_y)
    size = (max(1, round(prepared.input_size[0] * scale)), max(1, round(prepared.input_size[1] * scale)))
    if all(float(b).is_integer() for b in box) and (box[2] - box[0], box[3] - box[1]) == size:
        return np.ascontiguousarray(pixels[int(box[1]):int(box[3]), int(box[0]):int(box[2])])
    image = Image.fromarray(pixels, "RGBA").resize(size, Image.Resampling.LANCZOS, box=box)
    return np.asarray(image, dtype=np.uint8)
