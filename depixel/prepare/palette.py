"""Stage 0b, step 2 — denoising lossy pixels — RGBA → the same pixels snapped to a small palette.

A JPEG (or lossy WebP) of pixel art has hundreds of near-identical colours from ringing and
chroma subsampling. :func:`snap_colours` finds the art's palette by mode seeking in hqx YUV
and gives every pixel its palette colour; for 1× pixels whose chroma was subsampled it hands
the labelling to :mod:`depixel.prepare.chroma_unmix`, which works through the decoder's model. Part of the
input preparation (:mod:`depixel.prepare.inputs`); its own module because the palette search and
its constants are independent of the grid and the backdrop (docs/inputs.md).
"""
from __future__ import annotations

import heapq

import numpy as np

from ..arrays import unique
from ..colour import rgb_to_yuv
from .pixelgrid import colour_keys

# --- constants (none is in the paper: this stage is not part of it) ----------------------------
#: colours within this distance (hqx YUV, largest component, 0-255) are one palette colour
SNAP_RADIUS = 10.0
#: a palette candidate within this luma distance of a candidate SHADOW_RATIO times as
#: frequent is chroma bleeding from 4:2:0 subsampling (a tinted copy), not a colour of its own
SHADOW_LUMA = 10.0
SHADOW_RATIO = 2.0
#: a palette colour covers at least this share of the visible pixels (and at least 3 pixels)
MIN_SHARE = 0.005
#: pixels snap to the nearest palette colour with chroma counted this much: JPEG keeps luma
#: per pixel but chroma only per 2×2 block (4:2:0), so chroma is the less reliable half
CHROMA_WEIGHT = 0.3
#: clean colours (block medians) farther than this many SNAP_RADIUS from their palette colour
#: are gathered again into colours of their own (a box reaches up to 1.5 radii: sbm4_01's white
#: lies 17 from its off-white); only for blocks of at least LEFTOVER_BLOCK pixels a side, whose
#: median is taken over at least 2×2 inner pixels (a 3× block's single inner pixel still
#: carries JPEG's chroma bleeding: the ghost fixture saved 3× at q85 would gain two stray colours)
LEFTOVER = 1.5
LEFTOVER_BLOCK = 4
#: rounds of moving each palette colour to the mean of the pixels it gathers
REFINE_STEPS = 2


def distinct_colours(rgba: np.ndarray) -> int:
    return int(unique(colour_keys(rgba)).size)


