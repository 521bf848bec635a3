"""Stage 0 — input: the structure of an Aseprite file (``.aseprite``/``.ase``): layers, cels,
durations, tags, palette, slices.

Written from Aseprite's published file specification (docs/ase-file-specs.md in the
aseprite repository): a 128-byte header, then each frame's chunks (layers, cels, palette,
tags, slices). :func:`parse_aseprite` reads the structure and keeps each cel's pixel data
as stored; :mod:`.aseprite_compose` decodes and composites a frame when it is asked for,
so reading frame k costs one frame's work and memory, whatever the file holds
(:mod:`.aseprite` puts the two together).

Every size is checked before it is used: a truncated chunk or a size past its chunk is one
:class:`InputError` line, and the canvas is checked against ``max_pixels`` from the header.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..limits import DEFAULT_MAX_PIXELS, check_pixels

MAGIC = 0xA5E0
FRAME_MAGIC = 0xF1FA
HEADER_BYTES = 128
#: colour depth (bits per pixel) → colour mode
MODES = {32: "rgba", 16: "grayscale", 8: "indexed"}
#: Aseprite's blend modes by number (the layer chunk's field)
BLEND_MODES = ("normal", "multiply", "screen", "overlay", "darken", "lighten", "color dodge", "color burn",
               "hard light", "soft light", "difference", "exclusion", "hue", "saturation", "color", "luminosity",
               "addition", "subtract", "divide")
#: a tag's loop direction by number
DIRECTIONS = ("forward", "reverse", "pingpong", "pingpong reverse")
LAYER_KINDS = ("image", "group", "tilemap")
# header flags, layer flags, cel types, chunk types
_OPACITY_VALID, _GROUP_BLEND_VALID, _LAYER_UUIDS = 1, 2, 4
_VISIBLE, _BACKGROUND, _REFERENCE = 1, 8, 64
RAW, LINKED, COMPRESSED, TILEMAP = range(4)
_OLD_PALETTE, _OLD_PALETTE_6BIT, _LAYER, _CEL, _TAGS, _PALETTE, _SLICE = \
    0x0004, 0x0011, 0x2004, 0x2005, 0x2018, 0x2019, 0x2022


@dataclass(frozen=True)
class Layer:
    """A layer as the file declares it. ``parent`` is the index of its group (-1: top level);
    ``opacity`` and ``blend`` are those Aseprite applies (255 and "normal" where the file
    says they are not valid)."""

    name: str
    kind: str  # "image", "group" or "tilemap"
    parent: int
    visible: bool
    background: bool
    reference: bool
    opacity: int
    blend: str


@dataclass(frozen=True)
class Tag:
    """A named range of frames, ``first`` to ``last`` inclusive, played in ``direction``
    ("forward", "reverse", "pingpong", "pingpong reverse") ``repeat`` times (0: unspecified)."""

    name: str
    first: int
    last: int
    direction: str
    repeat: int


@dataclass(frozen=True)
class PaletteEntry:
    """One colour of the palette, ``(r, g, b, a)``, with its name when it has one."""

    rgba: tuple[int, int, int, int]
    name: str | None = None


@dataclass(frozen=True)
class SliceKey:
    """Where a slice is from ``frame`` on: its rectangle on the canvas (``width`` 0: hidden)."""

    frame: int
    x: int
    y: int
    width: int
    height: int


@dataclass(frozen=True)
class Slice:
    """A named region of the canvas, keyed by frame."""

    name: str
    keys: tuple[SliceKey, ...]


@dataclass(frozen=True)
class Cel:
    """One layer's image in one frame: its place, opacity and z-index, and its pixels as
    stored (``data``: raw or zlib-compressed, per ``kind``). A linked cel is resolved to the
    cel whose pixels it shares: ``source`` is that cel's frame (its own frame otherwise)."""

    layer: int
    frame: int
    x: int
    y: int
    opacity: int
    z_index: int
    kind: int  # RAW, COMPRESSED or TILEMAP (a linked cel takes its source's kind)
    width: int
    height: int
    data: bytes
    source: int


