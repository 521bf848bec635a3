"""What ``diff`` compares: two files (SVG, PDF or raster) brought to one size as RGBA arrays.

The comparison size is a raster's own size (or, for two vector files, their own size)
times ``scale``. A raster is enlarged by nearest neighbour (each pixel a square, as pixel
art is meant to be seen); an SVG or PDF is rendered at that size. Two comparisons are
refused rather than passed, because they could not see a change:

* **the art unseen**: a raster compared at fewer pixels than it has (``scale`` below 1
  drops rows and columns), or a vector file at fewer pixels than its art — an SVG's
  ``viewBox`` or its own width/height, whichever is smaller (depixel's viewBox is the pixel
  grid of the sprite), a PDF's page size — raises :class:`UnseenArtError`;
* **a size mismatch**: rasters (or vector files) of different sizes, or a vector file
  against a raster of another aspect ratio (more than a pixel off once rendered at the
  raster's width), raise :class:`SizeMismatchError` unless ``allow_size_mismatch``: then
  the vector file is drawn to fit inside the raster, keeping its shape, and both are padded
  with transparency to the larger size, so the area only one covers counts as changed.

Every image read or rendered is refused over ``max_pixels`` before it is decoded.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import validate
from ..errors import InputError, ParameterError, RenderError, display_name
from ..limits import DEFAULT_MAX_DIFF_PIXELS
from ..prepare.image import check_pixels, load_image, read_source

#: File name extensions of the renders ``diff`` compares in folders.
EXTENSIONS = (".svg", ".svgz", ".png", ".pdf")
_PT = 4.0 / 3.0  # CSS pixels per PDF point
#: Pixels an art pixel of a vector file must be drawn with (a side) for the anti-aliasing test:
#: at 1x and 2x, 64 of the 2,472 one-pixel edits of mushroom.png that showed were drawn as a
#: blend of one or two pixels and excused (benchmarks/diff_sensitivity.py); from 3x, none.
ANTIALIAS_MIN_SCALE = 3


class SizeMismatchError(InputError):
    """The two images have different sizes (or aspect ratios)."""


class UnseenArtError(ParameterError):
    """The comparison size has fewer pixels than the art: a change could pass unseen."""


@dataclass(frozen=True, eq=False)
class Source:
    """One file to compare, read but not yet rendered."""

    name: str  # for messages
    kind: str  # "svg", "pdf" or "raster"
    data: bytes
    size: tuple[float, float]  # own width, height in pixels (a PDF's in CSS pixels)
    art: tuple[float, float]  # the fewest pixels a comparison may have (module docstring)
    rgba: np.ndarray | None = None  # a raster, decoded


def kind_of(data: bytes, path: str | os.PathLike = "") -> str:
    """"svg" by extension or content (an XML declaration or ``<svg``, or gzip with an
    .svgz name), "pdf" by its signature, else "raster"."""
    suffix = Path(path).suffix.lower()
    if suffix in (".svg", ".svgz"):
        return "svg"
    if data.startswith(b"%PDF-"):
        return "pdf"
    head = data[:512].lstrip(b"\xef\xbb\xbf \t\r\n")
    return "svg" if head.startswith(b"<?xml") or head.startswith(b"<svg") else "raster"


def read(path: str | os.PathLike, max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> Source:
    """Read a file and find its size; a raster is decoded (refused over ``max_pixels``)."""
    from ..render.raster import svg_size  # noqa: PLC0415

    name = display_name(path)
    data = read_source(path)
    kind = kind_of(data, path)
    if kind == "svg":
        size = svg_size(data, name=name)
        box = _view_box(data, name) or size
        return Source(name, kind, data, size, (min(size[0], box[0]), min(size[1], box[1])))
    if kind == "pdf":
        from .pdf import page_size  # noqa: PLC0415

        width, height = page_size(data, name)
        return Source(name, kind, data, (width * _PT, height * _PT), (width * _PT, height * _PT))
    rgba = load_image(data, max_pixels=max_pixels, name=name)
    height, width = rgba.shape[:2]
    return Source(name, kind, data, (width, height), (width, height), rgba)


def sizes(a: Source, b: Source, scale: float, allow_size_mismatch: bool = False) -> list[tuple[int, int]]:
    """The (width, height) at which each of ``a`` and ``b`` is drawn (equal unless
    ``allow_size_mismatch``); raises as the module docstring says."""
    validate.positive("scale", scale)
    out: list[tuple[int, int]] = [_scaled(s.size, scale) for s in (a, b)]
    rasters = [s.kind == "raster" for s in (a, b)]
    if rasters[0] != rasters[1]:  # a vector file drawn at the raster's (scaled) size
        r, v = (0, 1) if rasters[0] else (1, 0)
        width, height = out[r]
        exact = width * out[v][1] / out[v][0] if out[v][0] else 0.0
        if abs(exact - height) <= 1.0:
            out[v] = (width, height)
        elif not allow_size_mismatch:
            raise SizeMismatchError(f"{a.name} and {b.name} differ in aspect ratio: {_shape(a)} against "
                                    f"{_shape(b)} (a vector file is drawn at the raster's size only when "
                                    "the shapes agree; allow_size_mismatch compares them anyway)",
                                    parameter="allow_size_mismatch")
        else:  # drawn to fit inside the raster, keeping its shape
            fit = min(width / out[v][0], height / out[v][1])
            out[v] = (max(1, round(out[v][0] * fit)), max(1, round(out[v][1] * fit)))
    for source, (width, height) in zip((a, b), out):
        need = (math.floor(source.art[0] + 1e-9), math.floor(source.art[1] + 1e-9))
        if source.kind != "raster" and rasters != [False, False]:
            continue  # drawn at the raster's size: the raster says how fine the art is
        if width < need[0] or height < need[1]:
            least = max(need[0] / source.size[0], need[1] / source.size[1])
            raise UnseenArtError(f"{source.name}: compared at {width}x{height}, fewer pixels than its "
                                 f"{need[0]}x{need[1]} of art, so a change could pass unseen "
                                 f"(use scale {_number(least)} or more)", parameter="scale")
    if out[0] != out[1] and not allow_size_mismatch:
        raise SizeMismatchError(f"{a.name} is {out[0][0]}x{out[0][1]} but {b.name} is {out[1][0]}x{out[1][1]} "
                                "(allow_size_mismatch compares them, the area only one covers counted as "
                                "changed)", parameter="allow_size_mismatch")
    return out


def too_coarse_for_antialiasing(source: Source, width: int, height: int) -> bool:
    """Is a vector file drawn at ``width`` × ``height`` given fewer than
    :data:`ANTIALIAS_MIN_SCALE` pixels an art pixel along a side? There, one edited pixel of
    the art can be drawn as a blend of one or two pixels, like an edge drawn differently, so
    the anti-aliasing test cannot tell them apart (docs/cli.md, "Anti-aliasing"). A raster's
    art is not known: never."""
    if source.kind == "raster":
        return False
    return width < ANTIALIAS_MIN_SCALE * source.art[0] - 1e-9 or height < ANTIALIAS_MIN_SCALE * source.art[1] - 1e-9


def pixels(source: Source, width: int, height: int, max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> np.ndarray:
    """``source`` drawn at ``width`` × ``height`` → ``(H, W, 4) uint8`` straight RGBA."""
    check_pixels(source.name, width, height, max_pixels)
    if source.kind == "svg":
        return _render_svg(source, width, height, max_pixels)
    if source.kind == "pdf":
        from .pdf import render_page  # noqa: PLC0415

        return render_page(source.data, width, height, source.name)
    assert source.rgba is not None
    if (width, height) == source.rgba.shape[1::-1]:
        return source.rgba if source.rgba.flags.writeable else source.rgba.copy()
    from PIL import Image  # noqa: PLC0415

    return np.array(Image.fromarray(source.rgba, "RGBA").resize((width, height), Image.Resampling.NEAREST))


def _render_svg(source: Source, width: int, height: int, max_pixels: int | None) -> np.ndarray:
    """An SVG drawn by cairosvg → a writable ``(H, W, 4) uint8`` array (the PNG freed first)."""
    import io  # noqa: PLC0415

    from PIL import Image  # noqa: PLC0415

    from ..render.raster import render  # noqa: PLC0415

    try:
        png = render(source.data, "png", size=(width, height), name=source.name, max_output_pixels=max_pixels)
    except RenderError as exc:  # the limit of the render is this comparison's max_pixels
        if exc.parameter != "max_output_pixels":
            raise
        raise RenderError(str(exc).replace("max_output_pixels", "max_pixels"), parameter="max_pixels") from None
    with Image.open(io.BytesIO(png)) as img:
        del png
        img.load()
        return np.array(img if img.mode == "RGBA" else img.convert("RGBA"))


def draw_pair(a: Source, b: Source, *, scale: float = 1.0, allow_size_mismatch: bool = False,
              max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> tuple[np.ndarray, np.ndarray]:
    """Both files (:func:`read`) as ``(H, W, 4) uint8`` RGBA of the same size, not yet flattened
    (module docstring). So ``scale=8`` compares a sprite's SVG with its 1x PNG at 8x."""
    (wa, ha), (wb, hb) = sizes(a, b, scale, allow_size_mismatch)
    first = pixels(a, wa, ha, max_pixels)
    second = pixels(b, wb, hb, max_pixels)
    if first.shape != second.shape:  # allowed: pad both to the larger size
        height, width = max(ha, hb), max(wa, wb)
        first, second = (np.pad(x, ((0, height - x.shape[0]), (0, width - x.shape[1]), (0, 0)))
                         for x in (first, second))
    return first, second


def _view_box(data: bytes, name: str) -> tuple[float, float] | None:
    """The width and height of an SVG's ``viewBox``, None without a usable one."""
    import xml.etree.ElementTree as ET  # noqa: PLC0415

    from ..render.raster import svg_document  # noqa: PLC0415

    box = ET.fromstring(svg_document(data, name)).get("viewBox", "").replace(",", " ").split()
    try:
        width, height = float(box[2]), float(box[3])
    except (IndexError, ValueError):
        return None
    return (width, height) if width > 0 and height > 0 and math.isfinite(width * height) else None


def _scaled(size: tuple[float, float], scale: float) -> tuple[int, int]:
    return max(1, round(size[0] * scale)), max(1, round(size[1] * scale))


def _shape(source: Source) -> str:
    w, h = source.size
    return f"{_number(w)}x{_number(h)}"


def _number(x: float) -> str:
    return f"{x:.4g}"