def snap_colours(rgba: np.ndarray, min_count: float | None = None, shadows: bool = True,
                 unmix: bool = False, leftovers: bool = False) -> tuple[np.ndarray, int, int, str | None]:
    """Snap the visible pixels' colours to a small palette (alpha is kept).

    Returns the snapped ``(H, W, 4) uint8`` image, the number of distinct colours before,
    the palette size and the chroma subsampling that was undone (``"4:2:0"``, or None). The
    palette is found by mode seeking in hqx YUV: the colour with the most pixels within
    about ``SNAP_RADIUS`` becomes a palette colour and takes those pixels, and so on while a
    colour gathers ``min_count`` pixels (default: ``MIN_SHARE`` of them, at least 3); with
    ``shadows``, a candidate is skipped when it is a tinted copy of a more frequent colour
    of the same luma (``SHADOW_*``: chroma bleeding of 4:2:0 subsampling, which block
    medians no longer have). Each palette colour then moves to the mean of the pixels it
    gathers, and every pixel takes the nearest palette colour, chroma weighted by
    ``CHROMA_WEIGHT``. With ``leftovers`` (clean colours, like the medians of large blocks),
    colours left farther than ``LEFTOVER`` radii from their palette colour are gathered again
    into colours of their own. With ``unmix`` (decoded 1× pixels), when the chroma was subsampled
    (:func:`depixel.prepare.chroma.chroma_grid`), the pixels' colours and the palette are then
    found jointly through the decoder's model instead (:func:`depixel.prepare.chroma_unmix.unmix`).
    """
    visible = rgba[..., 3] > 0
    rgb = rgba[..., :3][visible]
    out = rgba.copy()
    if rgb.shape[0] == 0:
        return out, 0, 0, None
    packed = (rgb[:, 0].astype(np.int64) << 16) | (rgb[:, 1].astype(np.int64) << 8) | rgb[:, 2]
    colours, inverse, counts = np.unique(packed, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    colour_rgb = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], axis=1).astype(np.float64)
    colour_yuv = rgb_to_yuv(colour_rgb)
    if min_count is None:
        min_count = max(3.0, MIN_SHARE * rgb.shape[0])

    palette = _palette(colour_yuv, colour_rgb, counts.astype(np.float64), min_count, shadows)
    if unmix:  # decoded pixels only: the decoder's model is not imported for other inputs (~3 ms)
        from . import chroma, chroma_unmix  # noqa: PLC0415

        grid = chroma.chroma_grid(rgb_to_yuv(rgba))
        if grid is not None and chroma_unmix.fits(rgba.shape[:2], len(palette)):
            labels, palette = chroma_unmix.unmix(rgba, palette, grid, min_count=min_count, radius=SNAP_RADIUS)
            snapped = np.clip(np.round(palette), 0, 255).astype(np.uint8)
            out[..., :3][visible] = snapped[labels[visible]]
            return out, int(colours.size), _distinct_rgb(snapped[unique(labels[visible])]), grid.name

    weight = np.array([1.0, CHROMA_WEIGHT, CHROMA_WEIGHT])
    nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    for _ in range(REFINE_STEPS):
        # each palette colour moves to the mean of the colours it gathers within the radius
        close = np.abs(colour_yuv - rgb_to_yuv(palette)[nearest]).max(axis=1) <= SNAP_RADIUS
        mass = np.bincount(nearest[close], weights=counts[close], minlength=len(palette))
        sums = np.stack([np.bincount(nearest[close], weights=counts[close] * colour_rgb[close, c],
                                     minlength=len(palette)) for c in range(3)], axis=1)
        moved = mass > 0
        palette[moved] = sums[moved] / mass[moved, None]
        palette = _merge_near(palette, np.bincount(nearest, weights=counts, minlength=len(palette)))
        nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    if leftovers:
        # a colour that a box took in (boxes reach a little beyond the radius) but that lies
        # far from the colour the box became is a colour of its own
        far = np.abs(colour_yuv - rgb_to_yuv(palette)[nearest]).max(axis=1) > LEFTOVER * SNAP_RADIUS
        if counts[far].sum() >= min_count:
            extra = _palette(colour_yuv[far], colour_rgb[far], counts[far].astype(np.float64), min_count, False)
            gap = np.abs(rgb_to_yuv(extra)[:, None, :] - rgb_to_yuv(palette)[None, :, :]).max(axis=2).min(axis=1)
            palette = np.vstack([palette, extra[gap > SNAP_RADIUS]])  # not a smear beside a colour it has
            nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    snapped = np.clip(np.round(palette), 0, 255).astype(np.uint8)[nearest]
    out[..., :3][visible] = snapped[inverse]
    return out, int(colours.size), _distinct_rgb(snapped), None


def _distinct_rgb(rgb: np.ndarray) -> int:
    """How many distinct rows an ``(n, 3) uint8`` array has."""
    return int(unique((rgb[:, 0].astype(np.int64) << 16) | (rgb[:, 1].astype(np.int64) << 8) | rgb[:, 2]).size)


