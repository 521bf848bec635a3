"""Stage 0 — input: an Aseprite file (``.aseprite``/``.ase``) → its frames as RGBA, with
durations, tags, palette and slices.

:func:`read_aseprite` reads a whole file into an :class:`Aseprite`;
:func:`~depixel.prepare.aseprite_compose.aseprite_frames` composites the frames one at a time,
which is how :func:`depixel.prepare.image.load_image` and ``load_frames`` read an Aseprite file
(told apart by its magic number, not its name). The structure is
read by :mod:`.aseprite_format`, the frames composited by :mod:`.aseprite_compose`
(docs/inputs.md, "Aseprite files"). The canvas counts against ``max_pixels``, the frames
against ``max_frames`` and, all of them read, their pixels in all against ``max_pixels``,
as for any animation. :func:`tag_frames` gives the frames a tag plays, in its order, and :func:`tag_playback` those of
an animation of the tag, with its repeat count.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..limits import DEFAULT_MAX_FRAMES, DEFAULT_MAX_PIXELS
from .aseprite_compose import aseprite_frames
from .aseprite_format import AsepriteFile, Layer, PaletteEntry, Slice, SliceKey, Tag, is_aseprite, parse_aseprite
from .image import ImageSource, _describe, read_source

__all__ = ["Aseprite", "AsepriteFile", "Layer", "PaletteEntry", "Slice", "SliceKey", "Tag", "aseprite_frames",
           "find_tag", "is_aseprite", "parse_aseprite", "read_aseprite", "tag_frames", "tag_playback"]


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


def tag_frames(ase: Aseprite | AsepriteFile | Sequence[Tag], tag: str, *, name: str = "<aseprite>") -> list[int]:
    """The frames the tag ``tag`` plays, in the order of one pass of its direction (of an
    :class:`Aseprite`, an :class:`AsepriteFile` or their ``tags``): ``forward`` first to
    last, ``reverse`` last to first, ``pingpong`` there and back without repeating either
    end (``[4, 5, 6, 5]``: looped, each frame is shown as Aseprite shows it), ``pingpong
    reverse`` back and there. An unknown tag is one :class:`InputError` line naming the
    tags there are (``name`` names the file); of two tags of one name, the first."""
    found = find_tag(ase, tag, name=name)
    ahead = list(range(found.first, found.last + 1))
    order = ahead[::-1] if found.direction in ("reverse", "pingpong reverse") else ahead
    if found.direction.startswith("pingpong"):
        order += order[-2:0:-1]
    return order


def tag_playback(ase: Aseprite | AsepriteFile | Sequence[Tag], tag: str, *,
                 name: str = "<aseprite>") -> tuple[list[int], int]:
    """The frames an animation of the tag ``tag`` shows, in order, and how many times it
    plays (0: for ever), as Aseprite plays the tag (its ``doc/playback_tests.cpp``): with
    ``repeat`` 0 (not given), one pass of :func:`tag_frames` for ever; with ``repeat`` N, a
    forward or reverse pass N times, and a ping-pong's N passes, each one way, turning
    without showing the end frame twice (``[4, 5, 6, 5, 4]`` for N = 2), once."""
    found = find_tag(ase, tag, name=name)
    order = tag_frames(ase, tag, name=name)
    if found.repeat == 0:
        return order, 0
    if not found.direction.startswith("pingpong") or found.first == found.last:
        return order, found.repeat
    one_way = order[:found.last - found.first + 1]
    played = list(one_way)
    for n in range(1, found.repeat):  # back without the end it turns at, then there again
        played += one_way[-2::-1] if n % 2 else one_way[1:]
    return played, 1


def find_tag(ase: Aseprite | AsepriteFile | Sequence[Tag], tag: str, *, name: str = "<aseprite>") -> Tag:
    """The first tag named ``tag``, or one :class:`InputError` line naming the tags there are."""
    tags = ase if isinstance(ase, Sequence) else ase.tags
    found = next((item for item in tags if item.name == tag), None)
    if found is None:
        there = f"its tags: {', '.join(repr(item.name) for item in tags)}" if tags else "it has no tags"
        raise InputError(f"{name}: no tag {tag!r}; {there}", parameter="tag")
    return found
