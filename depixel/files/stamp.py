"""The options stamp: which options made an output file, written inside the file itself.

A batch skips an output only when it is newer than its input *and* carries the stamp of
the options asked for now (like make, plus the command line), so changing an input or an
option reconverts exactly the files concerned, with no sidecar file. The stamp is a short
hash of depixel's version and every option that changes the output bytes; it is written as
an XML comment after the SVG's declaration, a PNG ``tEXt`` chunk, or the PDF's keywords.
"""
from __future__ import annotations

import json
import os
import re
import struct
import zlib
from pathlib import Path

from ..version import __version__

try:  # CPython's own SHA-256 (``_sha2`` from 3.12, ``_sha256`` before): ~0.4 ms to import,
    # where ``hashlib`` loads OpenSSL (~4 ms of every conversion); the same digest
    from _sha2 import sha256  # type: ignore[import-not-found]
except ImportError:
    try:
        from _sha256 import sha256  # type: ignore[import-not-found]
    except ImportError:  # a Python built without them
        from hashlib import sha256

KEY = "depixel-options"
_PATTERN = re.compile(rb"depixel-options:([0-9a-f]{16})")


def options_stamp(**options: object) -> str:
    """16 hex digits identifying depixel's version and ``options`` (JSON-able values)."""
    text = json.dumps({"version": __version__, **options}, sort_keys=True, default=str)
    return sha256(text.encode("utf-8")).hexdigest()[:16]


def embed(blob: bytes, fmt: str, stamp: str) -> bytes:
    """``blob`` (an SVG or PNG file's bytes) carrying ``stamp``; a PDF gets it at render time
    (:func:`depixel.render.raster.render`'s ``keywords``), so it is returned unchanged."""
    if fmt == "svg":
        comment = f"<!-- {KEY}:{stamp} -->\n".encode("ascii")
        end = blob.find(b"?>") + 2 if blob.startswith(b"<?xml") else 0
        if end:
            end += 1 if blob[end:end + 1] == b"\n" else 0
        return blob[:end] + comment + blob[end:]
    if fmt == "png":
        body = b"tEXt" + f"{KEY}\0{KEY}:{stamp}".encode("latin-1")
        chunk = struct.pack(">I", len(body) - 4) + body + struct.pack(">I", zlib.crc32(body))
        return blob[:-12] + chunk + blob[-12:]  # before IEND, the last chunk (12 bytes)
    return blob


def read(path: str | os.PathLike) -> str | None:
    """The stamp in an output file, or None (no file, not one of depixel's outputs)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
            fh.seek(0, os.SEEK_END)
            size = fh.tell()
            fh.seek(max(0, size - 4096))
            tail = fh.read()
    except OSError:
        return None
    match = _PATTERN.search(head) or _PATTERN.search(tail)
    return match.group(1).decode("ascii") if match else None


def up_to_date(source: str | os.PathLike, output: str | os.PathLike, stamp: str) -> bool:
    """True when ``output`` exists, is not older than ``source`` and carries ``stamp``."""
    try:
        if Path(output).stat().st_mtime_ns < Path(source).stat().st_mtime_ns:
            return False
    except (OSError, ValueError):
        return False
    return read(output) == stamp