@dataclass(frozen=True, eq=False)
class AsepriteFile:
    """The structure of an Aseprite file, pixels still stored: what :mod:`.aseprite_compose`
    needs to composite any frame. ``cels[f]`` are frame f's cels; ``palettes[f]`` the colours
    in force at frame f as ``(N, 4) uint8`` (a palette chunk changes it from its frame on)."""

    name: str
    width: int
    height: int
    mode: str  # "rgba", "grayscale" or "indexed"
    transparent_index: int  # the palette index that is transparent (indexed only)
    compose_groups: bool  # header flag 2: groups are composited apart, with their opacity and blend
    pixel_ratio: tuple[int, int]
    layers: tuple[Layer, ...]
    cels: tuple[tuple[Cel, ...], ...]
    durations: tuple[int, ...]
    tags: tuple[Tag, ...]
    palette: tuple[PaletteEntry, ...]  # the first frame's
    palettes: tuple[tuple[int, np.ndarray], ...]
    slices: tuple[Slice, ...]

    @property
    def n_frames(self) -> int:
        return len(self.durations)

    def colours(self, frame: int) -> np.ndarray:
        """The ``(256, 4) uint8`` RGBA colours of indices 0-255 at ``frame``."""
        return next(colours for first, colours in reversed(self.palettes) if first <= frame)


def is_aseprite(data: bytes | memoryview) -> bool:
    """Whether ``data`` starts like an Aseprite file (magic number 0xA5E0 at byte 4)."""
    return len(data) >= 6 and bytes(data[4:6]) == MAGIC.to_bytes(2, "little")


class _Reader:
    """Little-endian fields from ``data[pos:end]``; running past ``end`` is a truncated file."""

    def __init__(self, data: memoryview, pos: int, end: int, name: str, what: str) -> None:
        self.data, self.pos, self.end, self.name, self.what = data, pos, end, name, what

    def take(self, n: int) -> memoryview:
        if n < 0 or self.pos + n > self.end:
            raise InputError(f"{self.name}: truncated or corrupt Aseprite file ({self.what} is cut short)")
        self.pos += n
        return self.data[self.pos - n:self.pos]

    def fields(self, fmt: str) -> tuple[int, ...]:
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def one(self, fmt: str) -> int:
        return self.fields(fmt)[0]

    def string(self) -> str:
        return bytes(self.take(self.one("H"))).decode("utf-8", errors="replace")

    def rest(self) -> bytes:
        return bytes(self.take(self.end - self.pos))


def parse_aseprite(data: bytes, name: str = "<aseprite>", max_pixels: int | None = DEFAULT_MAX_PIXELS
                   ) -> AsepriteFile:
    """Read the structure of an Aseprite file (``data``: its bytes). The canvas is checked
    against ``max_pixels`` from the header, before anything else is read."""
    view = memoryview(data)
    head = _Reader(view, 0, len(view), name, "the header")
    if not is_aseprite(data):
        raise InputError(f"{name}: not an Aseprite file (no 0xA5E0 magic number)")
    (_, _, n_frames, width, height, depth, flags, speed, _, _, transparent, _, _, _, _, ratio_w, ratio_h) = \
        head.fields("IHHHHHIHIIB3BHBB")
    head.take(HEADER_BYTES - head.pos)
    if depth not in MODES:
        raise InputError(f"{name}: Aseprite colour depth {depth} is not 8, 16 or 32 bits")
    if width == 0 or height == 0:
        raise InputError(f"{name}: image has zero size")
    if n_frames == 0:
        raise InputError(f"{name}: Aseprite file declares no frames")
    check_pixels(name, width, height, max_pixels)
    state = _State(name, depth, flags, n_frames)
    pos = HEADER_BYTES
    for frame in range(n_frames):
        pos = _read_frame(view, pos, frame, speed, state)
    return AsepriteFile(
        name=name, width=width, height=height, mode=MODES[depth],
        transparent_index=transparent if depth == 8 else 0, compose_groups=bool(flags & _GROUP_BLEND_VALID),
        pixel_ratio=(ratio_w, ratio_h) if ratio_w and ratio_h else (1, 1), layers=tuple(state.layers),
        cels=tuple(tuple(sorted(cels.values(), key=lambda c: c.layer)) for cels in state.cels),
        durations=tuple(state.durations), tags=tuple(state.tags), palette=state.named_palette(),
        palettes=tuple(state.palettes), slices=tuple(state.slices))


