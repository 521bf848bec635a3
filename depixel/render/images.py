"""The rasters an SVG embeds (``<image href="data:image/png;base64,…">``), each decoded once.

cairosvg decodes an ``<image>``'s picture every time it draws the element: an SVG that
draws one embedded PNG a thousand times with ``<use>`` decodes it a thousand times (a 25 KB
PNG of 2000×2000 flat pixels: 16 MB each, minutes in all), and a 42 KB PNG of 16000×16000
pixels takes a gigabyte however small it is drawn. It also reads the PNG through a Python
callback, where a Ctrl-C is swallowed by cffi with a traceback on stderr.

Here, while a document is rendered (:func:`decoding`), each distinct picture is decoded
once by Pillow, from its header checked first against the render's pixel budget (every
picture decoded counted, each once), and handed to cairo as an image surface (premultiplied
as cairo's own PNG reader does, so the render is the same). Embedded SVG documents and
pictures on a surface that maps colours are left to cairosvg.
"""
from __future__ import annotations

import io
import os
import struct
import sys
from typing import Any

import numpy as np

from ..errors import RenderError
from ..validate import shown

#: The key under which a render's decoded pictures are kept in cairosvg's (otherwise unused,
#: shared with every child surface) ``images`` table.
_KEY = "#depixel-decoded-images"


class Decoded(dict):
    """The pictures one render has decoded (href → entry), and their pixels in all."""

    def __init__(self, name: str, budget: int | None) -> None:
        super().__init__()
        self.name, self.budget, self.pixels = name, budget, 0


def decoding(surface: Any, name: str, budget: int | None) -> None:
    """Make ``surface`` (a cairosvg surface being made, before it draws) decode each
    embedded picture once, within ``budget`` pixels in all (None: no limit)."""
    _install()
    surface.images[_KEY] = Decoded(name, budget)


_ORIGINAL: Any = None


def _install() -> None:
    """Route cairosvg's ``<image>`` through :func:`_image` (once per process; surfaces not
    set up by :func:`decoding` keep cairosvg's own drawing)."""
    global _ORIGINAL
    import cairosvg.surface  # noqa: PLC0415

    if _ORIGINAL is None:
        _ORIGINAL = cairosvg.surface.TAGS["image"]
        cairosvg.surface.TAGS["image"] = _image


def _image(surface: Any, node: Any) -> None:
    decoded = getattr(surface, "images", {}).get(_KEY)
    if not isinstance(decoded, Decoded) or surface.map_image:
        return _ORIGINAL(surface, node)
    from cairosvg.url import parse_url  # noqa: PLC0415

    href = node.get_href() or ""
    entry = decoded.get(href)
    if entry is None:
        base = node.get("{http://www.w3.org/XML/1998/namespace}base")
        if not base and node.url:  # as cairosvg
            base = os.path.dirname(node.url) + "/"
        data = node.fetch_url(parse_url(href, base), "image/*")
        entry = decoded[href] = _decode(data, decoded)
    if entry is False:  # not a raster (an SVG document, or too short to be one)
        return _ORIGINAL(surface, node)
    _paint(surface, node, entry)
    return None


def _decode(data: bytes, decoded: Decoded) -> Any:
    """A cairo pattern of the picture ``data``, after its size is checked and counted; False
    for what is not a raster cairosvg would decode (left to cairosvg)."""
    if len(data) < 5 or data.startswith((b"<svg ", b"<?xml", b"<!DOC", b"\x1f\x8b")) or b"<svg" in data:
        return False
    import warnings  # noqa: PLC0415

    from PIL import Image, ImageOps  # noqa: PLC0415

    counted = data.startswith(b"\x89PNG\r\n\x1a\n") and data[12:16] == b"IHDR" and len(data) >= 24
    if counted:  # the size from the header, before Pillow's own guard
        _count(decoded, *struct.unpack(">II", data[16:24]))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            img = Image.open(io.BytesIO(data))
            width, height = img.size
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise RenderError(f"{decoded.name}: an embedded picture claims over {Image.MAX_IMAGE_PIXELS} pixels "
                          "(decompression bomb guard)") from None
    except Exception as exc:  # as cairosvg: an unreadable picture stops the render
        raise RenderError(f"{decoded.name}: an embedded picture cannot be read ({type(exc).__name__})") from None
    if not counted:
        _count(decoded, width, height)
    try:
        upright = img if data.startswith(b"\x89PNG") else ImageOps.exif_transpose(img)  # as cairosvg
        rgba = np.asarray(upright.convert("RGBA"))
    except MemoryError:
        raise RenderError(f"{decoded.name}: not enough memory to decode an embedded {width}x{height} "
                          "picture") from None
    except Exception as exc:
        raise RenderError(f"{decoded.name}: an embedded picture cannot be decoded ({type(exc).__name__})") from None
    return _pattern(rgba)


