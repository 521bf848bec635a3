"""The stamp: what made an output file, and whether it is still as depixel wrote it.

Written inside the file itself (no sidecar file): an XML comment after the SVG's
declaration, a PNG ``tEXt`` chunk before ``IEND``, the PDF's keywords. Its text is one line,

    depixel-options:OPTIONS;input=SIZE,MTIME_NS,INPUT;body=BODY

OPTIONS is a short hash of depixel's version and every option that changes the output
bytes; SIZE, MTIME_NS and INPUT (the first 16 hex digits of the SHA-256 of its bytes) are the
input's identity as it was read; BODY is the digest of the file's own bytes without the stamp
(for a PNG, without the whole chunk, whose CRC depends on it). So a batch can tell

* an output made from this very input with these options (``CURRENT``: skipped), from
  the input's size and mtime, or its bytes when only the mtime moved (a ``touch``, a checkout);
* one depixel wrote and nobody changed since (``STALE``: overwritten when the input or an
  option changed);
* one edited since (``EDITED``: its body no longer matches, whether or not its input and
  options are the ones it was made from), or not depixel's at all (``UNSTAMPED``: no stamp;
  a tool that strips comments drops it too): both are kept unless the user forces it.

An output written from standard input has no ``input=`` part (it is never current); a stamp
from before this format has neither part (``OLD``: depixel's, but whether it was edited
cannot be told, so it is kept unless the user forces it, as an edit would be).
"""
from __future__ import annotations

import json
import os
import re
import stat
import struct
import zlib
from dataclasses import dataclass
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
#: The body digest while the body is digested (the same length as any digest).
ZERO = "0" * 16
_PATTERN = re.compile(rb"depixel-options:([0-9a-f]{16})(?:;input=([0-9]{1,20}),(-?[0-9]{1,24}),([0-9a-f]{16}))?"
                      rb"(?:;body=([0-9a-f]{16}))?")
_PNG = b"\x89PNG\r\n\x1a\n"
#: What an existing output is, for a conversion about to write it (:func:`status`).
NEW, CURRENT, STALE, UNSTAMPED, EDITED, OLD = "new", "current", "stale", "unstamped", "edited", "old"
#: The existing outputs a conversion keeps unless forced: not depixel's, edited, or too old to tell.
KEPT = (UNSTAMPED, EDITED, OLD)


@dataclass(frozen=True)
class Identity:
    """An input file as it was read: its size, modification time (ns) and digest."""

    size: int
    mtime_ns: int
    digest: str  # :func:`digest` of its bytes

    def matches(self, path: str | os.PathLike) -> bool:
        """Whether ``path`` still holds these bytes: the same size and mtime, or the same
        size and digest (its bytes are read only when the mtime alone moved)."""
        try:
            now = os.stat(path)
            if now.st_size != self.size or not stat.S_ISREG(now.st_mode):
                return False
            if now.st_mtime_ns == self.mtime_ns:
                return True
            with open(path, "rb") as fh:
                return digest(fh.read(self.size + 1)) == self.digest
        except (OSError, ValueError):
            return False


@dataclass(frozen=True)
class Stamp:
    """A stamp as found in a file; ``identity`` and ``body`` are None in older stamps."""

    options: str
    identity: Identity | None
    body: str | None


def options_stamp(**options: object) -> str:
    """16 hex digits identifying depixel's version and ``options`` (JSON-able values)."""
    text = json.dumps({"version": __version__, **options}, sort_keys=True, default=str)
    return sha256(text.encode("utf-8")).hexdigest()[:16]


def digest(data: bytes) -> str:
    """The first 16 hex digits of the SHA-256 of ``data``."""
    return sha256(data).hexdigest()[:16]


def text(options: str, identity: Identity | None, body: str = ZERO) -> str:
    """The stamp's one line (:data:`ZERO` for a body not digested yet)."""
    source = "" if identity is None else f";input={identity.size},{identity.mtime_ns},{identity.digest}"
    return f"{KEY}:{options}{source};body={body}"


def embed(blob: bytes, fmt: str, options: str, identity: Identity | None) -> bytes:
    """``blob`` (an SVG, PNG or PDF file's bytes) carrying its complete stamp. A PDF gets its
    stamp at render time, as its keywords: it must be rendered with ``text(options,
    identity)`` (the body :data:`ZERO`), which is completed here."""
    draft = text(options, identity).encode("ascii")
    staged = _insert(blob, fmt, draft)
    if fmt == "pdf" and staged.count(draft) != 1:
        raise ValueError("a PDF to stamp carries its draft stamp in its keywords, once")
    final = text(options, identity, _body_digest(staged)).encode("ascii")
    return _insert(blob, fmt, final) if fmt != "pdf" else staged.replace(draft, final)


