"""Stage 0 — input: one frame of an :class:`~depixel.prepare.aseprite_format.AsepriteFile`
composited as Aseprite shows it → ``(H, W, 4) uint8`` RGBA.

Each cel's pixels are decoded (raw or zlib, never past the cel's declared size: a zlib bomb
stops at that size), turned into RGBA (grey ``(v, v, v, a)``; indices through the frame's
palette, the transparent index left out) and laid over the canvas in Aseprite's drawing
order with its Normal blending (``rgba_blender_normal`` in Aseprite's ``doc/blend_funcs.cpp``,
integer for integer: the opacity of cel × layer, then ``Bc + (Sc - Bc)·Sa/Ra`` truncated).
Hidden layers (or layers in a hidden group) and reference layers are left out; the
background layer is drawn first. Groups are flattened into their parent unless the file
says its groups are composited apart (header flag 2), then with their own opacity. Cels are
ordered by layer and z-index (spec NOTE.5). Blend modes other than Normal and tilemap
layers are refused in one line naming the layer.
"""
from __future__ import annotations

import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..limits import MAX_FILE_BYTES, check_frame_index, check_frames, check_frames_pixels
from .aseprite_format import RAW, AsepriteFile, Cel

#: bytes a pixel of each colour mode
_BYTES = {"rgba": 4, "grayscale": 2, "indexed": 1}


@dataclass
class Decoder:
    """The cels decoded while compositing frames of one file: decoded bytes count against
    ``budget`` a frame (MAX_FILE_BYTES, as a decompressed .svgz does), and each layer's last
    decoded cel is kept, so a cel linked over many frames is decoded once."""

    ase: AsepriteFile
    budget: int = MAX_FILE_BYTES
    spent: int = 0
    last: dict[int, tuple[int, np.ndarray]] = field(default_factory=dict)  # layer → (source frame, pixels)

    def pixels(self, cel: Cel) -> np.ndarray:
        """The cel's pixels as stored: ``(h, w, bytes a pixel) uint8``."""
        kept = self.last.get(cel.layer)
        if kept is not None and kept[0] == cel.source:
            return kept[1]
        ase, depth = self.ase, _BYTES[self.ase.mode]
        size = cel.width * cel.height * depth
        where = f"{ase.name}: the cel of layer {ase.layers[cel.layer].name!r} in frame {cel.source}"
        if self.spent + size > self.budget:
            raise InputError(f"{where} is {cel.width}x{cel.height}: a frame's cels would decode to over "
                             f"{self.budget // 2**20} MiB")
        self.spent += size
        if cel.kind == RAW:
            raw = cel.data[:size]
        else:  # a tilemap's cels are refused before (tilemap layers), so COMPRESSED
            raw = _inflate(cel.data, size, where)
        if len(raw) < size:
            raise InputError(f"{where} is cut short ({len(raw)} of its {size} bytes)")
        pixels = np.frombuffer(raw, np.uint8).reshape(cel.height, cel.width, depth)
        self.last[cel.layer] = (cel.source, pixels)
        return pixels


def _inflate(data: bytes, size: int, where: str) -> bytes:
    """``data`` decompressed, ``size`` bytes at most: a stream that would give more is refused
    before more is made."""
    stream = zlib.decompressobj()
    try:
        raw = stream.decompress(data, size)
        extra = stream.decompress(stream.unconsumed_tail, 1) if stream.unconsumed_tail or not stream.eof else b""
    except zlib.error:
        raise InputError(f"{where} has corrupt compressed data") from None
    if extra:
        raise InputError(f"{where} decompresses past its declared size (a zlib bomb?)")
    return raw


def frame_rgba(ase: AsepriteFile, index: int, decoder: Decoder | None = None) -> np.ndarray:
    """Frame ``index`` composited → ``(H, W, 4) uint8`` RGBA (module docstring)."""
    decoder = decoder or Decoder(ase)
    decoder.spent = 0
    canvas = np.zeros((ase.height, ase.width, 4), np.uint8)
    cels = {cel.layer: cel for cel in ase.cels[index]}
    colours = ase.colours(index) if ase.mode == "indexed" else None
    if colours is not None and any(layer.background and _shown(ase, i) for i, layer in enumerate(ase.layers)):
        canvas[...] = colours[ase.transparent_index]  # under an indexed background: its transparent colour
    for background in (True, False):  # Aseprite draws the background layer first, then the others
        _draw(canvas, ase, -1, cels, decoder, colours, background)
    return canvas


def _shown(ase: AsepriteFile, index: int) -> bool:
    """Whether layer ``index`` and every group above it are visible."""
    while index >= 0:
        if not ase.layers[index].visible:
            return False
        index = ase.layers[index].parent
    return True


def _plan(ase: AsepriteFile, parent: int, cels: dict[int, Cel]) -> list[int]:
    """The layers drawn into group ``parent`` (-1: the canvas), back to front: groups
    flattened into it unless composited apart, ordered by the cels' z-index (spec NOTE.5:
    by layer order + z-index, then z-index), hidden and reference layers left out."""
    items: list[tuple[int, int, int]] = []  # (order, z-index, layer)

    def add(group: int) -> None:
        for i, layer in enumerate(ase.layers):
            if layer.parent != group:
                continue
            order = len(items) + 1  # Aseprite numbers every layer it adds, a flattened group too
            if layer.kind == "group" and not ase.compose_groups:
                items.append((order, 0, -1 - i))  # a placeholder keeps the group's order number
                add(i)
            else:
                items.append((order, cels[i].z_index if i in cels else 0, i))

    add(parent)
    if any(z for _, z, _ in items):
        items.sort(key=lambda item: (item[0] + item[1], item[1]))
    return [i for _, _, i in items if i >= 0 and _shown(ase, i) and not ase.layers[i].reference]


