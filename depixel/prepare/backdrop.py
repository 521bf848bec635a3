"""Stage 0b, step 3 — the backdrop — RGBA → the same pixels with one colour made fully transparent.

Sprites are often drawn on a solid backdrop colour; :func:`make_transparent` keys it out
(a given colour, or ``"auto"``: the colour of the four corners when they agree). Part of
the input preparation (:mod:`depixel.prepare.inputs`); its own module so that each preparation
step is read and changed on its own.
"""
from __future__ import annotations

import numpy as np

from ..arrays import unique
from ..colour import Colour, rgb_to_yuv
from .palette import SNAP_RADIUS
from .pixelgrid import AUTO, colour_keys


def make_transparent(rgba: np.ndarray, colour: str | Colour, snapped: bool = False):
    """Make every visible pixel of one colour fully transparent.

    ``colour`` is an ``(r, g, b)`` triple or ``"auto"``: the colour of the four corners
    when all four are that same opaque colour. On a ``snapped`` (denoised) image the
    palette colour nearest to a given colour is taken when it lies within SNAP_RADIUS.
    Returns ``(rgba, colour made transparent or None, pixels changed, note or None)``.
    """
    keys = colour_keys(rgba)
    if colour == AUTO:
        corners = keys[[0, 0, -1, -1], [0, -1, 0, -1]]
        if corners[0] == 0 and (corners == 0).all():
            return rgba, None, 0, None  # already on a transparent backdrop
        if not (corners == corners[0]).all() or rgba[0, 0, 3] != 255:
            return rgba, None, 0, "the corners differ, so no backdrop colour was made transparent"
        target: Colour = (int(rgba[0, 0, 0]), int(rgba[0, 0, 1]), int(rgba[0, 0, 2]))
    else:
        target = (int(colour[0]), int(colour[1]), int(colour[2]))
        if snapped:
            visible = rgba[..., 3] > 0
            present = unique(rgba[..., :3][visible], axis=0)
            if present.size:
                gap = np.abs(rgb_to_yuv(present) - rgb_to_yuv(np.array(target, dtype=np.float64))).max(axis=1)
                if gap.min() <= SNAP_RADIUS:
                    nearest = present[int(np.argmin(gap))]
                    target = (int(nearest[0]), int(nearest[1]), int(nearest[2]))
    hit = (rgba[..., 3] > 0) & (rgba[..., :3] == np.array(target, dtype=np.uint8)).all(axis=2)
    n = int(hit.sum())
    if n == 0:
        return rgba, None, 0, f"no pixel is {hex_code(target)}, so nothing was made transparent"
    out = rgba.copy()
    out[hit, 3] = 0
    return out, target, n, None


def hex_code(colour: Colour) -> str:
    """``#rrggbb`` of an ``(r, g, b)`` colour."""
    return "#{:02x}{:02x}{:02x}".format(*colour)
