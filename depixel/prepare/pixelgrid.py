"""Stage 0b, step 1 — the pixel grid of upscaled art — RGBA as given → the grid, and the 1× pixels.

Pixel art saved upscaled with nearest-neighbour has every art pixel as a k×k block.
:func:`find_grid` finds the factor and offset of each axis (from the exact colour changes, or
from luma edges for lossy input); :func:`reduce_blocks` and :func:`block_medians` reduce
every block to one pixel. Part of the input preparation (:mod:`depixel.prepare.inputs`, which calls
these in order); its own module because the grid search is a self-contained piece of
numerics with its own constants (docs/inputs.md has the measurements).

Coordinates: sizes and offsets are ``(x, y)`` pairs, arrays are ``(row, column)``.
"""
from __future__ import annotations

import numpy as np

from ..colour import rgb_to_yuv

# --- constants (none is in the paper: this stage is not part of it) ----------------------------
#: largest nearest-neighbour factor looked for or accepted, per axis
MAX_FACTOR = 32
#: a detected axis needs at least this many block boundaries where the art changes colour,
#: so a few coincidentally aligned edges (a lone rectangle) are never taken for a grid
MIN_EVIDENCE = 3
#: lossy input: a luma step (0-255) over this between neighbours is an edge, if the steps
#: on either side are no larger (ringing beside an edge is weaker than the edge)
LOSSY_EDGE = 24.0
#: lossy input: at most this share of the edges may lie off the grid; measured on the paper
#: sprites at 2×–8× with random offsets, JPEG q70–95: ≤ 0.15; the best grid of any 1× JPEG
#: leaves ≥ 0.32 off it (docs/inputs.md)
LOSSY_OFF_GRID = 0.25
#: lossy input: at least this share of pixels must lie within LOSSY_EDGE luma of their block's median
LOSSY_BLOCK_AGREEMENT = 0.9

#: the pixel-size option that asks for detection
AUTO = "auto"


def colour_keys(rgba: np.ndarray) -> np.ndarray:
    """``(H, W) int64``: equal exactly when two pixels look the same (RGBA equal, or both
    fully transparent whatever RGB they hide)."""
    q = rgba.astype(np.int64)
    keys = (q[..., 0] << 24) | (q[..., 1] << 16) | (q[..., 2] << 8) | q[..., 3]
    return np.where(q[..., 3] == 0, 0, keys)


Grid = tuple[tuple[int, int], tuple[int, int]]  # ((kx, ky), (ox, oy))


def find_grid(rgba: np.ndarray, pixel_size: str | tuple[int, int] = AUTO, lossy: bool = False) -> Grid | None:
    """The nearest-neighbour grid of an ``(H, W, 4)`` image, ``((kx, ky), (ox, oy))``, or None.

    Across a block boundary the art may change colour; inside a block it may not. So a
    factor k with offset o fits an axis when every colour change between neighbouring
    pixels along it lies at a position p ≡ o (mod k) (p: the pixel after the change), and
    the largest fitting k ≤ 32 with ``MIN_EVIDENCE`` changing boundaries is taken; both
    axes must fit. For ``lossy`` input a change is a luma edge (``LOSSY_EDGE``), up to
    ``LOSSY_OFF_GRID`` of them may lie off the grid, and ``LOSSY_BLOCK_AGREEMENT`` of the
    pixels must be close to their block's median. A forced ``(kx, ky)`` gets the offset
    whose boundaries carry the most changes.
    """
    if lossy:
        luma = rgb_to_yuv(rgba)[..., 0]
        change = (_edge_share(luma), _edge_share(luma.T))
    else:
        keys = colour_keys(rgba)
        change = (_change_share(keys), _change_share(keys.T))
    if not isinstance(pixel_size, str):  # forced
        if pixel_size == (1, 1):
            return None
        return pixel_size, (_best_offset(change[0], pixel_size[0]), _best_offset(change[1], pixel_size[1]))
    fits = [_fit_axis(c, LOSSY_OFF_GRID if lossy else 0.0) for c in change]
    if fits[0] is None or fits[1] is None:
        return None
    grid = (fits[0][0], fits[1][0]), (fits[0][1], fits[1][1])
    if lossy and _median_agreement(rgba, luma, grid) < LOSSY_BLOCK_AGREEMENT:
        return None
    return grid


def _change_share(keys: np.ndarray) -> np.ndarray:
    """For each boundary between columns i and i+1, the share of rows where the colour changes."""
    return (keys[:, 1:] != keys[:, :-1]).mean(axis=0)


def _edge_share(luma: np.ndarray) -> np.ndarray:
    """Like :func:`_change_share` for lossy pixels: the share of rows with a luma edge,
    a step over LOSSY_EDGE that is no smaller than the steps on either side of it (the
    ringing beside an edge is weaker than the edge)."""
    step = np.abs(np.diff(luma, axis=1))
    edge = step > LOSSY_EDGE
    edge[:, 1:] &= step[:, 1:] >= step[:, :-1]  # no smaller than the step before it
    edge[:, :-1] &= step[:, :-1] >= step[:, 1:]  # ... and the step after it
    return edge.mean(axis=0)


def _offset_mass(change: np.ndarray, k: int) -> np.ndarray:
    """``(k,)``: the colour changes at boundary positions p ≡ o (mod k), for each o.
    Boundary i lies before pixel p = i + 1."""
    return np.bincount(np.arange(1, change.size + 1) % k, weights=change, minlength=k)