def _insert(blob: bytes, fmt: str, line: bytes) -> bytes:
    if fmt == "svg":
        comment = b"<!-- " + line + b" -->\n"
        end = blob.find(b"?>") + 2 if blob.startswith(b"<?xml") else 0
        if end:
            end += 1 if blob[end:end + 1] == b"\n" else 0
        return blob[:end] + comment + blob[end:]
    if fmt == "png":
        body = b"tEXt" + KEY.encode("ascii") + b"\0" + line
        chunk = struct.pack(">I", len(body) - 4) + body + struct.pack(">I", zlib.crc32(body))
        return blob[:-12] + chunk + blob[-12:]  # before IEND, the last chunk (12 bytes)
    return blob


def _spans(blob: bytes) -> list[tuple[int, int, re.Match]]:
    """Where the stamps are: the text of each, or for a PNG the whole ``tEXt`` chunk that
    holds it (when the chunk is well formed)."""
    spans = []
    for match in _PATTERN.finditer(blob):
        start, end = match.span()
        if blob.startswith(_PNG):
            head = start - len(KEY) - 1 - 8
            if head >= 0 and blob[head + 4:head + 8] == b"tEXt" and \
                    struct.unpack(">I", blob[head:head + 4])[0] == end - head - 8:
                start, end = head, end + 4
        spans.append((start, end, match))
    return spans


def _body_digest(blob: bytes) -> str:
    """The digest of ``blob`` without its stamps (:func:`_spans`)."""
    parts, at = [], 0
    for start, end, _ in _spans(blob):
        parts.append(blob[at:start])
        at = end
    parts.append(blob[at:])
    return digest(b"".join(parts))


def parse(blob: bytes) -> Stamp | None:
    """The (first) stamp in a file's bytes, or None."""
    match = _PATTERN.search(blob)
    if match is None:
        return None
    options, size, mtime, source, body = (g.decode("ascii") if g is not None else None for g in match.groups())
    identity = None if source is None else Identity(int(size), int(mtime), source)  # type: ignore[arg-type]
    return Stamp(options, identity, body)  # type: ignore[arg-type]


def intact(blob: bytes) -> bool:
    """Whether a stamped file's bytes are as depixel wrote them (its body digest holds)."""
    found = parse(blob)
    return found is not None and found.body is not None and found.body == _body_digest(blob)


def read(path: str | os.PathLike) -> Stamp | None:
    """The stamp of an output file from its first and last 4 KiB (where depixel writes it),
    or None (no file, not one of depixel's outputs). Its body is not checked."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a pipe would wait for a writer, a device never end
            return None
        with open(path, "rb") as fh:
            head = fh.read(4096)
            fh.seek(0, os.SEEK_END)
            size = fh.tell()
            fh.seek(max(0, size - 4096))
            tail = fh.read()
    except (OSError, ValueError):
        return None
    return parse(head) or parse(tail)


def status(source: str | os.PathLike, output: str | os.PathLike, options: str) -> str:
    """What the existing ``output`` is for a conversion of ``source`` with the options stamp
    ``options``: NEW (no file, or a device written in place), CURRENT, STALE, UNSTAMPED,
    EDITED or OLD (the module's docstring). A file is read whole only when its first and last
    4 KiB hold a stamp: a current one must also be as depixel wrote it (an edit made while
    the input stayed the same is EDITED, not CURRENT)."""
    try:
        if not stat.S_ISREG(os.stat(output).st_mode):
            return NEW
    except (OSError, ValueError):  # missing (or unreachable: the writer reports it)
        return NEW
    found = read(output)
    if found is None:
        return UNSTAMPED
    now = replaceable(output)
    if now == STALE and found.options == options and found.identity is not None and \
            found.identity.matches(source):
        return CURRENT
    return now


def replaceable(output: str | os.PathLike) -> str:
    """Whether an existing ``output`` may be replaced: NEW (none, or a device), STALE (as
    depixel wrote it), UNSTAMPED, EDITED, or OLD (a stamp without a body digest: whether it
    was edited cannot be told)."""
    try:
        if not stat.S_ISREG(os.stat(output).st_mode):
            return NEW
        blob = Path(output).read_bytes()
    except FileNotFoundError:
        return NEW
    except (OSError, ValueError):
        return UNSTAMPED  # unreadable: not something to overwrite blindly
    found = parse(blob)
    if found is None:
        return UNSTAMPED
    if found.body is None:
        return OLD
    return STALE if intact(blob) else EDITED
