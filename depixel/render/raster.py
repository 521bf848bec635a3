"""Rasterizing SVG (PNG, PDF, RGBA arrays) through cairosvg.

cairosvg is imported only here and only when a function is called: converting to SVG never
loads cairo, so the common path starts fast and works on machines without libcairo.
Importing cairosvg raises ``OSError`` (not ``ImportError``) when the system cairo library is
missing; both become a :class:`RenderError` with a one-line hint.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
from collections.abc import Iterator
from importlib import metadata

import numpy as np

from .. import validate
from ..errors import RenderError
from ..limits import DEFAULT_MAX_OUTPUT_PIXELS, MAX_FILE_BYTES, PDF_PAGE_POINTS
from .images import decoding
from .references import check_references

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


def svg_document(svg: str | bytes, name: str = "<svg>") -> bytes:
    """The SVG's bytes, a gzip-compressed one (.svgz) decompressed with a bound:
    more than MAX_FILE_BYTES once decompressed is refused while decompressing."""
    data = _as_bytes(svg)
    if not data.startswith(b"\x1f\x8b"):
        return data
    import zlib  # noqa: PLC0415

    inflate = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    try:
        out = inflate.decompress(data, MAX_FILE_BYTES + 1)
    except zlib.error as exc:
        raise RenderError(f"{name}: corrupt compressed SVG ({exc})") from None
    if len(out) > MAX_FILE_BYTES:
        raise RenderError(f"{name}: over {MAX_FILE_BYTES // 2**20} MiB once decompressed, too large")
    return out


def reproducible_date() -> str:
    """The creation date written into PDFs: ``SOURCE_DATE_EPOCH`` when set (the
    reproducible-builds convention), else a fixed date, so the same input gives the same bytes."""
    import datetime  # noqa: PLC0415
    import os  # noqa: PLC0415

    try:
        epoch = int(os.environ.get("SOURCE_DATE_EPOCH", "0"))
    except ValueError:
        epoch = 0
    moment = datetime.datetime.fromtimestamp(max(epoch, 0), datetime.timezone.utc)
    return moment.strftime("%Y-%m-%dT%H:%M:%SZ")


def render(svg: str | bytes, fmt: str = "png", *, scale: float | None = None,
           size: tuple[int | None, int | None] = (None, None), background: tuple[int, int, int] | None = None,
           name: str = "<svg>", max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS,
           keywords: str | None = None) -> bytes:
    """Render SVG (or gzip-compressed SVG) text to PNG or PDF bytes.

    The size is the SVG's own width/height times ``scale`` (default 1); ``size``, a width
    and/or height in pixels, overrides it (one of them alone keeps the aspect ratio). A PNG is
    that size rounded to whole pixels, with the drawing stretched by the rounding (under a
    pixel) so that it covers the last row and column. A PNG of more than
    ``max_output_pixels`` is refused before it is allocated. ``background`` is an opaque RGB
    colour painted under the drawing (default: transparent). A PDF carries the creation date
    of :func:`reproducible_date` and ``keywords`` in its metadata, so it is byte-stable.
    """
    validate.choice("format", fmt, RASTER_FORMATS)
    width, height = size
    if scale is not None:
        validate.positive("scale", scale)
    for key, value in (("width", width), ("height", height)):
        if value is not None:
            validate.number(key, value, low=1, integer=True)
    max_output_pixels = validate.limit("max_output_pixels", max_output_pixels)
    cairosvg = _cairosvg()
    data = svg_document(svg, name)
    colour = "#{:02x}{:02x}{:02x}".format(*background) if background is not None else None
    surface_class = _png_surface(cairosvg) if fmt == "png" else _pdf_surface(cairosvg)
    try:
        tree = cairosvg.parser.Tree(bytestring=data)
        check_finite(tree.xml_tree, name)
        check_references(tree.xml_tree, name)
        with _output_file() as (path, fd):
            surface = surface_class(tree, path, 96, None, None, None, 1.0 if scale is None else scale,
                                    width, height, colour, max_pixels=max_output_pixels, name=name)
            if fmt == "pdf":
                import cairocffi  # noqa: PLC0415

                surface.cairo.set_metadata(cairocffi.PDF_METADATA_CREATE_DATE, reproducible_date())
                surface.cairo.set_metadata(cairocffi.PDF_METADATA_CREATOR, "depixel")
                if keywords:
                    surface.cairo.set_metadata(cairocffi.PDF_METADATA_KEYWORDS, keywords)
            surface.finish()
            return _read_all(fd)
    except RenderError:
        raise
    except _TooLarge as exc:
        shown = validate.shown
        raise RenderError(f"{name}: a {shown(exc.width)}x{shown(exc.height)} render is "
                          f"{shown(exc.width * exc.height)} pixels, over the limit of {max_output_pixels} "
                          "(raise it with max_output_pixels)", parameter="max_output_pixels") from None
    except _PageSize as exc:
        parameter = "width" if width is not None else "height" if height is not None else "scale"
        validate.page_size("pdf", exc.width / 0.75, exc.height / 0.75, name, parameter, RenderError)
        raise  # (page_size refuses what _PageSize refused)
    except MemoryError:
        raise RenderError(f"{name}: not enough memory to render it") from None
    except Exception as exc:  # cairosvg raises ParseError, ValueError, ... for bad SVG
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RenderError(f"{name}: cannot render SVG ({reason})") from None


@contextlib.contextmanager
def _output_file() -> Iterator[tuple[str, int]]:
    """A file cairo writes by name, and a descriptor to read it back: a file in memory on
    Linux, else a temporary file. Given a Python file object instead, cairo would call back
    into Python for every block it writes, and a Ctrl-C arriving meanwhile would be raised in
    that callback, where cffi swallows it ("Exception ignored from cffi callback", a
    traceback) and the render goes on or ends short; now it is raised when cairo returns."""
    if hasattr(os, "memfd_create") and os.path.isdir("/proc/self/fd"):
        fd = os.memfd_create("depixel-render", getattr(os, "MFD_CLOEXEC", 0))
        try:
            yield f"/proc/self/fd/{fd}", fd
        finally:
            os.close(fd)
        return
    import tempfile  # noqa: PLC0415

    fd, path = tempfile.mkstemp(prefix="depixel-render-")
    try:
        yield path, fd
    finally:
        os.close(fd)
        os.unlink(path)


def _read_all(fd: int) -> bytes:
    """Everything in the file open as ``fd``, from its start."""
    os.lseek(fd, 0, os.SEEK_SET)
    with open(fd, "rb", closefd=False) as fh:
        return fh.read()


class _PageSize(Exception):
    def __init__(self, width: float, height: float) -> None:
        super().__init__(f"{width}x{height} pt")
        self.width, self.height = width, height


_PDF_SURFACE = None


def _pdf_surface(cairosvg):
    """cairosvg's PDF surface, refusing a page outside the PDF format's range before cairo
    makes it (``limits.PDF_PAGE_POINTS``: cairo would write a page no reader shows, or drop
    the drawing's operators)."""
    global _PDF_SURFACE
    if _PDF_SURFACE is None:
        class CheckedPDFSurface(cairosvg.surface.PDFSurface):
            def __init__(self, *args, max_pixels: int | None = None, name: str = "<svg>", **kwargs) -> None:
                self._max_pixels, self._name = max_pixels, name  # the embedded pictures' budget
                super().__init__(*args, **kwargs)

            def _create_surface(self, width, height):
                low, high = PDF_PAGE_POINTS
                if not (low <= width <= high and low <= height <= high):
                    raise _PageSize(width, height)
                decoding(self, self._name, self._max_pixels)
                return super()._create_surface(width, height)

        _PDF_SURFACE = CheckedPDFSurface
    return _PDF_SURFACE


class _TooLarge(Exception):
    def __init__(self, width: int, height: int) -> None:
        super().__init__(f"{width}x{height}")
        self.width, self.height = width, height


_PNG_SURFACE = None


def _png_surface(cairosvg):
    """cairosvg's PNG surface, checking the pixel count before the image is allocated and
    stretching the drawing over the whole pixels of the rounded size."""
    global _PNG_SURFACE
    if _PNG_SURFACE is not None:
        return _PNG_SURFACE

    class LimitedPNGSurface(cairosvg.surface.PNGSurface):
        def __init__(self, *args, max_pixels: int | None = None, name: str = "<svg>", **kwargs) -> None:
            self._max_pixels, self._name = max_pixels, name
            self._stretch: tuple[float, float] | None = None
            super().__init__(*args, **kwargs)

        def _create_surface(self, width, height):
            w, h = int(round(width)), int(round(height))
            if self._max_pixels is not None and w * h > self._max_pixels:
                raise _TooLarge(w, h)
            decoding(self, self._name, self._max_pixels)  # the embedded pictures: within the same budget
            if w > 0 and h > 0 and self._stretch is None:
                self._stretch = (w / width, h / height)
            return super()._create_surface(width, height)

        def set_context_size(self, width, height, viewbox, tree):
            if self._stretch is not None:  # only the document's own viewport, once
                self.context.scale(*self._stretch)
                self._stretch = None
            super().set_context_size(width, height, viewbox, tree)

    _PNG_SURFACE = LimitedPNGSurface
    return _PNG_SURFACE


def render_rgba(svg: str | bytes, *, width: int | None = None, height: int | None = None,
                scale: float | None = None, name: str = "<svg>",
                max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS) -> np.ndarray:
    """Render SVG text to an ``(H, W, 4) uint8`` RGBA array on a transparent background."""
    from PIL import Image  # noqa: PLC0415

    png = render(svg, "png", scale=scale, size=(width, height), name=name,
                 max_output_pixels=max_output_pixels)
    with Image.open(io.BytesIO(png)) as img:
        return np.ascontiguousarray(np.asarray(img.convert("RGBA"), dtype=np.uint8))


_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_UNITS_PX = {"": 1.0, "px": 1.0, "pt": 4.0 / 3.0, "pc": 16.0, "in": 96.0, "cm": 96.0 / 2.54, "mm": 96.0 / 25.4}


def svg_size(svg: str | bytes, name: str = "<svg>") -> tuple[float, float]:
    """Width and height of an SVG document in CSS pixels (from width/height, else the viewBox)."""
    import xml.etree.ElementTree as ET  # noqa: PLC0415

    try:
        root = ET.fromstring(svg_document(svg, name))
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
    check_finite(root, name)
    if not (size[0] > 0 and size[1] > 0):
        raise RenderError(f"{name}: SVG has zero size")
    return size[0], size[1]


#: The largest width, height or viewBox number accepted (CSS pixels): far beyond any drawing
#: (a 1e9-pixel side at 1x is refused by every pixel limit anyway), yet far from the
#: overflow of a float64 or of cairo's fixed-point coordinates being multiplied.
MAX_SVG_NUMBER = 1e15


def check_finite(root, name: str) -> None:
    """Refuse (:class:`RenderError`) an SVG root (an ElementTree element) whose width,
    height or viewBox holds a number over :data:`MAX_SVG_NUMBER` in size (``1e400`` is
    infinite once read: sizes computed from it overflow or divide by zero)."""
    for attr in ("width", "height", "viewBox"):
        for text in re.findall(_NUMBER, root.get(attr, "")):
            if not abs(float(text)) <= MAX_SVG_NUMBER:
                raise RenderError(f"{name}: SVG {attr} {text[:24]} is too large a number (at most "
                                  f"{MAX_SVG_NUMBER:g})")


def paste_pngs(pngs: list[tuple[int, int, bytes]], size: tuple[int, int]) -> bytes:
    """A transparent PNG of ``size`` with each PNG pasted at its ``(x, y)`` (a sheet's sprites)."""
    from PIL import Image  # noqa: PLC0415

    canvas = Image.new("RGBA", size, (0, 0, 0, 0))
    for x, y, png in pngs:
        with Image.open(io.BytesIO(png)) as tile:
            canvas.paste(tile.convert("RGBA"), (x, y))
    buffer = io.BytesIO()
    canvas.save(buffer, format="PNG")
    return buffer.getvalue()
