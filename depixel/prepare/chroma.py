"""Stage 0b (preparation) for lossy 1× pixels — undoing chroma subsampling — RGBA and a
palette → the palette colour of every pixel.

JPEG (at its usual 4:2:0) and lossy WebP keep luma for every pixel but chroma once per 2×2
pixels: the encoder averages the chroma of each block (the blocks are aligned to the image
origin) and the decoder rebuilds every pixel's chroma from those samples, either by
interpolating them (libjpeg's and libwebp's "fancy" upsampling: along each axis 3/4 of the
own block's sample and 1/4 of the nearer neighbour's) or by repeating them. The colour of a
one-pixel feature is then no longer in the file; what is left is its luma and its share of
the mean chroma of its block. This module finds how chroma was subsampled, from the pixels
alone (:func:`chroma_grid`), and models how the decoder rebuilt it (:class:`ChromaGrid`'s
operators). :mod:`depixel.prepare.chroma_unmix` then gives every pixel the palette colour that
explains both its own luma and, through this model, the chroma of the pixels around it (the
joint labelling is its own module: the larger half, with its own constants and solver).

Not in the paper; docs/inputs.md has the measurements. Arrays are ``(row, column)``; a
*block* is the set of pixels that share one chroma sample.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..colour import rgb_to_yuv

# --- constants (measured on the 54 paper sprites saved as JPEG, docs/inputs.md) ------------------
#: a chroma model fits when it rebuilds the decoded chroma to within this mean error (0-255
#: scale): 4:2:0 JPEGs at q60-95 fit to at most 2.9; the model is then checked against the
#: same model one pixel off the grid (SAMPLING_CONTRAST)
SAMPLING_MISFIT = 3.0
#: ... and must fit at least this much better on the image's own grid than one pixel off it
#: (4:2:0 JPEGs: median 0.4; 4:4:4 JPEGs and noise: 0.6 to 1.4, median 1.0)
SAMPLING_CONTRAST = 0.75


#: rgb = yuv @ _RGB_OF_YUV (the inverse of depixel.colour.rgb_to_yuv)
_RGB_OF_YUV = np.linalg.inv(rgb_to_yuv(np.eye(3)))
#: the subsampling is judged on at most this many rows and columns (a crop at the centre)
DETECT_SIDE = 256
#: the inverse of the per-axis blur [1/8, 3/4, 1/8] that the encoder's block means make of
#: the decoder's interpolated chroma: taps √2·r^|n|, r = 2√2 − 3 (|r|⁵ < 2e-4: nine taps
#: are exact to far below one level)
_UNBLUR = np.sqrt(2) * (2 * np.sqrt(2) - 3) ** np.abs(np.arange(-4, 5))


def yuv_to_rgb(yuv: np.ndarray) -> np.ndarray:
    """RGB (0-255 float, not clipped) of an ``(..., 3)`` hqx YUV array."""
    return yuv @ _RGB_OF_YUV


@dataclass(frozen=True)
class ChromaGrid:
    """How the decoder rebuilt chroma: ``block`` is (rows, columns) of pixels per chroma
    sample ((2, 2) for 4:2:0, (1, 2) for 4:2:2), ``smooth`` whether it interpolated the
    samples (libjpeg's "fancy" upsampling: pixel 2i is 3/4 of sample i and 1/4 of sample
    i−1, pixel 2i+1 3/4 of i and 1/4 of i+1, the edge samples standing in for their missing
    neighbours) or repeated them. The blocks start at the image origin; an odd last row or
    column is a block of its own (JPEG repeats the edge pixel).

    The operators work on ``(h, w, ...)`` arrays, with plain slicing (small matrix products
    go through BLAS, whose threads stall on a busy machine).
    """

    block: tuple[int, int]
    smooth: bool = True

    @property
    def name(self) -> str:
        return "4:2:0" if self.block == (2, 2) else "4:2:2" if self.block == (1, 2) else "4:4:4"

    def _each(self, x: np.ndarray, step, *args) -> np.ndarray:
        """``step`` (an axis-0 operator) applied along every subsampled axis."""
        for axis, k in enumerate(self.block):
            if k == 2:
                x = np.swapaxes(step(np.swapaxes(x, 0, axis), *(a[axis] for a in args)), 0, axis)
        return x

    def down(self, pixels: np.ndarray) -> np.ndarray:
        """``(h, w, ...)`` → ``(bh, bw, ...)``: the mean of each block (the encoder's samples)."""
        return self._each(pixels, _pair_means)

    def up(self, samples: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """``(bh, bw, ...)`` → ``(h, w, ...)``: the pixels the decoder makes of the samples."""
        return self._each(samples, lambda x, n: _upsample(x, n, self.smooth), shape)

    def up_adjoint(self, pixels: np.ndarray) -> np.ndarray:
        """The transpose of :meth:`up`: each sample, the sum of the pixels it feeds weighted by
        how much it feeds them."""
        return self._each(pixels, lambda x: _upsample_adjoint(x, self.smooth))

    def gram(self, shape: tuple[int, int]) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """upᵀup, tridiagonal along each subsampled axis: ``(axis, diagonal, off-diagonal)``."""
        out = []
        for axis, (n, k) in enumerate(zip(shape, self.block)):
            if k == 2:
                m = (n + 1) // 2
                pixel = np.arange(n)
                own = pixel // 2
                other = np.clip(np.where(pixel % 2, own + 1, own - 1), 0, m - 1)
                mixed = (other != own) & self.smooth  # fed by two samples, 3/4 and 1/4
                diagonal = (np.bincount(own, weights=np.where(mixed, 0.5625, 1.0), minlength=m)
                            + np.bincount(other[mixed], weights=np.full(mixed.sum(), 0.0625), minlength=m))
                pair = np.minimum(own, other)[mixed]
                off = np.bincount(pair, weights=np.full(pair.size, 0.1875), minlength=m)[: m - 1]
                out.append((axis, diagonal, off))
        return out


def _pair_means(x: np.ndarray) -> np.ndarray:
    """Means of row pairs (axis 0); an odd last row is a pair of its own."""
    if x.shape[0] % 2:
        x = np.concatenate([x, x[-1:]])
    return (x[0::2] + x[1::2]) / 2


def _upsample(c: np.ndarray, n: int, smooth: bool) -> np.ndarray:
    """Rows (axis 0) of samples → ``n`` rows of pixels (see :class:`ChromaGrid`)."""
    if not smooth:
        return np.repeat(c, 2, axis=0)[:n]
    out = np.empty((2 * c.shape[0],) + c.shape[1:])
    out[0::2] = 0.75 * c
    out[0::2][1:] += 0.25 * c[:-1]
    out[0] += 0.25 * c[0]
    out[1::2] = 0.75 * c
    out[1::2][:-1] += 0.25 * c[1:]
    out[-1] += 0.25 * c[-1]
    return out[:n]


def _upsample_adjoint(r: np.ndarray, smooth: bool) -> np.ndarray:
    """The transpose of :func:`_upsample` (axis 0)."""
    if r.shape[0] % 2:
        r = np.concatenate([r, np.zeros_like(r[:1])])  # the transpose of the crop to n rows
    even, odd = r[0::2], r[1::2]
    if not smooth:
        return even + odd
    g = 0.75 * (even + odd)
    g[:-1] += 0.25 * even[1:]  # sample i is 1/4 of pixel 2(i+1) ...
    g[1:] += 0.25 * odd[:-1]  # ... and of pixel 2(i−1)+1
    g[0] += 0.25 * even[0]  # the edge samples stand in for their missing neighbours
    g[-1] += 0.25 * odd[-1]
    return g



# --- which subsampling --------------------------------------------------------------------------

def chroma_grid(yuv: np.ndarray) -> ChromaGrid | None:
    """How the chroma of an ``(H, W, 3)`` YUV image was subsampled, or None (not at all, or
    not in a way this module models).

    A model (4:2:0 interpolated or repeated, else 4:2:2) fits when the chroma it rebuilds
    from the samples that explain the decoded chroma matches it to within
    ``SAMPLING_MISFIT``, and at least ``SAMPLING_CONTRAST`` times better than the same
    model one pixel off the image's grid: chroma that really was subsampled fits on the grid
    and nowhere else, while smooth chroma (or none) fits everywhere and tells nothing. Large
    images are judged on a crop of ``DETECT_SIDE`` pixels at their centre.
    """
    h, w = yuv.shape[:2]
    top, left = max(0, (h - DETECT_SIDE) // 4 * 2), max(0, (w - DETECT_SIDE) // 4 * 2)  # even: on the grid
    chroma = yuv[top:top + DETECT_SIDE, left:left + DETECT_SIDE, 1:]
    for block in ((2, 2), (1, 2)):
        if any(n < 2 * k + 1 for n, k in zip(chroma.shape[:2], block)):
            continue
        misfit, smooth = min((_misfit(chroma, ChromaGrid(block, smooth)), smooth) for smooth in (True, False))
        grid = ChromaGrid(block, smooth)
        shifted = _misfit(chroma[block[0] - 1:, block[1] - 1:], grid)
        if misfit <= SAMPLING_MISFIT and misfit <= SAMPLING_CONTRAST * shifted:
            return grid
    return None


def _misfit(chroma: np.ndarray, grid: ChromaGrid) -> float:
    """Mean absolute difference between ``chroma`` and what ``grid`` rebuilds from the
    samples that explain it: the block means, which for interpolated samples are those
    samples blurred by [1/8, 3/4, 1/8] along each axis, unblurred."""
    samples = grid.down(chroma)
    if grid.smooth:
        samples = grid._each(samples, lambda x: _convolve(x, _UNBLUR))
    return float(np.abs(grid.up(samples, chroma.shape[:2]) - chroma).mean())


def _convolve(x: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """``x`` convolved with symmetric ``taps`` along axis 0, edge rows repeated."""
    r = len(taps) // 2
    padded = np.concatenate([np.repeat(x[:1], r, axis=0), x, np.repeat(x[-1:], r, axis=0)])
    n = x.shape[0]
    return sum(t * padded[i:i + n] for i, t in enumerate(taps))

