"""Input — an animated PNG (APNG) → every frame as a browser shows it, with its delay and plays.

Pillow composites APNG frames itself, but blends ``APNG_BLEND_OP_OVER`` with a paste through the
frame's alpha, which blends the alpha channel too: half-transparent blue over opaque red comes
out 191 opaque, not 255 (Pillow 13). So depixel reads the chunks and composites as the APNG
specification says; Pillow only decodes each frame's pixels (its ``fdAT`` data rewrapped as a
PNG with the file's header, palette and transparency).

The canvas starts transparent black; a frame replaces its rectangle (``OP_SOURCE``) or is drawn
over it (``OP_OVER``, straight alpha); after it is shown, ``OP_BACKGROUND`` clears the rectangle
to transparent and ``OP_PREVIOUS`` restores what was there before (on the first frame it acts
as ``OP_BACKGROUND``).
"""
from __future__ import annotations

import dataclasses
import struct
import zlib
from collections.abc import Iterator

import numpy as np

from ..errors import InputError
from ..limits import check_frames, check_frames_pixels, check_pixels
from .pillow import open_image, quiet_pillow, to_rgba

SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: dispose_op and blend_op values (APNG specification, fcTL)
DISPOSE_BACKGROUND, DISPOSE_PREVIOUS = 1, 2
BLEND_OVER = 1


@dataclasses.dataclass(frozen=True)
class ApngFrame:
    """One frame as stored: its rectangle, timing, operations and compressed pixels."""

    x: int
    y: int
    width: int
    height: int
    delay: float  # milliseconds as stored (a denominator of 0 means hundredths)
    dispose: int
    blend: int
    data: bytes  # the zlib stream of its IDAT or fdAT chunks


@dataclasses.dataclass(frozen=True)
class ApngFile:
    """The chunks of an APNG that matter to its frames."""

    header: bytes  # the IHDR data (width and height are replaced per frame)
    extra: bytes  # the PLTE and tRNS chunks, whole, for decoding each frame
    plays: int  # acTL num_plays: 0 for ever
    frames: tuple[ApngFrame, ...]

    @property
    def size(self) -> tuple[int, int]:
        return struct.unpack_from(">II", self.header)


def is_apng(data: bytes) -> bool:
    """Whether ``data`` is a PNG with an animation control chunk before its image data."""
    if not data.startswith(SIGNATURE):
        return False
    pos = len(SIGNATURE)
    while pos + 8 <= len(data):
        length, kind = struct.unpack_from(">I4s", data, pos)
        if kind == b"acTL":
            return True
        if kind in (b"IDAT", b"IEND"):
            return False
        pos += 12 + length
    return False


def parse_apng(data: bytes, name: str, max_frames: int | None = None) -> ApngFile:
    """Walk the chunks of an APNG (no pixel decoded); more than ``max_frames`` frames (as its
    ``acTL`` declares or as found) are refused before any is decoded."""
    pos = len(SIGNATURE)
    header = extra = b""
    plays = 0
    frames: list[ApngFrame] = []
    control: tuple | None = None  # the fcTL fields of the frame being read
    parts: list[bytes] = []

    def finish() -> None:
        if control is not None:
            _, w, h, x, y, num, den, dispose, blend = control
            delay = 1000.0 * num / (den or 100)
            frames.append(ApngFrame(x, y, w, h, delay, dispose, blend, b"".join(parts)))
            check_frames(name, len(frames), max_frames)

    try:
        while True:
            length, kind = struct.unpack_from(">I4s", data, pos)
            body = data[pos + 8 : pos + 8 + length]
            if len(body) < length:
                raise IndexError("a chunk runs past the end")
            pos += 12 + length
            if kind == b"IHDR":
                header = body
            elif kind in (b"PLTE", b"tRNS"):
                extra += data[pos - 12 - length : pos]
            elif kind == b"acTL":
                declared, plays = struct.unpack(">II", body)
                check_frames(name, declared, max_frames)
            elif kind == b"fcTL":
                finish()
                control, parts = struct.unpack(">IIIIIHHBB", body), []
            elif kind == b"IDAT" and control is not None:  # IDAT before any fcTL: the default image
                parts.append(body)
            elif kind == b"fdAT" and control is not None:
                parts.append(body[4:])
            elif kind == b"IEND":
                break
    except (IndexError, struct.error):
        raise InputError(f"{name}: truncated or corrupt image data") from None
    finish()
    if len(header) != 13 or not frames:
        raise InputError(f"{name}: truncated or corrupt image data")
    return ApngFile(header, extra, plays, tuple(frames))