def _draw(target: np.ndarray, ase: AsepriteFile, parent: int, cels: dict[int, Cel], decoder: Decoder,
          colours: np.ndarray | None, background: bool) -> None:
    """Draw the layers of group ``parent`` over ``target`` (the background layer alone, or
    every other layer)."""
    for i in _plan(ase, parent, cels):
        layer = ase.layers[i]
        if layer.kind == "group":
            image = np.zeros_like(target)
            _draw(image, ase, i, cels, decoder, colours, background)
            if image[..., 3].any():
                _refuse_blend(ase, i)
                normal_blend(target, image, layer.opacity, ~image.any(axis=2))
            continue
        if layer.background != background or i not in cels:
            continue
        cel = cels[i]
        _refuse_blend(ase, i)
        if layer.kind == "tilemap":
            raise InputError(f"{ase.name}: the cel of layer {layer.name!r} in frame {cel.frame} is a tilemap; "
                             "depixel reads image layers only (convert the layer to a normal layer in Aseprite)")
        _draw_cel(target, ase, cel, decoder.pixels(cel), colours, mul_un8(cel.opacity, layer.opacity))


def _refuse_blend(ase: AsepriteFile, index: int) -> None:
    layer = ase.layers[index]
    if layer.blend != "normal":
        raise InputError(f"{ase.name}: layer {layer.name!r} uses the {layer.blend.title()} blend mode; depixel "
                         "composites Normal layers only (set it to Normal, or hide the layer, in Aseprite)")


def _draw_cel(target: np.ndarray, ase: AsepriteFile, cel: Cel, pixels: np.ndarray, colours: np.ndarray | None,
              opacity: int) -> None:
    """Lay one cel's pixels over ``target`` at its place, clipped to the canvas."""
    height, width = target.shape[:2]
    x0, y0 = max(cel.x, 0), max(cel.y, 0)
    x1, y1 = min(cel.x + cel.width, width), min(cel.y + cel.height, height)
    if x0 >= x1 or y0 >= y1:
        return
    part = pixels[y0 - cel.y:y1 - cel.y, x0 - cel.x:x1 - cel.x]
    if ase.mode == "rgba":
        rgba = part
        skip = ~part.any(axis=2)  # the mask colour: 0, transparent black
    elif ase.mode == "grayscale":
        value, alpha = part[..., 0], part[..., 1]
        rgba = np.stack([value, value, value, alpha], axis=-1)
        skip = (value == 0) & (alpha == 0)
    else:
        assert colours is not None
        rgba = colours[part[..., 0]]
        skip = part[..., 0] == ase.transparent_index
    normal_blend(target[y0:y1, x0:x1], rgba, opacity, skip)


def mul_un8(a, b):
    """``a·b/255`` rounded as Aseprite (pixman's MUL_UN8) rounds it; ints or int arrays."""
    t = a * b + 128
    return ((t >> 8) + t) >> 8


def normal_blend(backdrop: np.ndarray, src: np.ndarray, opacity: int, skip: np.ndarray | np.bool_) -> None:
    """Aseprite's Normal blending of ``src`` over ``backdrop`` (both ``(h, w, 4) uint8``, the
    backdrop changed in place) at ``opacity``, except where ``skip``."""
    b = backdrop.astype(np.int32)
    s = src.astype(np.int32)
    sa = mul_un8(s[..., 3], opacity)
    ba = b[..., 3]
    ra = sa + ba - mul_un8(ba, sa)
    delta = (s[..., :3] - b[..., :3]) * sa[..., None]
    safe = np.maximum(ra, 1)[..., None]
    rgb = b[..., :3] + np.sign(delta) * (np.abs(delta) // safe)  # C's division truncates toward zero
    out = np.concatenate([rgb, ra[..., None]], axis=-1)
    empty = (ba == 0)[..., None]
    out = np.where(empty, np.concatenate([s[..., :3], sa[..., None]], axis=-1), out)  # over nothing: the source
    keep = (skip | (s[..., 3] == 0) & (ba != 0))[..., None]
    backdrop[...] = np.where(keep, b, out).astype(np.uint8)


def aseprite_frames(ase: AsepriteFile, only: int | None, max_pixels: int | None,
                    max_frames: int | None) -> Iterator[tuple[int, np.ndarray]]:
    """Frame ``only`` (None: every frame, in order) composited: ``(index, (H, W, 4) uint8)``.
    The limits are checked first: frame ``only`` under ``max_frames`` and the file's frames;
    all of them within ``max_frames`` and their pixels in all within ``max_pixels``."""
    n, name = ase.n_frames, ase.name
    if only is None:
        check_frames(name, n, max_frames)
        check_frames_pixels(name, n, n * ase.width * ase.height, max_pixels)
    else:
        check_frame_index(name, only, max_frames)
        if only >= n:
            raise InputError(f"{name}: has {n} frame(s), no frame {only}")
    decoder = Decoder(ase)
    for index in range(n) if only is None else (only,):
        yield index, frame_rgba(ase, index, decoder)