def _count(decoded: Decoded, width: int, height: int) -> None:
    """Add a picture's pixels to the render's count; over the budget is refused."""
    decoded.pixels += width * height
    if decoded.budget is not None and decoded.pixels > decoded.budget:
        raise RenderError(f"{decoded.name}: its embedded pictures hold {shown(decoded.pixels)} pixels, over the "
                          f"limit of {decoded.budget} (raise it with max_output_pixels)",
                          parameter="max_output_pixels")


def _pattern(rgba: np.ndarray):
    """An ``(H, W, 4) uint8`` straight-alpha picture as a cairo surface pattern: ARGB32,
    premultiplied as cairo's PNG reader does (``c * a / 255`` rounded)."""
    import cairocffi as cairo  # noqa: PLC0415

    height, width = rgba.shape[:2]
    alpha = rgba[..., 3:4].astype(np.uint32)
    scaled = rgba[..., :3].astype(np.uint32) * alpha + 128
    colour = ((scaled + (scaled >> 8)) >> 8).astype(np.uint8)
    pixels = np.empty((height, width, 4), np.uint8)  # one native-endian 32-bit ARGB word a pixel
    order = (2, 1, 0) if sys.byteorder == "little" else (1, 2, 3)
    for channel, at in zip(range(3), order):
        pixels[..., at] = colour[..., channel]
    pixels[..., 3 if sys.byteorder == "little" else 0] = rgba[..., 3]
    buffer = bytearray(pixels.tobytes())
    surface = cairo.ImageSurface.create_for_data(buffer, cairo.FORMAT_ARGB32, width, height, width * 4)
    surface.keep = buffer  # the pixels live as long as the surface
    return surface


def _paint(surface: Any, node: Any, image: Any) -> None:
    """Draw the decoded picture as cairosvg's ``image`` does once it has decoded it."""
    import cairocffi as cairo  # noqa: PLC0415
    from cairosvg.helpers import preserve_ratio, size  # noqa: PLC0415

    filters = {"optimizeQuality": cairo.FILTER_BEST, "optimizeSpeed": cairo.FILTER_FAST}
    x, y = size(surface, node.get("x"), "x"), size(surface, node.get("y"), "y")
    width = size(surface, node.get("width"), "x")
    height = size(surface, node.get("height"), "y")
    pattern = cairo.SurfacePattern(image)
    pattern.set_filter(filters.get(node.get("image-rendering"), cairo.FILTER_GOOD))
    node.image_width, node.image_height = image.get_width(), image.get_height()
    width, height = width or node.image_width, height or node.image_height
    scale_x, scale_y, translate_x, translate_y = preserve_ratio(surface, node, width, height)
    if not (translate_x == 0 and translate_y == 0 and width == scale_x * node.image_width
            and height == scale_y * node.image_height):
        surface.context.rectangle(x, y, width, height)
        surface.context.clip()
    opacity = float(node.get("opacity", 1))
    surface.context.save()
    surface.context.translate(x, y)
    surface.context.scale(scale_x, scale_y)
    surface.context.translate(translate_x, translate_y)
    surface.context.set_source(pattern)
    surface.context.paint_with_alpha(opacity)
    surface.context.restore()