def _fit_axis(change: np.ndarray, off_grid: float) -> tuple[int, int] | None:
    """(k, o) of the largest factor that fits one axis, or None (see :func:`find_grid`)."""
    where = np.flatnonzero(change) + 1  # positions with a colour change before them
    if off_grid == 0.0:  # exact: every change on the grid, so k divides all their spacings
        if where.size < MIN_EVIDENCE:
            return None
        spacing = int(np.gcd.reduce(np.diff(where)))
        k = max((d for d in range(2, min(MAX_FACTOR, spacing) + 1) if spacing % d == 0), default=1)
        return (k, int(where[0] % k)) if k > 1 else None
    # every factor at once: the changes at each (k, offset), k = 2 … top, in one bincount
    top = min(MAX_FACTOR, change.size)
    factors = np.arange(2, top + 1)
    first = np.concatenate([[0], np.cumsum(factors)])[:-1]  # where each factor's offsets start
    position = np.arange(1, change.size + 1)
    slot = (first[:, None] + position[None, :] % factors[:, None]).ravel()
    mass = np.bincount(slot, weights=np.tile(change, len(factors)), minlength=int(factors.sum()))
    evidence = np.bincount(slot, weights=np.tile(change > 0, len(factors)).astype(np.float64),
                           minlength=int(factors.sum()))
    total = float(change.sum())
    best = np.maximum.reduceat(mass, first)  # each factor's best offset's changes
    for i in np.flatnonzero(total - best <= off_grid * total)[::-1]:  # the largest fitting factor wins
        o = int(np.argmax(mass[first[i]:first[i] + factors[i]]))
        if evidence[first[i] + o] >= MIN_EVIDENCE:
            return int(factors[i]), o
    return None


def _best_offset(change: np.ndarray, k: int) -> int:
    """The offset whose boundaries carry the most colour changes (0 on ties)."""
    return int(np.argmax(_offset_mass(change, k))) if k > 1 else 0


def _blocks(shape: tuple[int, int], grid: Grid) -> tuple[np.ndarray, tuple[int, int]]:
    """The block of every pixel, ``(H*W,)`` in scanline order, and the blocks' grid shape.
    A partial block at an edge is a block."""
    (kx, ky), (ox, oy) = grid
    bx = (np.arange(shape[1]) + (kx - ox) % kx) // kx
    by = (np.arange(shape[0]) + (ky - oy) % ky) // ky
    grid_shape = (int(by[-1]) + 1, int(bx[-1]) + 1)
    return (by[:, None] * grid_shape[1] + bx[None, :]).ravel(), grid_shape


def reduce_blocks(rgba: np.ndarray, grid: Grid) -> np.ndarray:
    """``(h, w, 4)``: one pixel per block, of the block's most common colour (ties: the
    lower colour key)."""
    block, (gh, gw) = _blocks(rgba.shape[:2], grid)
    colours, first_pixel, colour_id = np.unique(colour_keys(rgba).ravel(), return_index=True,
                                                return_inverse=True)
    pairs, counts = np.unique(block * colours.size + colour_id.ravel(), return_counts=True)
    pair_block = pairs // colours.size
    order = np.lexsort((-counts, pair_block))  # per block, the most common colour first
    first = order[np.r_[True, pair_block[order][1:] != pair_block[order][:-1]]]
    return rgba.reshape(-1, 4)[first_pixel[pairs[first] % colours.size]].reshape(gh, gw, 4)


def block_medians(rgba: np.ndarray, grid: Grid) -> np.ndarray:
    """``(h, w, 4)``: one pixel per block, each channel the (lower) median of the block's
    inner pixels (all of them when the block is too thin to have any): the block's colour
    without the ringing and the chroma blur along its edges."""
    (kx, ky), (ox, oy) = grid
    block, (gh, gw) = _blocks(rgba.shape[:2], grid)
    inner_x = _inner(rgba.shape[1], kx, ox)
    inner_y = _inner(rgba.shape[0], ky, oy)
    inner = (inner_y[:, None] & inner_x[None, :]).ravel()
    has_inner = np.bincount(block[inner], minlength=gh * gw) > 0
    use = inner | ~has_inner[block]
    return _medians(rgba.reshape(-1, 4)[use], block[use], gh * gw).reshape(gh, gw, 4)


def _inner(n: int, k: int, o: int) -> np.ndarray:
    """``(n,)`` bool: pixels not on the first or last line of their block (blocks of k ≥ 3)."""
    if k < 3:
        return np.ones(n, dtype=bool)
    place = (np.arange(n) + (k - o) % k) % k
    return (place > 0) & (place < k - 1)


def _medians(pixels: np.ndarray, group: np.ndarray, n_groups: int) -> np.ndarray:
    """``(n_groups, 4) uint8``: per group the (lower) median of each channel of ``pixels``."""
    size = np.bincount(group, minlength=n_groups)
    middle = np.cumsum(size) - size + (size - 1) // 2
    out = np.empty((n_groups, 4), dtype=np.uint8)
    for c in range(4):
        ordered = np.sort(group * 256 + pixels[:, c])  # by group, then by value
        out[:, c] = ordered[middle] & 255
    return out


def _median_agreement(rgba: np.ndarray, luma: np.ndarray, grid: Grid) -> float:
    """Share of pixels whose luma lies within LOSSY_EDGE of their block median's."""
    block, _ = _blocks(rgba.shape[:2], grid)
    block_luma = rgb_to_yuv(block_medians(rgba, grid).reshape(-1, 4))[:, 0]
    return float(np.mean(np.abs(luma.ravel() - block_luma[block]) <= LOSSY_EDGE))
