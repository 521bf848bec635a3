"""Input — an animated GIF → every frame as a browser shows it, with its delay and loop block.

Pillow composites the frames of a GIF itself, but not as the viewers people use do (tried on
Pillow 13): a frame whose disposal is unspecified inherits the previous frame's disposal, and
"restore to background" fills the area with the background colour, opaque, when the file has no
transparent index. Chromium and Firefox clear that area to transparent and read each frame's
disposal alone. So depixel walks the GIF's blocks itself and composites as they do; Pillow only
decodes the pixels of each frame (the frame's LZW data rewrapped as a one-image GIF, its own
colour table as the global one), so the colours are always the frame's own palette's, whatever
``GifImagePlugin.LOADING_STRATEGY`` says.

The canvas is the logical screen: it starts transparent; a frame draws its non-transparent
pixels inside its rectangle (clipped to the screen); after it is shown, disposal 2 clears the
rectangle to transparent, disposal 3 restores what was there before it, others keep it.
"""
from __future__ import annotations

import dataclasses
import io
import struct
from collections.abc import Iterator

import numpy as np

from ..errors import InputError
from ..limits import check_frames, check_frames_pixels, check_pixels
from .pillow import bomb_error, is_bomb, quiet_pillow

#: how a GIF starts
SIGNATURES = (b"GIF87a", b"GIF89a")
#: disposal methods (GIF89a, Graphic Control Extension): 2 clears the frame's area, 3 restores it
RESTORE_BACKGROUND, RESTORE_PREVIOUS = 2, 3


@dataclasses.dataclass(frozen=True)
class GifFrame:
    """One image of a GIF as stored: its rectangle, colour table, delay and disposal."""

    x: int
    y: int
    width: int
    height: int
    palette: bytes  # RGB triples, the local table or else the global one (b"": none, greys)
    interlaced: bool
    data: bytes  # LZW minimum code size, then the data sub-blocks and their terminator
    delay: int  # milliseconds as stored (hundredths × 10)
    disposal: int
    transparent: int | None  # the transparent colour index


@dataclasses.dataclass(frozen=True)
class GifFile:
    """The blocks of a GIF: the logical screen's size, its images and the loop block."""

    width: int
    height: int
    frames: tuple[GifFrame, ...]
    loop: int | None  # the NETSCAPE2.0 block's count; None when the file has none


def parse_gif(data: bytes, name: str, max_frames: int | None = None) -> GifFile:
    """Walk the blocks of a GIF (no pixel decoded); more than ``max_frames`` images are refused
    as soon as they are found. The file may end after a complete image without its trailer;
    anything else malformed is an :class:`InputError`."""
    if not data.startswith(SIGNATURES):
        raise InputError(f"{name}: not a GIF file")
    if len(data) < 13:
        raise InputError(f"{name}: not an image (a GIF signature without the header that follows it)")
    width, height, flags = struct.unpack_from("<HHB", data, 6)
    if width == 0 or height == 0:
        raise InputError(f"{name}: image has zero size")
    pos = 13
    palette = b""
    if flags & 0x80:
        size = 3 << ((flags & 7) + 1)
        palette, pos = data[pos : pos + size], pos + size
    frames: list[GifFrame] = []
    loop: int | None = None
    control = (0, 0, None)  # the delay, disposal and transparent index of the next image
    try:
        while pos < len(data):
            kind, pos = data[pos], pos + 1
            if kind == 0x3B:  # trailer
                break
            if kind == 0x21:  # extension: a label, then data sub-blocks
                label = data[pos]
                blocks, pos = _sub_blocks(data, pos + 1)
                if label == 0xF9 and blocks and len(blocks[0]) >= 4:
                    packed, delay, index = struct.unpack_from("<BHB", blocks[0])
                    control = (delay * 10, (packed >> 2) & 7, index if packed & 1 else None)
                elif (label == 0xFF and loop is None and len(blocks) >= 2 and blocks[0] == b"NETSCAPE2.0"
                      and len(blocks[1]) >= 3 and blocks[1][0] == 1):
                    loop = struct.unpack_from("<H", blocks[1], 1)[0]
                continue
            if kind != 0x2C:
                raise InputError(f"{name}: truncated or corrupt image data")
            x, y, w, h, packed = struct.unpack_from("<HHHHB", data, pos)
            pos += 9
            local = palette
            if packed & 0x80:
                size = 3 << ((packed & 7) + 1)
                local, pos = data[pos : pos + size], pos + size
            start = pos
            _, pos = _sub_blocks(data, pos + 1)
            delay, disposal, transparent = control
            frames.append(GifFrame(x, y, w, h, local, bool(packed & 0x40), data[start:pos], delay, disposal,
                                   transparent))
            control = (0, 0, None)
            check_frames(name, len(frames), max_frames)
    except (IndexError, struct.error):  # a block runs past the end of the data
        raise InputError(f"{name}: truncated or corrupt image data") from None
    if not frames:
        raise InputError(f"{name}: a GIF without images")
    return GifFile(width, height, tuple(frames), loop)