class _State:
    """What the chunks read so far have declared."""

    def __init__(self, name: str, depth: int, flags: int, n_frames: int) -> None:
        self.name, self.depth, self.flags = name, depth, flags
        self.layers: list[Layer] = []
        self.levels: list[int] = []  # each layer's child level, to find its parent
        self.cels: list[dict[int, Cel]] = [{} for _ in range(n_frames)]
        self.durations: list[int] = []
        self.tags: list[Tag] = []
        self.slices: list[Slice] = []
        self.colours = np.zeros((256 if depth == 8 else 0, 4), np.uint8)  # the palette being read
        self.names: dict[int, str] = {}
        self.new_palette_seen = False
        self.changed = True  # the colours changed in the frame being read
        self.palettes: list[tuple[int, np.ndarray]] = []
        self.first_palette: tuple[np.ndarray, dict[int, str]] | None = None

    def named_palette(self) -> tuple[PaletteEntry, ...]:
        colours, names = self.first_palette or (self.colours, self.names)
        return tuple(PaletteEntry((r, g, b, a), names.get(i)) for i, (r, g, b, a) in enumerate(colours.tolist()))


def _read_frame(view: memoryview, pos: int, frame: int, speed: int, state: _State) -> int:
    """Read frame ``frame``'s header and chunks from ``pos``; the position of the next frame."""
    name = state.name
    head = _Reader(view, pos, len(view), name, f"frame {frame}'s header")
    size, magic, old_count, duration, _, new_count = head.fields("IHHHHI")
    if magic != FRAME_MAGIC or size < 16 or pos + size > len(view):
        raise InputError(f"{name}: truncated or corrupt Aseprite file (frame {frame} "
                         + ("has no 0xF1FA magic number)" if magic != FRAME_MAGIC else f"declares {size} bytes)"))
    end = pos + size
    state.durations.append(duration or speed)
    count = new_count or old_count
    at = head.pos
    for _ in range(count):
        chunk = _Reader(view, at, end, name, f"a chunk of frame {frame}")
        chunk_size, kind = chunk.fields("IH")
        if chunk_size < 6 or at + chunk_size > end:
            raise InputError(f"{name}: truncated or corrupt Aseprite file (a chunk of frame {frame} declares "
                             f"{chunk_size} bytes, past its frame)")
        chunk.end = at + chunk_size
        chunk.what = f"chunk 0x{kind:04X} of frame {frame}"
        _read_chunk(kind, chunk, frame, state)
        at += chunk_size
    if state.changed:
        colours = np.zeros((256, 4), np.uint8)
        colours[:min(256, len(state.colours))] = state.colours[:256]
        state.palettes.append((frame, colours))
        state.changed = False
    if frame == 0:
        state.first_palette = (state.colours.copy(), dict(state.names))
    return end


