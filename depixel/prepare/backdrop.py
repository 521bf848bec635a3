"""Stage 0b, step 3 — the backdrop — RGBA → the same pixels with the backdrop made fully transparent.

Sprites are often drawn on a solid backdrop colour; :func:`make_transparent` removes it (a
given colour, or ``"auto"``: the colour of the four corners when they agree). The backdrop
is that colour where it reaches the image's border, 4-connected, as a flood fill from the
border finds it: a sprite's eye-whites or teeth of the same colour are inside its outline
and stay (``everywhere`` removes every pixel of the colour, a colour key). Part of the input
preparation (:mod:`depixel.prepare.inputs`); its own module so that each preparation step
is read and changed on its own.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import unique
from ..colour import Colour, rgb_to_yuv
from .palette import SNAP_RADIUS
from .pixelgrid import AUTO, colour_keys


def over_colour(rgba: np.ndarray, colour: Colour) -> np.ndarray:
    """``(H, W, 4)`` RGBA composited over an opaque ``(r, g, b)`` → ``(H, W, 4) uint8``, alpha 255
    (:func:`depixel.flatten`; the input option ``background``)."""
    rgb = np.array(colour, dtype=np.int64)
    pixels = rgba.astype(np.int64)
    alpha = pixels[..., 3:4]
    out = np.empty(pixels.shape, np.uint8)
    out[..., :3] = (pixels[..., :3] * alpha + rgb * (255 - alpha) + 127) // 255
    out[..., 3] = 255
    return out


class Backdrop(NamedTuple):
    """What :func:`make_transparent` did."""

    rgba: np.ndarray  # the image with the backdrop's alpha 0 (the input itself when nothing changed)
    colour: Colour | None  # the colour made transparent, None when no pixel was
    pixels: int  # pixels made transparent
    kept: int  # visible pixels of that colour left as they are (inside the art, not joined to the border)
    note: str | None  # why nothing was made transparent, when nothing was


def make_transparent(rgba: np.ndarray, colour: str | Colour, snapped: bool = False,
                     everywhere: bool = False) -> Backdrop:
    """Make the backdrop fully transparent: the visible pixels of one colour that are joined
    to the image's border through pixels of that colour (4-connected), or with
    ``everywhere`` every visible pixel of that colour.

    ``colour`` is an ``(r, g, b)`` triple or ``"auto"``: the colour of the four corners
    when all four are that same opaque colour. On a ``snapped`` (denoised) image the
    palette colour nearest to a given colour is taken when it lies within SNAP_RADIUS.
    """
    keys = colour_keys(rgba)
    if colour == AUTO:
        corners = keys[[0, 0, -1, -1], [0, -1, 0, -1]]
        if corners[0] == 0 and (corners == 0).all():
            return Backdrop(rgba, None, 0, 0, None)  # already on a transparent backdrop
        if not (corners == corners[0]).all() or rgba[0, 0, 3] != 255:
            return Backdrop(rgba, None, 0, 0, "the corners differ, so no backdrop colour was made transparent")
        target: Colour = (int(rgba[0, 0, 0]), int(rgba[0, 0, 1]), int(rgba[0, 0, 2]))
    else:
        target = (int(colour[0]), int(colour[1]), int(colour[2]))
        if snapped:
            target = _nearest_present(rgba, target)
    same = (rgba[..., 3] > 0) & (rgba[..., :3] == np.array(target, dtype=np.uint8)).all(axis=2)
    hit = same if everywhere else border_connected(same)
    n, kept = int(hit.sum()), int(same.sum() - hit.sum())
    if n == 0:
        where = "no pixel is" if kept == 0 else f"none of the {kept} pixels of"
        reach = "" if kept == 0 else " reaches the border"
        return Backdrop(rgba, None, 0, kept, f"{where} {hex_code(target)}{reach}, so nothing was made transparent")
    out = rgba.copy()
    out[hit, 3] = 0
    return Backdrop(out, target, n, kept, None)


def backdrop_mask(rgba: np.ndarray) -> np.ndarray:
    """``(H, W) bool``: the backdrop ``--transparent auto`` would remove (the pixels of the
    four corners' colour, when all four are that one opaque colour, joined to the border
    through it), whether or not it was removed; nothing when the corners differ. The smooth
    shading keeps it out of the art's blend (docs/rendering.md, "The backdrop")."""
    keys = colour_keys(rgba)
    corners = keys[[0, 0, -1, -1], [0, -1, 0, -1]]
    if not (corners == corners[0]).all() or rgba[0, 0, 3] != 255:
        return np.zeros(rgba.shape[:2], bool)
    return border_connected(keys == corners[0])


def border_connected(mask: np.ndarray) -> np.ndarray:
    """``(H, W) bool``: the pixels of ``mask`` joined to the image's border through ``mask``
    (4-connected), as a flood fill from every border pixel of ``mask`` reaches them.

    Each round fills whole runs: every row run of ``mask`` touching a reached pixel, then
    every column run. So the rounds count the turns of the longest way in, not its length:
    a backdrop around a sprite takes two or three (a spiral corridor takes one a turn)."""
    rows, cols = _runs(mask), _runs(mask.T).T
    reached = mask.copy()
    reached[1:-1, 1:-1] = False
    count = -1
    while (now := int(reached.sum())) != count:
        count = now
        reached = _fill_runs(reached, rows)
        reached = _fill_runs(reached, cols)
    return reached


def _runs(mask: np.ndarray) -> np.ndarray:
    """``(H, W) int64``: the number of each pixel's run of ``mask`` along its row (runs
    numbered from 0 in reading order), -1 outside ``mask``."""
    starts = mask.copy()
    starts[:, 1:] &= ~mask[:, :-1]
    number = np.cumsum(starts, axis=None).reshape(mask.shape) - 1
    return np.where(mask, number, -1)


def _fill_runs(reached: np.ndarray, runs: np.ndarray) -> np.ndarray:
    """``reached`` grown to the whole of every run (``runs``) it touches."""
    touched = np.zeros(int(runs.max()) + 2, dtype=bool)  # the last slot: outside every run (-1)
    touched[runs[reached]] = True
    touched[-1] = False
    return touched[runs]


def _nearest_present(rgba: np.ndarray, target: Colour) -> Colour:
    """The visible colour nearest to ``target`` when it lies within SNAP_RADIUS (hqx YUV),
    else ``target``: a denoised image holds its palette's colours, not the one asked for."""
    visible = rgba[..., 3] > 0
    present = unique(rgba[..., :3][visible], axis=0)
    if present.size:
        gap = np.abs(rgb_to_yuv(present) - rgb_to_yuv(np.array(target, dtype=np.float64))).max(axis=1)
        if gap.min() <= SNAP_RADIUS:
            nearest = present[int(np.argmin(gap))]
            return int(nearest[0]), int(nearest[1]), int(nearest[2])
    return target


def hex_code(colour: Colour) -> str:
    """``#rrggbb`` of an ``(r, g, b)`` colour."""
    return "#{:02x}{:02x}{:02x}".format(*colour)
