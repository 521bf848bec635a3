"""Animated GIF and APNG files written byte by byte for the tests, so every field a reader must
honour is set as the test says: a frame's rectangle, colour table, transparent index, delay and
disposal (GIF); a frame's rectangle, delay fraction, dispose and blend operations (APNG); the
loop block or its absence. Pillow's writers choose some of these themselves (they crop frames,
merge equal ones and set disposal their way)."""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np


@dataclass
class GifImage:
    """One image of a GIF: colour indices ``(h, w)`` at (x, y)."""

    indices: list[list[int]]
    x: int = 0
    y: int = 0
    delay: int = 10  # hundredths of a second
    disposal: int = 0
    transparent: int | None = None
    palette: list[tuple[int, int, int]] | None = None  # a local colour table
    control: bool = True  # write a Graphic Control Extension


def _lzw(indices: list[int]) -> bytes:
    """LZW data of 8-bit indices without compression: every index a literal 9-bit code, the
    table cleared before it would grow to 10 bits."""
    clear, end = 256, 257
    codes = [clear]
    for n, index in enumerate(indices):
        if n and n % 254 == 0:
            codes.append(clear)
        codes.append(index)
    codes.append(end)
    acc = bits = 0
    out = bytearray()
    for code in codes:
        acc |= code << bits
        bits += 9
        while bits >= 8:
            out.append(acc & 255)
            acc >>= 8
            bits -= 8
    if bits:
        out.append(acc)
    blocks = b"".join(bytes([len(out[i : i + 255])]) + out[i : i + 255] for i in range(0, len(out), 255))
    return bytes([8]) + blocks + b"\0"


def _table(colours: list[tuple[int, int, int]]) -> bytes:
    return b"".join(bytes(c) for c in colours).ljust(768, b"\0")


def gif(size: tuple[int, int], palette: list[tuple[int, int, int]], images: list[GifImage],
        loop: int | None = None) -> bytes:
    """A GIF89a of ``size`` (width, height) with a 256-entry global table; a NETSCAPE2.0 block
    with ``loop`` repeats unless ``loop`` is None."""
    out = b"GIF89a" + struct.pack("<HHBBB", size[0], size[1], 0xF7, 0, 0) + _table(palette)
    if loop is not None:
        out += b"!\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", loop) + b"\0"
    for image in images:
        if image.control:
            flags = (image.disposal << 2) | (image.transparent is not None)
            out += b"!\xf9\x04" + struct.pack("<BHB", flags, image.delay, image.transparent or 0) + b"\0"
        h, w = len(image.indices), len(image.indices[0])
        local = 0x87 if image.palette else 0
        out += b"," + struct.pack("<HHHHB", image.x, image.y, w, h, local)
        if image.palette:
            out += _table(image.palette)
        out += _lzw([v for row in image.indices for v in row])
    return out + b";"


@dataclass
class PngFrame:
    """One frame of an APNG: ``(h, w, 4) uint8`` pixels at (x, y)."""

    rgba: np.ndarray
    x: int = 0
    y: int = 0
    delay: tuple[int, int] = (1, 10)  # numerator, denominator (seconds)
    dispose: int = 0  # 0 none, 1 background, 2 previous
    blend: int = 0  # 0 source, 1 over


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def apng(size: tuple[int, int], frames: list[PngFrame], plays: int = 0, default: np.ndarray | None = None) -> bytes:
    """An RGBA APNG of ``size`` (width, height); ``default`` is an IDAT image that is not part
    of the animation (else the first frame is the IDAT)."""
    def pixels(rgba: np.ndarray) -> bytes:
        raw = b"".join(b"\0" + row.tobytes() for row in np.ascontiguousarray(rgba, np.uint8))
        return zlib.compress(raw)

    out = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", size[0], size[1], 8, 6, 0, 0, 0))
    out += _chunk(b"acTL", struct.pack(">II", len(frames), plays))
    if default is not None:
        out += _chunk(b"IDAT", pixels(default))
    sequence = 0
    for n, frame in enumerate(frames):
        h, w = frame.rgba.shape[:2]
        out += _chunk(b"fcTL", struct.pack(">IIIIIHHBB", sequence, w, h, frame.x, frame.y, *frame.delay,
                                           frame.dispose, frame.blend))
        sequence += 1
        if n == 0 and default is None:
            out += _chunk(b"IDAT", pixels(frame.rgba))
        else:
            out += _chunk(b"fdAT", struct.pack(">I", sequence) + pixels(frame.rgba))
            sequence += 1
    return out + _chunk(b"IEND", b"")
