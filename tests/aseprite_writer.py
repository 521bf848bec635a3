"""A small writer of Aseprite files for the tests, written from Aseprite's file specification
(docs/ase-file-specs.md in the aseprite repository), independently of the reader.

What it can write, and so what the tests cover:

* the three colour modes: RGBA (32 bpp), grayscale (16 bpp, value + alpha), indexed (8 bpp,
  with the header's transparent index);
* layers: image and group layers with child levels (nesting), visible or hidden, background,
  reference, opacity (the header's "opacity is valid" flag on by default), blend mode, and the
  header flag that composites groups apart with their own opacity; tilemap layers (type 2,
  with a tileset index) for the refusal;
* cels: compressed (zlib), raw, linked (to a cel of an earlier frame), at any position
  (partly off the canvas too), with cel opacity and z-index;
* per-frame durations (and the header's deprecated speed for frames of duration 0), the
  frame header's old and new chunk counts;
* tags (from, to, direction, repeat, name), the new palette chunk (0x2019) with colour names,
  the old palette chunks (0x0004, 0x0011: 6-bit colours), slices;
* hand-made damage for the malformed cases is done by the tests on the bytes written here.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

#: the header flags: layer opacity valid, group opacity/blend valid (composite groups apart)
OPACITY_VALID, GROUPS_APART = 1, 2


@dataclass
class LayerSpec:
    name: str
    kind: int = 0  # 0 image, 1 group, 2 tilemap
    level: int = 0
    visible: bool = True
    background: bool = False
    reference: bool = False
    opacity: int = 255
    blend: int = 0


@dataclass
class CelSpec:
    layer: int
    pixels: np.ndarray | None = None  # (h, w, bytes a pixel) uint8 as stored; (h, w) for indexed
    x: int = 0
    y: int = 0
    opacity: int = 255
    kind: str = "compressed"  # "compressed", "raw" or "linked"
    link: int = 0  # the frame a linked cel links to
    z: int = 0


@dataclass
class FrameSpec:
    cels: list[CelSpec] = field(default_factory=list)
    duration: int = 100
    extra: list[bytes] = field(default_factory=list)  # chunks written as given (type and data)


def string(text: str) -> bytes:
    raw = text.encode("utf-8")
    return struct.pack("<H", len(raw)) + raw


def chunk(kind: int, data: bytes) -> bytes:
    return struct.pack("<IH", 6 + len(data), kind) + data


def layer_chunk(layer: LayerSpec) -> bytes:
    flags = (1 if layer.visible else 0) | 2 | (8 if layer.background else 0) | (64 if layer.reference else 0)
    data = struct.pack("<HHHHHHB3x", flags, layer.kind, layer.level, 0, 0, layer.blend, layer.opacity)
    data += string(layer.name)
    if layer.kind == 2:
        data += struct.pack("<I", 0)
    return chunk(0x2004, data)


def cel_chunk(cel: CelSpec) -> bytes:
    kind = {"raw": 0, "linked": 1, "compressed": 2}[cel.kind]
    data = struct.pack("<HhhBHh5x", cel.layer, cel.x, cel.y, cel.opacity, kind, cel.z)
    if cel.kind == "linked":
        return chunk(0x2005, data + struct.pack("<H", cel.link))
    assert cel.pixels is not None
    pixels = np.ascontiguousarray(cel.pixels, np.uint8)
    height, width = pixels.shape[:2]
    raw = pixels.tobytes()
    return chunk(0x2005, data + struct.pack("<HH", width, height) + (raw if cel.kind == "raw" else zlib.compress(raw)))


def palette_chunk(colours: np.ndarray, names: dict[int, str] | None = None, first: int = 0) -> bytes:
    """The new palette chunk: ``colours`` ``(N, 4)`` from index ``first``, the palette ``first + N`` long."""
    names = names or {}
    size = first + len(colours)
    data = struct.pack("<III8x", size, first, size - 1)
    for i, rgba in enumerate(np.asarray(colours, np.uint8).tolist()):
        name = names.get(first + i)
        data += struct.pack("<H4B", 1 if name is not None else 0, *rgba) + (string(name) if name is not None else b"")
    return chunk(0x2019, data)


def old_palette_chunk(rgb: np.ndarray, six_bit: bool = False, skip: int = 0) -> bytes:
    """An old palette chunk (0x0004, or 0x0011 with 0-63 values): one packet."""
    rgb = np.asarray(rgb, np.uint8)
    data = struct.pack("<HBB", 1, skip, len(rgb) % 256) + rgb.tobytes()
    return chunk(0x0011 if six_bit else 0x0004, data)


def tags_chunk(tags: list[tuple[str, int, int, int, int]]) -> bytes:
    """``(name, from, to, direction, repeat)`` each."""
    data = struct.pack("<H8x", len(tags))
    for name, first, last, direction, repeat in tags:
        data += struct.pack("<HHBH6x3Bx", first, last, direction, repeat, 0, 0, 0) + string(name)
    return chunk(0x2018, data)


def slice_chunk(name: str, keys: list[tuple[int, int, int, int, int]]) -> bytes:
    data = struct.pack("<III", len(keys), 0, 0) + string(name)
    for key in keys:
        data += struct.pack("<IiiII", *key)
    return chunk(0x2022, data)


def aseprite_bytes(width: int, height: int, layers: list[LayerSpec], frames: list[FrameSpec], *,
                   depth: int = 32, transparent_index: int = 0, flags: int = OPACITY_VALID, speed: int = 100,
                   first_chunks: list[bytes] | None = None, old_count: bool = False) -> bytes:
    """A whole file. ``first_chunks`` (palette, tags, slices…) go in the first frame after
    the layers; ``old_count`` writes the chunk count in the frame header's old field only."""
    body = b""
    for index, frame in enumerate(frames):
        chunks = []
        if index == 0:
            chunks += [layer_chunk(layer) for layer in layers] + list(first_chunks or [])
        chunks += [cel_chunk(cel) for cel in frame.cels] + frame.extra
        data = b"".join(chunks)
        count = len(chunks)
        head = struct.pack("<IHHHxxI", 16 + len(data), 0xF1FA, count if old_count else min(count, 0xFFFF),
                           frame.duration, 0 if old_count else count)
        body += head + data
    header = struct.pack("<IHHHHHIHIIB3xHBBhhHH", 128 + len(body), 0xA5E0, len(frames), width, height, depth, flags,
                         speed, 0, 0, transparent_index, 256 if depth == 8 else 0, 1, 1, 0, 0, 0, 0)
    header += bytes(128 - len(header))
    return header + body


def rgba_cel(layer: int, rgba, **keywords) -> CelSpec:
    """A cel of ``(h, w, 4)`` RGBA pixels."""
    return CelSpec(layer, np.asarray(rgba, np.uint8), **keywords)


def one_layer(rgba: np.ndarray, **keywords) -> bytes:
    """A one-layer, one-frame RGBA file of ``rgba`` (the whole canvas one cel)."""
    height, width = rgba.shape[:2]
    return aseprite_bytes(width, height, [LayerSpec("Layer 1")], [FrameSpec([rgba_cel(0, rgba)])], **keywords)