def check_apng(apng: ApngFile, name: str, max_pixels: int | None, whole: bool = True) -> None:
    """The pixel limits, before anything is decoded: the canvas and every frame within
    ``max_pixels``, for the ``whole`` animation the canvas × frames too; a frame must lie
    inside the canvas (the specification's rule)."""
    width, height = apng.size
    check_pixels(name, width, height, max_pixels)
    if whole:
        check_frames_pixels(name, len(apng.frames), len(apng.frames) * width * height, max_pixels)
    for frame in apng.frames:
        if frame.width == 0 or frame.height == 0 or frame.x + frame.width > width or frame.y + frame.height > height:
            raise InputError(f"{name}: an APNG frame lies outside the image")


def composite(apng: ApngFile, name: str) -> Iterator[np.ndarray]:
    """Every frame as a browser shows it, in order, each decoded when asked for: ``(H, W, 4)
    uint8`` RGBA each (module docstring)."""
    width, height = apng.size
    canvas = np.zeros((height, width, 4), np.uint8)
    for index, frame in enumerate(apng.frames):
        rows, cols = slice(frame.y, frame.y + frame.height), slice(frame.x, frame.x + frame.width)
        area = canvas[rows, cols]
        before = area.copy() if frame.dispose == DISPOSE_PREVIOUS and index else None
        pixels = decode_frame(apng, frame, name)
        area[...] = over(pixels, area) if frame.blend == BLEND_OVER else pixels
        yield canvas.copy()
        if before is not None:
            area[...] = before
        elif frame.dispose in (DISPOSE_BACKGROUND, DISPOSE_PREVIOUS):
            area[...] = 0


def over(top: np.ndarray, below: np.ndarray) -> np.ndarray:
    """``top`` drawn over ``below`` (straight-alpha RGBA uint8, Porter–Duff over), rounded."""
    a_top = top[..., 3:].astype(np.float64) / 255.0
    a_below = below[..., 3:].astype(np.float64) / 255.0 * (1.0 - a_top)
    alpha = a_top + a_below
    colour = top[..., :3] * a_top + below[..., :3] * a_below
    colour = np.divide(colour, alpha, out=np.zeros_like(colour), where=alpha > 0)
    return np.rint(np.concatenate((colour, alpha * 255.0), axis=-1)).astype(np.uint8)


def decode_frame(apng: ApngFile, frame: ApngFrame, name: str) -> np.ndarray:
    """``(h, w, 4) uint8`` RGBA of one frame, decoded by Pillow from its compressed pixels."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    one = (SIGNATURE + chunk(b"IHDR", struct.pack(">II", frame.width, frame.height) + apng.header[8:])
           + apng.extra + chunk(b"IDAT", frame.data) + chunk(b"IEND", b""))
    try:
        with quiet_pillow(), open_image(one, name) as img:
            img.load()
            return to_rgba(img, name)
    except InputError:
        raise
    except MemoryError:
        raise InputError(f"{name}: not enough memory to decode a {frame.width}x{frame.height} image") from None
    except Exception:  # Pillow raises OSError, SyntaxError, ValueError, zlib.error, ...
        raise InputError(f"{name}: truncated or corrupt image data") from None
