"""PDF renders for ``diff``: a one-page PDF drawn at a size in pixels through PDFium.

pypdfium2 (the ``pdf`` extra: ``pip install "/path/to/depixel[pdf]"``) is imported only when a PDF is compared;
without it a PDF is refused with a one-line hint. A PDF of more than one page is refused:
depixel writes one page a file, and a page-by-page comparison would need a verdict of its own.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError


def _pdfium():
    try:
        import pypdfium2  # noqa: PLC0415 (lazy on purpose: only PDF comparisons need it)
    except ImportError:
        raise InputError('comparing PDF files needs pypdfium2: pip install pypdfium2 (or depixel with its pdf '
                         'extra: pip install "/path/to/depixel[pdf]")') from None
    return pypdfium2


def _page(data: bytes, name: str):
    pdfium = _pdfium()
    try:
        document = pdfium.PdfDocument(data)
    except pdfium.PdfiumError as exc:
        raise InputError(f"{name}: not a readable PDF ({exc})") from None
    if len(document) != 1:
        raise InputError(f"{name}: has {len(document)} pages; diff compares one-page PDFs")
    return document, document[0]


def page_size(data: bytes, name: str) -> tuple[float, float]:
    """Width and height of the PDF's page in points."""
    document, page = _page(data, name)
    try:
        width, height = page.get_size()
    finally:
        page.close()
        document.close()
    if not (width > 0 and height > 0):
        raise InputError(f"{name}: the PDF page has zero size")
    return float(width), float(height)


def render_page(data: bytes, width: int, height: int, name: str) -> np.ndarray:
    """The PDF's page drawn over transparency at ``width`` × ``height`` pixels →
    ``(H, W, 4) uint8`` straight RGBA."""
    import pypdfium2.raw as raw  # noqa: PLC0415

    pdfium = _pdfium()
    document, page = _page(data, name)
    try:
        bitmap = pdfium.PdfBitmap.new_native(width, height, raw.FPDFBitmap_BGRA, rev_byteorder=True)
        raw.FPDFBitmap_FillRect(bitmap.raw, 0, 0, width, height, 0)
        raw.FPDF_RenderPageBitmap(bitmap.raw, page.raw, 0, 0, width, height, 0,
                                  raw.FPDF_ANNOT | raw.FPDF_REVERSE_BYTE_ORDER)
        rows = np.frombuffer(bitmap.buffer, dtype=np.uint8).reshape(height, bitmap.stride)
        rgba = rows[:, : width * 4].reshape(height, width, 4).copy()
        bitmap.close()
    except MemoryError:
        raise InputError(f"{name}: not enough memory to render it") from None
    finally:
        page.close()
        document.close()
    return rgba
