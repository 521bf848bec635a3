"""Stage 0 — input: an Aseprite file (``.aseprite``/``.ase``) → its frames as RGBA, with
durations, tags, palette and slices.

:func:`read_aseprite` reads a whole file into an :class:`Aseprite`;
:func:`~depixel.prepare.aseprite_compose.aseprite_frames` composites the frames one at a time,
which is how :func:`depixel.prepare.image.load_image` and ``load_frames`` read an Aseprite file
(told apart by its magic number, not its name). The structure is
read by :mod:`.aseprite_format`, the frames composited by :mod:`.aseprite_compose`
(docs/inputs.md, "Aseprite files"). The canvas counts against ``max_pixels``, the frames
against ``max_frames`` and, all of them read, their pixels in all against ``max_pixels``,
as for any animation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_PIXELS
from .aseprite_compose import aseprite_frames
from .aseprite_format import AsepriteFile, Layer, PaletteEntry, Slice, SliceKey, Tag, is_aseprite, parse_aseprite
from .image import ImageSource, _describe, read_source

__all__ = ["Aseprite", "AsepriteFile", "Layer", "PaletteEntry", "Slice", "SliceKey", "Tag", "aseprite_frames",
           "is_aseprite", "parse_aseprite", "read_aseprite"]


@dataclass(frozen=True, eq=False)
class Aseprite:
    """An Aseprite file read: every frame composited as Aseprite shows it (``(H, W, 4) uint8``
    RGBA, read-only), each frame's duration (ms), the tags, the palette (names kept; the
    first frame's), the layers, the slices, and the pixel ratio the file declares (width:height,
    not applied to the frames)."""

    width: int
    height: int
    mode: str  # "rgba", "grayscale" or "indexed"
    frames: tuple[np.ndarray, ...]
    durations: tuple[int, ...]
    tags: tuple[Tag, ...]
    palette: tuple[PaletteEntry, ...]
    layers: tuple[Layer, ...]
    slices: tuple[Slice, ...]
    pixel_ratio: tuple[int, int]


def read_aseprite(source: ImageSource, *, max_pixels: int | None = DEFAULT_MAX_PIXELS,
                  max_frames: int | None = DEFAULT_MAX_FRAMES, name: str | None = None) -> Aseprite:
    """Read an Aseprite file (a path, its bytes or a binary file object) with every frame
    composited. Anything unreadable or over the limits is one :class:`InputError` line."""
    name = _describe(source, name)
    ase = parse_aseprite(read_source(source), name, max_pixels)
    frames = []
    for _, rgba in aseprite_frames(ase, None, max_pixels, max_frames):
        rgba.flags.writeable = False
        frames.append(rgba)
    return Aseprite(width=ase.width, height=ase.height, mode=ase.mode, frames=tuple(frames), durations=ase.durations,
                    tags=ase.tags, palette=ase.palette, layers=ase.layers, slices=ase.slices,
                    pixel_ratio=ase.pixel_ratio)