def _sub_blocks(data: bytes, pos: int) -> tuple[list[bytes], int]:
    """The data sub-blocks from ``pos`` up to their zero terminator, and the place after it."""
    blocks: list[bytes] = []
    while True:
        size = data[pos]
        if size == 0:
            return blocks, pos + 1
        if pos + 1 + size > len(data):
            raise IndexError("a sub-block runs past the end")
        blocks.append(data[pos + 1 : pos + 1 + size])
        pos += 1 + size


def check_gif(gif: GifFile, name: str, max_pixels: int | None, whole: bool = True) -> None:
    """The pixel limits, before anything is decoded: the screen and every image within
    ``max_pixels``, and, for the ``whole`` animation, the screen × images too (as
    :func:`depixel.prepare.image.load_frames` counts)."""
    check_pixels(name, gif.width, gif.height, max_pixels)
    if whole:
        check_frames_pixels(name, len(gif.frames), len(gif.frames) * gif.width * gif.height, max_pixels)
    for frame in gif.frames:
        check_pixels(name, frame.width, frame.height, max_pixels)


def composite(gif: GifFile, name: str) -> Iterator[np.ndarray]:
    """Every frame as a browser shows it, in order, each decoded when asked for: ``(H, W, 4)
    uint8`` RGBA each (module docstring)."""
    canvas = np.zeros((gif.height, gif.width, 4), np.uint8)
    for frame in gif.frames:
        h = max(0, min(frame.height, gif.height - frame.y))  # the rectangle clipped to the screen
        w = max(0, min(frame.width, gif.width - frame.x))
        indices = decode_indices(frame, name)[:h, :w]
        rows, cols = slice(frame.y, frame.y + h), slice(frame.x, frame.x + w)
        before = canvas[rows, cols].copy() if frame.disposal == RESTORE_PREVIOUS else None
        colours = _colour_table(frame.palette)
        drawn = np.ones(indices.shape, bool) if frame.transparent is None else indices != frame.transparent
        area = canvas[rows, cols]
        area[drawn] = colours.take(indices[drawn], axis=0)
        yield canvas.copy()
        if frame.disposal == RESTORE_BACKGROUND:
            area[...] = 0
        elif before is not None:
            area[...] = before


def _colour_table(palette: bytes) -> np.ndarray:
    """``(256, 4) uint8`` opaque colours of a colour table; a frame with none is read in greys
    (as Pillow does), and an index past the table's end is black."""
    table = np.zeros((256, 4), np.uint8)
    table[:, 3] = 255
    if not palette:
        table[:, :3] = np.arange(256, dtype=np.uint8)[:, None]
        return table
    rgb = np.frombuffer(palette[: 768 - len(palette) % 3], np.uint8).reshape(-1, 3)
    table[: rgb.shape[0], :3] = rgb
    return table


def decode_indices(frame: GifFrame, name: str) -> np.ndarray:
    """``(h, w) uint8`` colour indices of one image, decoded by Pillow from its LZW data."""
    from PIL import Image  # noqa: PLC0415

    if frame.width == 0 or frame.height == 0:
        return np.zeros((frame.height, frame.width), np.uint8)
    # any 256-entry table: only the indices are read
    one = (b"GIF89a" + struct.pack("<HHBBB", frame.width, frame.height, 0x87, 0, 0) + bytes(768)
           + b"," + struct.pack("<HHHHB", 0, 0, frame.width, frame.height, 0x40 if frame.interlaced else 0)
           + frame.data + b";")
    try:
        with quiet_pillow(), Image.open(io.BytesIO(one)) as img:
            img.load()
            return np.asarray(img, dtype=np.uint8)
    except MemoryError:
        raise InputError(f"{name}: not enough memory to decode a {frame.width}x{frame.height} image") from None
    except Exception as exc:  # Pillow raises OSError, SyntaxError, ValueError, ...
        if is_bomb(exc):
            raise bomb_error(name) from None
        raise InputError(f"{name}: truncated or corrupt image data") from None