def _read_chunk(kind: int, r: _Reader, frame: int, state: _State) -> None:
    if kind == _LAYER:
        _read_layer(r, state)
    elif kind == _CEL:
        _read_cel(r, frame, state)
    elif kind == _PALETTE:
        size, first, last = r.fields("III")
        r.take(8)
        if size > 65536 or first > last or last >= size:
            raise InputError(f"{state.name}: corrupt Aseprite palette (entries {first} to {last} of {size})")
        _resize_palette(state, size)
        for index in range(first, last + 1):
            flags, *rgba = r.fields("H4B")
            state.colours[index] = rgba
            if flags & 1:
                state.names[index] = r.string()
        state.new_palette_seen = state.changed = True
    elif kind in (_OLD_PALETTE, _OLD_PALETTE_6BIT) and not state.new_palette_seen:
        index = 0
        for _ in range(r.one("H")):
            skip, count = r.fields("BB")
            index += skip
            count = count or 256
            if index + count > 256:
                raise InputError(f"{state.name}: corrupt Aseprite palette (an old palette chunk past 256 colours)")
            _resize_palette(state, max(len(state.colours), index + count))
            rgb = np.frombuffer(r.take(3 * count), np.uint8).reshape(count, 3).astype(np.int64)
            if kind == _OLD_PALETTE_6BIT:
                rgb = (rgb & 63) << 2 | (rgb & 63) >> 4  # 0-63 → 0-255 as Aseprite scales it
            state.colours[index:index + count, :3], state.colours[index:index + count, 3] = rgb, 255
            index += count
        state.changed = True
    elif kind == _TAGS:
        count = r.one("H")
        r.take(8)
        for _ in range(count):
            first, last, direction, repeat = r.fields("HHBH")
            r.take(10)
            tag_name = r.string()
            if first > last or last >= len(state.cels):
                raise InputError(f"{state.name}: corrupt Aseprite tag {tag_name!r} (frames {first} to {last} "
                                 f"of {len(state.cels)})")
            state.tags.append(Tag(tag_name, first, last, DIRECTIONS[direction] if direction < 4 else "forward",
                                  repeat))
    elif kind == _SLICE:
        count, flags, _ = r.fields("III")
        slice_name = r.string()
        keys = []
        for _ in range(count):
            key = SliceKey(*r.fields("IiiII"))
            r.take((16 if flags & 1 else 0) + (8 if flags & 2 else 0))
            keys.append(key)
        state.slices.append(Slice(slice_name, tuple(keys)))
    # other chunks (cel extra, colour profile, external files, tilesets, user data, masks) do
    # not change the pixels of a frame composited at 1:1


def _resize_palette(state: _State, size: int) -> None:
    if size != len(state.colours):
        colours = np.zeros((size, 4), np.uint8)
        keep = min(size, len(state.colours))
        colours[:keep] = state.colours[:keep]
        state.colours = colours
        state.names = {i: n for i, n in state.names.items() if i < size}


def _read_layer(r: _Reader, state: _State) -> None:
    flags, kind, level, _, _, blend, opacity = r.fields("HHHHHHB")
    r.take(3)
    layer_name = r.string()
    if kind >= len(LAYER_KINDS):
        raise InputError(f"{state.name}: layer {layer_name!r} has an unknown Aseprite layer type {kind}")
    parent = -1
    for index in range(len(state.layers) - 1, -1, -1):  # the last group one level up (spec NOTE.1)
        if state.levels[index] < level:
            parent = index if state.layers[index].kind == "group" else -1
            break
    if level and parent < 0:
        raise InputError(f"{state.name}: layer {layer_name!r} is nested (level {level}) under no group")
    background = bool(flags & _BACKGROUND)
    valid = not background and (kind != 1 or bool(state.flags & _GROUP_BLEND_VALID))
    state.levels.append(level)
    state.layers.append(Layer(
        name=layer_name, kind=LAYER_KINDS[kind], parent=parent, visible=bool(flags & _VISIBLE),
        background=background, reference=bool(flags & _REFERENCE),
        opacity=opacity if valid and state.flags & _OPACITY_VALID else 255,
        blend=(BLEND_MODES[blend] if blend < len(BLEND_MODES) else f"#{blend}") if valid else "normal"))


def _read_cel(r: _Reader, frame: int, state: _State) -> None:
    layer, x, y, opacity, kind, z_index = r.fields("HhhBHh")
    r.take(5)
    if layer >= len(state.layers):
        raise InputError(f"{state.name}: a cel of frame {frame} is on layer {layer}, which the file does not declare")
    if kind == LINKED:
        target = r.one("H")
        linked = state.cels[target].get(layer) if target < frame else None
        if linked is not None:  # a link to no earlier cel is dropped, as Aseprite drops it
            state.cels[frame][layer] = replace(linked, frame=frame, x=x, y=y, opacity=opacity, z_index=z_index)
        return
    width, height = r.fields("HH")
    if kind not in (RAW, COMPRESSED, TILEMAP):
        raise InputError(f"{state.name}: a cel of frame {frame} has an unknown Aseprite cel type {kind}")
    if width and height:
        state.cels[frame][layer] = Cel(layer, frame, x, y, opacity, z_index, kind, width, height, r.rest(), frame)
