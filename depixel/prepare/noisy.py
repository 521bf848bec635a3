"""Stage 0b, a hint — lossless RGBA → whether it looks anti-aliased or noisy, with the numbers.

A PNG can hold pixels that went through a smoothing resize or a JPEG before it was saved:
hundreds of colours, most of them blends along edges or wiggles of a few levels, each of
which becomes shapes and hairlines in the SVG. Denoising (:mod:`.palette`) snaps them, but it
is on by default only for files that say they are lossy; :func:`noise_hint` tells when a
lossless input looks like one, so the user can ask for it. Not every colourful image is
noisy: icons with smooth gradients have as many colours, and denoising would band them.

Three measures, each over the visible pixels and their neighbours on the four axes
(horizontal, vertical, two diagonals; a pixel sits between the two neighbours of an axis):

- **colours**: clean pixel art has few (the corpus: at most 33, SNES frames included);
  below MIN_COLOURS nothing else is looked at (the common case costs one ``unique``);
- **wiggles**: of the pixels whose two neighbours on an axis are both near-identical to it
  (within the denoiser's SNAP_RADIUS, not equal), the share that is lighter or darker than
  both: noise wiggles (about half), a gradient runs one way (icon_disk: 20%);
- **blends**: the colours of the pixels that lie on the way between two clearly different
  neighbours (a smoothing filter's edge): most of an anti-aliased drawing's colours are
  blends, few of a gradient's are (icon_disk: 16% of its colours).

The thresholds come from the corpus and fixtures (none fires) against anti-aliased and
noisy versions of the fixtures (each fires); tests/test_noisy.py pins both.
"""
from __future__ import annotations

import numpy as np

from ..arrays import unique
from ..colour import rgb_to_yuv
from .palette import SNAP_RADIUS, snap_colours
from .pixelgrid import colour_keys

#: fewer distinct colours than this never get a hint (clean pixel art: at most 33 in the corpus)
MIN_COLOURS = 64
#: noisy: near-identical neighbour pairs on both sides of a pixel, per visible pixel, at least...
MIN_NEAR = 0.1
#: ...and the share of them where the pixel is lighter or darker than both (noise ~0.5, a gradient ~0.2)
MIN_WIGGLE = 0.35
#: anti-aliased: colours seen only as a blend between two clearly different neighbours, at least
#: this share of all colours (a gradient icon: 0.16) and this many
MIN_BLEND_SHARE = 0.3
MIN_BLENDS = 16
#: a pixel blends two neighbours when it lies within SNAP_RADIUS / 2 of the segment between
#: them, at least this far from either end (as a share of the way) and more than SNAP_RADIUS from each
BLEND_MARGIN = 0.15
#: the axes a pixel's two opposite neighbours lie on: (dy, dx) of one of them
AXES = ((0, 1), (1, 0), (1, 1), (1, -1))


def noise_hint(rgba: np.ndarray) -> str | None:
    """A phrase saying why ``rgba`` looks anti-aliased or noisy and what denoising would
    make of it ("127 colours, 65 of them blends along edges (anti-aliased?): denoise snaps
    them to 12 (--denoise)"), or None when it looks like clean pixel art."""
    keys = colour_keys(rgba)
    visible = rgba[..., 3] > 0
    colours = int(unique(keys[visible]).size)
    if colours < MIN_COLOURS:
        return None
    near, wiggles, blends = _measures(rgba, keys, visible)
    if near >= MIN_NEAR and wiggles >= MIN_WIGGLE:
        why = "most a few levels off their neighbours' (noise, or once a JPEG?)"
    elif blends >= MIN_BLENDS and blends >= MIN_BLEND_SHARE * colours:
        why = f"{blends} of them blends along edges (anti-aliased?)"
    else:
        return None
    palette = snap_colours(rgba, unmix=True)[2]
    return f"{colours} colours, {why}: denoise snaps them to {palette} (--denoise)"


def _measures(rgba: np.ndarray, keys: np.ndarray, visible: np.ndarray) -> tuple[float, float, int]:
    """(near-identical pairs on both sides per visible pixel, the share of them that wiggle,
    the number of colours seen as blends)."""
    h, w = visible.shape
    yuv = rgb_to_yuv(rgba[..., :3])
    padded_yuv = np.pad(yuv, ((1, 1), (1, 1), (0, 0)))
    padded_visible = np.pad(visible, 1)
    near_pairs = wiggling = 0
    blend = np.zeros_like(visible)
    for dy, dx in AXES:
        a = padded_yuv[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        b = padded_yuv[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        both = visible & padded_visible[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] & \
            padded_visible[1 - dy:1 - dy + h, 1 - dx:1 - dx + w]
        to_a, to_b = np.abs(yuv - a).max(axis=2), np.abs(yuv - b).max(axis=2)
        near = both & (to_a > 0) & (to_a <= SNAP_RADIUS) & (to_b > 0) & (to_b <= SNAP_RADIUS)
        near_pairs += int(near.sum())
        wiggling += int((near & (((yuv - a) * (yuv - b)).sum(axis=2) > 0)).sum())
        way = b - a
        t = ((yuv - a) * way).sum(axis=2) / np.maximum((way * way).sum(axis=2), 1e-9)
        off = np.abs(a + np.clip(t, 0, 1)[..., None] * way - yuv).max(axis=2)
        blend |= both & (t > BLEND_MARGIN) & (t < 1 - BLEND_MARGIN) & (off <= SNAP_RADIUS / 2) & \
            (to_a > SNAP_RADIUS) & (to_b > SNAP_RADIUS)
    blends = int(unique(keys[blend]).size)
    return near_pairs / max(int(visible.sum()), 1), wiggling / max(near_pairs, 1), blends
