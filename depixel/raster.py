"""Rasterizing SVG (PNG, PDF, RGBA arrays) through cairosvg.

cairosvg is imported only here and only when a function is called: converting to SVG never
loads cairo, so the common path starts fast and works on machines without libcairo.
Importing cairosvg raises ``OSError`` (not ``ImportError``) when the system cairo library is
missing; both become a :class:`RenderError` with a one-line hint.
"""
from __future__ import annotations

import io
import re
from importlib import metadata

import numpy as np

from .errors import RenderError

#: Formats :func:`render` writes.
RASTER_FORMATS = ("png", "pdf")


def cairosvg_version() -> str | None:
    """Installed cairosvg version from its package metadata (does not load cairo)."""
    try:
        return metadata.version("cairosvg")
    except metadata.PackageNotFoundError:
        return None


def _cairosvg():
    try:
        import cairosvg  # noqa: PLC0415 (lazy on purpose, see module docstring)
    except ImportError:
        raise RenderError("PNG/PDF output needs cairosvg: pip install cairosvg") from None
    except OSError as exc:
        raise RenderError(
            f"PNG/PDF output needs the cairo library, which could not be loaded ({exc}); "
            "install it (e.g. apt install libcairo2, brew install cairo)"
        ) from None
    return cairosvg


def _as_bytes(svg: str | bytes) -> bytes:
    return svg.encode("utf-8") if isinstance(svg, str) else svg


def render(svg: str | bytes, fmt: str = "png", *, scale: float | None = None, width: int | None = None,
           height: int | None = None, background: tuple[int, int, int] | None = None,
           name: str = "<svg>") -> bytes:
    """Render SVG text to PNG or PDF bytes.

    The size is the SVG's own width/height times ``scale`` (default 1); ``width`` and/or
    ``height`` in pixels override it (one of them alone keeps the aspect ratio).
    ``background`` is an opaque RGB colour painted under the drawing (default: transparent).
    """
    if fmt not in RASTER_FORMATS:
        raise ValueError(f"unknown raster format {fmt!r}; choose one of {', '.join(RASTER_FORMATS)}")
    cairosvg = _cairosvg()
    convert = cairosvg.svg2png if fmt == "png" else cairosvg.svg2pdf
    colour = "#{:02x}{:02x}{:02x}".format(*background) if background is not None else None
    try:
        return convert(bytestring=_as_bytes(svg), scale=1.0 if scale is None else scale,
                       output_width=width, output_height=height, background_color=colour)
    except Exception as exc:  # cairosvg raises ParseError, ValueError, ... for bad SVG
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RenderError(f"{name}: cannot render SVG ({reason})") from None


def render_rgba(svg: str | bytes, *, width: int | None = None, height: int | None = None,
                scale: float | None = None, name: str = "<svg>") -> np.ndarray:
    """Render SVG text to an ``(H, W, 4) uint8`` RGBA array on a transparent background."""
    from PIL import Image  # noqa: PLC0415

    png = render(svg, "png", scale=scale, width=width, height=height, name=name)
    with Image.open(io.BytesIO(png)) as img:
        return np.ascontiguousarray(np.asarray(img.convert("RGBA"), dtype=np.uint8))


_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_UNITS_PX = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "in": 96.0, "cm": 96.0 / 2.54, "mm": 96.0 / 25.4}


def svg_size(svg: str | bytes, name: str = "<svg>") -> tuple[float, float]:
    """Width and height of an SVG document in CSS pixels (from width/height, else the viewBox)."""
    import xml.etree.ElementTree as ET  # noqa: PLC0415

    try:
        root = ET.fromstring(_as_bytes(svg))
    except ET.ParseError as exc:
        raise RenderError(f"{name}: not a valid SVG document ({exc})") from None
    if not root.tag.endswith("svg"):
        raise RenderError(f"{name}: not an SVG document (root element <{root.tag}>)")
    box = root.get("viewBox", "").replace(",", " ").split()
    size = []
    for i, attr in enumerate(("width", "height")):
        text = root.get(attr, "").strip()
        match = re.fullmatch(rf"({_NUMBER})\s*(px|pt|pc|in|cm|mm)?", text)
        if match:
            size.append(float(match.group(1)) * _UNITS_PX[match.group(2) or ""])
        elif len(box) == 4 and re.fullmatch(_NUMBER, box[2 + i]):
            size.append(float(box[2 + i]))
        else:
            raise RenderError(f"{name}: SVG has no usable {attr} or viewBox")
    if not (size[0] > 0 and size[1] > 0):
        raise RenderError(f"{name}: SVG has zero size")
    return size[0], size[1]