def _merge_near(palette: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Merge palette colours closer than SNAP_RADIUS (the closest pair first, into their
    mass-weighted mean), so that no two colours of the result are near-identical."""
    palette, mass = palette.copy(), mass.astype(np.float64).copy()
    while len(palette) > 1:
        yuv = rgb_to_yuv(palette)
        gap = np.abs(yuv[:, None, :] - yuv[None, :, :]).max(axis=2)
        np.fill_diagonal(gap, np.inf)
        i, j = np.unravel_index(int(np.argmin(gap)), gap.shape)
        if gap[i, j] > SNAP_RADIUS:
            break
        total = max(mass[i] + mass[j], 1e-9)
        palette[i] = (palette[i] * mass[i] + palette[j] * mass[j]) / total
        mass[i] = mass[i] + mass[j]
        palette, mass = np.delete(palette, j, axis=0), np.delete(mass, j)
    return palette


#: mode seeking counts pixels in cells of half the radius: a colour's neighbourhood is the
#: 5×5×5 cells around its own, about SNAP_RADIUS either way
_CELL = SNAP_RADIUS / 2
_REACH = 2
#: hqx luma of an RGB colour: colour @ _LUMA
_LUMA = rgb_to_yuv(np.eye(3))[:, 0]


def _palette(yuv: np.ndarray, rgb: np.ndarray, counts: np.ndarray, min_count: float,
             shadows: bool) -> np.ndarray:
    """``(K, 3) float64`` RGB palette by mode seeking over a histogram of the colours."""
    r = _REACH
    cell_of = np.floor(yuv / _CELL).astype(np.int64)
    cell_of -= cell_of.min(axis=0)
    span = tuple(cell_of.max(axis=0) + 1)
    keys, colour_cell = np.unique(np.ravel_multi_index(tuple(cell_of.T), span), return_inverse=True)
    colour_cell = colour_cell.ravel()
    cells = np.stack(np.unravel_index(keys, span), axis=1) + 2 * r  # grid positions, room for a 2r box around each
    shape = tuple(np.array(span) + 4 * r)
    mass = np.bincount(colour_cell, weights=counts, minlength=len(cells))
    rgb_sum = np.stack([np.bincount(colour_cell, weights=counts * rgb[:, c], minlength=len(cells))
                        for c in range(3)], axis=1)
    grid = np.zeros(shape, dtype=np.float32)  # pixels per cell not taken yet (counts: exact)
    grid[tuple(cells.T)] = mass
    # pixels within reach of each cell; only cells that could gather min_count are candidates
    density = _box_sums(grid, cells)
    candidates = np.flatnonzero(density >= min_count)
    cell_at = np.full(shape, -1, dtype=np.int32)  # which cell sits at each grid position
    cell_at[tuple(cells.T)] = np.arange(len(cells), dtype=np.int32)
    # lazy greedy: the box sums only shrink as boxes are taken, so a stale sum is an upper
    # bound; the candidate on top of the heap is the densest (first on ties) once its own sum,
    # brought up to date, still beats the next stale one
    heap = list(zip((-density[candidates]).tolist(), candidates.tolist()))
    heapq.heapify(heap)
    live = np.zeros(len(cells), dtype=bool)
    live[candidates] = True
    chosen: list[np.ndarray] = []
    chosen_mass: list[tuple[float, float]] = []  # (luma, pixels)
    while heap:
        _, c = heapq.heappop(heap)
        if not live[c]:
            continue  # its cell was taken
        x, y, z = cells[c]
        box = (slice(x - r, x + r + 1), slice(y - r, y + r + 1), slice(z - r, z + r + 1))
        now = float(grid[box].sum())
        if heap and (-now, c) > heap[0]:
            heapq.heappush(heap, (-now, c))  # not the densest any more: back, with its true sum
            continue
        if now < min_count:
            break
        gone = cell_at[box][cell_at[box] >= 0]
        cell_at[box] = -1  # taken: these cells are gone for every later box
        grid[box] = 0.0
        live[gone] = False
        colour = rgb_sum[gone].sum(axis=0) / now
        luma = float(colour @ _LUMA)
        if not shadows or not any(abs(luma - y) <= SHADOW_LUMA and m >= SHADOW_RATIO * now
                                  for y, m in chosen_mass):
            chosen.append(colour)
            chosen_mass.append((luma, now))
    if not chosen:  # too few pixels for any colour to count: the most common one
        chosen = [rgb[int(np.argmax(counts))]]
    return np.array(chosen, dtype=np.float64)


def _box_sums(grid: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``(n,) float64``: the sum of ``grid`` over the (2·_REACH+1)³ box around each of the
    ``(n, 3)`` positions ``at`` (at least _REACH cells from the edges): one gather of every
    box's cells (cumulative sums along a grid's first axes are slow strided passes)."""
    r = _REACH
    strides = np.array([grid.shape[1] * grid.shape[2], grid.shape[2], 1])
    offset = (np.stack(np.meshgrid(*[np.arange(-r, r + 1)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) @ strides)
    return grid.ravel()[(at @ strides)[:, None] + offset].sum(axis=1, dtype=np.float64)


def _nearest(points: np.ndarray, palette: np.ndarray) -> np.ndarray:
    """Index of the nearest palette row (Euclidean) for every point."""
    d = ((points[:, None, :] - palette[None, :, :]) ** 2).sum(axis=2)
    return np.argmin(d, axis=1)
