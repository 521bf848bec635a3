"""Stage 0b (preparation) for lossy 1× pixels — undoing chroma subsampling — RGBA and a
palette → the palette colour of every pixel.

JPEG (at its usual 4:2:0) and lossy WebP keep luma for every pixel but chroma once per 2×2
pixels: the encoder averages the chroma of each block (the blocks are aligned to the image
origin) and the decoder rebuilds every pixel's chroma from those samples, either by
interpolating them (libjpeg's and libwebp's "fancy" upsampling: along each axis 3/4 of the
own block's sample and 1/4 of the nearer neighbour's) or by repeating them. The colour of a
one-pixel feature is then no longer in the file; what is left is its luma and its share of
the mean chroma of its block. This module

1. finds how chroma was subsampled, from the pixels alone (:func:`chroma_grid`), and
2. gives every pixel the palette colour that explains both at once (:func:`unmix`): its own
   luma, and, through the decoder's model, the chroma of the pixels around it; with a
   smoothness prior (pixel art is made of runs of one colour), alternating with a refit of
   the palette's colours to that labelling (least squares through the same model), so that
   a colour seen only in thin features, mixed in every block, comes back unmixed.

Not in the paper; docs/inputs.md has the measurements. Arrays are ``(row, column)``; a
*block* is the set of pixels that share one chroma sample.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .image import rgb_to_yuv

# --- constants (measured on the 54 paper sprites saved as JPEG, docs/inputs.md) ------------------
#: a chroma model fits when it rebuilds the decoded chroma to within this mean error (0-255
#: scale): 4:2:0 JPEGs at q60-95 fit to at most 2.9; the model is then checked against the
#: same model one pixel off the grid (SAMPLING_CONTRAST)
SAMPLING_MISFIT = 3.0
#: ... and must fit at least this much better on the image's own grid than one pixel off it
#: (4:2:0 JPEGs: median 0.4; 4:4:4 JPEGs and noise: 0.6 to 1.4, median 1.0)
SAMPLING_CONTRAST = 0.75
#: noise of the decoded luma and chroma against the art's colours (0-255; the energy counts
#: differences in these steps, squared) and the cost of a pixel differing from one of its
#: four neighbours: chosen on the paper sprites at q70-95 (luma 5-9, chroma 9-16 and
#: smoothness 2-4 all give a median within 0.03 of the best; luma is off by 9 at the 90th percentile
#: at q85, docs/inputs.md)
LUMA_NOISE = 7.0
CHROMA_NOISE = 12.0
SMOOTHNESS = 3.0
#: a pixel's label is chosen among this many palette colours nearest to its luma (given the
#: true palette, the right colour is the nearest for 78 % of the pixels of the paper sprites'
#: q85 JPEGs, among the 4 nearest for 99.2 %)
CANDIDATES = 4
#: labelling rounds (the palette grows and is refitted between them) and sweeps per round
#: (2 rounds: median 0.83 instead of 0.88 at q85; more sweeps or rounds gain nothing)
ROUNDS = 3
SWEEPS = 1
#: a pixel whose luma lies more than MISSING · LUMA_NOISE from its label's, or whose decoded
#: chroma lies more than CHROMA_MISSING · CHROMA_NOISE from the model's, is not explained by
#: the palette; enough such pixels of one luma become a new colour (GROW_STEPS a round)
MISSING = 3.0
CHROMA_MISSING = 3.0
GROW_STEPS = 1
#: weight in the palette refit of a pixel the decoder clipped to RGB's range (its chroma is off)
CLIPPED_WEIGHT = 0.1
#: each refitted palette colour is pulled towards its previous value with this weight per pixel
RIDGE = 0.1
#: larger images keep the nearest palette colour: the joint labelling holds a few arrays of
#: pixels × palette colours float64s
MAX_CELLS = 1 << 22

#: rgb = yuv @ _RGB_OF_YUV (the inverse of depixel.image.rgb_to_yuv)
_RGB_OF_YUV = np.linalg.inv(rgb_to_yuv(np.eye(3)))
#: the subsampling is judged on at most this many rows and columns (a crop at the centre)
DETECT_SIDE = 256
#: the inverse of the per-axis blur [1/8, 3/4, 1/8] that the encoder's block means make of
#: the decoder's interpolated chroma: taps √2·r^|n|, r = 2√2 − 3 (|r|⁵ < 2e-4: nine taps
#: are exact to far below one level)
_UNBLUR = np.sqrt(2) * (2 * np.sqrt(2) - 3) ** np.abs(np.arange(-4, 5))


def fits(shape: tuple[int, int], colours: int) -> bool:
    """Whether :func:`unmix` takes an image of this size and palette (``MAX_CELLS``)."""
    return shape[0] * shape[1] * colours <= MAX_CELLS


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


def _tridiagonal(x: np.ndarray, diagonal: np.ndarray, off: np.ndarray) -> np.ndarray:
    """A symmetric tridiagonal matrix times ``x`` along axis 0."""
    shape = (-1,) + (1,) * (x.ndim - 1)
    out = diagonal.reshape(shape) * x
    out[1:] += off.reshape(shape) * x[:-1]
    out[:-1] += off.reshape(shape) * x[1:]
    return out


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


# --- joint labelling ------------------------------------------------------------------------------

def unmix(rgba: np.ndarray, palette: np.ndarray, grid: ChromaGrid, min_count: float = 3.0,
          radius: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The palette colour of every visible pixel of a decoded image whose chroma was
    subsampled on ``grid``, and the palette refitted.

    Parameters
    ----------
    rgba : ``(H, W, 4) uint8``, as decoded.
    palette : ``(K, 3)`` RGB (0-255) to start from (``depixel.prepare``'s mode seeking).
    min_count, radius : a colour missing from the palette is added when at least
        ``min_count`` pixels, within ``radius`` of one luma, need it (:func:`_grow`).

    Returns ``(labels, palette)``: ``(H, W) int64`` indices into the refitted ``(K', 3)
    float64`` RGB palette (K' ≥ K; −1 for fully transparent pixels). Starting from the
    nearest colour by luma, the labels minimise (by iterated conditional modes) the energy

        Σ_pixels ((Y − Y_label) / LUMA_NOISE)²
        + |decoded chroma − up(down(chroma of the labels))|² / CHROMA_NOISE²
        + SMOOTHNESS · (neighbour pairs with different labels)

    where down/up are the encoder's block means and the decoder's rebuilding of ``grid``;
    between ``ROUNDS`` the palette grows by the colours it lacks and moves to the colours
    that best explain the labelling (luma: mean of its pixels; chroma: least squares through
    the same model). Fully transparent pixels keep their decoded chroma and take no label.
    """
    shape = rgba.shape[:2]
    visible = rgba[..., 3] > 0
    yuv = rgb_to_yuv(rgba)
    luma, chroma = yuv[..., 0], yuv[..., 1:]
    fixed = np.where(visible[..., None], 0.0, chroma)  # transparent pixels' chroma, as decoded
    pal = rgb_to_yuv(np.asarray(palette, dtype=np.float64))
    labels = np.where(visible, np.argmin(np.abs(luma[..., None] - pal[:, 0]), axis=-1), -1)
    clipped = ((rgba[..., :3] == 0) | (rgba[..., :3] == 255)).any(axis=-1)
    model = _Model(grid, shape, visible, chroma, fixed, clipped)
    for round_ in range(ROUNDS):
        labels = model.relabel(luma, pal, labels)
        if round_ < ROUNDS - 1:
            misfit = np.sqrt(((model.decoded(pal, labels)[..., 1:] - chroma) ** 2).sum(axis=-1))
            pal, labels = _grow(luma, chroma, misfit, pal, labels, min_count, radius)
            pal = model.refit(luma, pal, labels)
    return labels, np.clip(yuv_to_rgb(pal), 0, 255)


def _grow(luma: np.ndarray, chroma: np.ndarray, misfit: np.ndarray, pal: np.ndarray, labels: np.ndarray,
          min_count: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Add palette colours for pixels the palette does not explain (luma more than
    ``MISSING`` noise steps from their label's, or decoded chroma ``misfit`` more than
    ``CHROMA_MISSING`` from the model's): while at least ``min_count`` of them lie within
    ``radius`` of one luma, the densest such luma becomes a colour (its chroma, the mean of
    theirs, is mixed; the refit unmixes it) and takes them."""
    for _ in range(GROW_STEPS):
        on = labels >= 0
        lost = on & ((np.abs(luma - pal[np.maximum(labels, 0), 0]) > MISSING * LUMA_NOISE)
                     | (misfit > CHROMA_MISSING * CHROMA_NOISE))
        if lost.sum() < min_count:
            break
        reach = int(radius)
        counts = np.bincount(np.clip(np.round(luma[lost]), 0, 255).astype(np.int64), minlength=256)
        around = np.convolve(counts, np.ones(2 * reach + 1), mode="same")  # pixels within the radius
        centre = int(np.argmax(around))
        if around[centre] < min_count:
            break
        take = lost & (np.abs(luma - centre) <= reach + 0.5)
        colour = np.concatenate([[luma[take].mean()], chroma[take].mean(axis=0)])
        pal = np.vstack([pal, colour])
        labels = np.where(take, len(pal) - 1, labels)
    return pal, labels


class _Model:
    """The decoder's chroma model on one image, worked at the level of the chroma samples
    (a quarter of the pixels for 4:2:0), and the two alternating steps.

    With b the samples of the labels' chroma (block means), the decoder's chroma is U b
    (U: the upsampling, separable) and the error |U b − (C − o)|² (C: decoded chroma, o: the
    share of the fixed transparent pixels). Its gradient with respect to b is
    2 (G b − t) with G = UᵀU, tridiagonal along each subsampled axis, and t = Uᵀ(C − o),
    fixed per image; so a label change only needs G applied to the samples.
    """

    def __init__(self, grid: ChromaGrid, shape: tuple[int, int], visible: np.ndarray, chroma: np.ndarray,
                 fixed: np.ndarray, clipped: np.ndarray) -> None:
        self.grid, self.shape, self.visible = grid, shape, visible
        self.grams = grid.gram(shape)
        #: a pixel's weight in its sample (1/2 per subsampled axis, 1 for a lone edge pixel),
        #: and weight² · Gᵢᵢ of its sample: the |Δ|² coefficient of a label change
        self.weight, self.change = np.ones(shape), np.ones(shape)
        for axis, diagonal, _ in self.grams:
            n = shape[axis]
            along = np.full(n, 0.5)
            if n % 2:
                along[-1] = 1.0
            self.weight = self.weight * np.expand_dims(along, 1 - axis)
            self.change = self.change * np.expand_dims(along ** 2 * diagonal[np.arange(n) // 2], 1 - axis)
        self.chroma = chroma
        #: how much each pixel's chroma counts in the refit: less where the decoder clipped it
        self.trust = np.where(clipped, CLIPPED_WEIGHT, 1.0)
        # the transparent pixels' share of the decoded chroma (none in a JPEG)
        self.offset = grid.up(grid.down(fixed), shape) if fixed.any() else np.zeros_like(fixed)
        target = grid.up_adjoint(chroma - self.offset)
        self.target = target[..., 0] + 1j * target[..., 1]  # t, (bh, bw), chroma as u + iv
        rows, cols = np.indices(shape)
        self.sample_index = (rows // grid.block[0]) * self.target.shape[1] + cols // grid.block[1]
        #: Gᵢᵢ of each sample (the product of the per-axis diagonals)
        self.sample_diagonal = np.ones(self.target.shape[:2])
        for axis, diagonal, _ in self.grams:
            self.sample_diagonal = self.sample_diagonal * np.expand_dims(diagonal, 1 - axis)
        everywhere = bool(visible.all())  # a JPEG: no transparent pixel to leave out
        #: per phase: pixel and sample slices, visible pixels (None: all), weights, |Δ|²
        #: coefficients, and each pixel's index in the phase
        self.phase_list = []
        for pixels, blocks in self.phases():
            weight = self.weight[pixels]
            self.phase_list.append((pixels, blocks, None if everywhere else visible[pixels], weight,
                                    self.change[pixels], np.arange(weight.size).reshape(weight.shape)))

    def decoded(self, pal: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """``(h, w, 3)`` YUV: what the decoder would give back for this labelling (each
        label's luma, the rebuilt chroma, clipped to RGB's range as decoders do)."""
        chroma = np.where(self.visible[..., None], pal[labels, 1:], 0.0)
        yuv = np.concatenate([pal[labels, :1], self.grid.up(self.grid.down(chroma), self.shape) + self.offset], axis=-1)
        return rgb_to_yuv(np.clip(yuv_to_rgb(yuv), 0, 255))

    def samples(self, pixels: np.ndarray) -> np.ndarray:
        """``(h, w, ...)`` → ``(bh, bw, ...)``: the block means (the encoder's samples)."""
        return self.grid.down(pixels)

    def gram_times(self, samples: np.ndarray) -> np.ndarray:
        """G = upᵀup applied to ``(bh, bw, ...)`` samples."""
        for axis, diagonal, off in self.grams:
            samples = np.swapaxes(_tridiagonal(np.swapaxes(samples, 0, axis), diagonal, off), 0, axis)
        return samples

    def phases(self):
        """The four pixel phases (row and column parity) as (pixel slices, sample slices): the
        pixels of a phase are never neighbours and each has a sample of its own."""
        for di in (0, 1):
            for dj in (0, 1):
                pixels = (slice(di, None, 2), slice(dj, None, 2))
                count = ((self.shape[0] - di + 1) // 2, (self.shape[1] - dj + 1) // 2)
                # with 2 pixels per sample along an axis, the phase's pixel i has sample i
                blocks = tuple(slice(0, n) if k == 2 else pixel for k, n, pixel in zip(self.grid.block, count, pixels))
                yield pixels, blocks

    def relabel(self, luma: np.ndarray, pal: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """Up to ``SWEEPS`` sweeps of iterated conditional modes over the four phases, each
        one vectorized step over the ``CANDIDATES`` palette colours nearest in luma to each
        pixel. A pixel's chroma term is the change of the model's error when its label alone
        changes: with Δ = weight · (new − current chroma) the change of its sample, it is
        2 Δ·(G b − t) + |Δ|² Gᵢᵢ. After a phase, G b − t is brought up to date for the change
        of each sample itself (Gᵢᵢ Δ); the small share of the neighbouring samples (G's
        off-diagonal) waits for the next sweep."""
        padded = np.full((labels.shape[0] + 2, labels.shape[1] + 2), -1)  # neighbours off the image
        padded[1:-1, 1:-1] = labels  # take no colour
        labels = padded[1:-1, 1:-1]
        # chroma as complex numbers u + iv, in noise units: one array where there would be two
        pal_chroma = (pal[:, 1] + 1j * pal[:, 2]) / CHROMA_NOISE
        m = min(CANDIDATES, len(pal))
        by_luma = np.argsort(pal[:, 0], kind="stable")
        sorted_luma = pal[by_luma, 0]
        # the m colours nearest in luma are a run of the sorted colours, starting at one of
        # m + 1 places: the run whose farther end is nearer
        start = np.clip(np.searchsorted(sorted_luma, luma)[..., None] - np.arange(m, -1, -1), 0, len(pal) - m)
        reach = np.maximum(np.abs(luma[..., None] - sorted_luma[start]),
                           np.abs(sorted_luma[start + m - 1] - luma[..., None]))
        first = np.take_along_axis(start, np.argmin(reach, axis=-1)[..., None], axis=-1)
        candidates = by_luma[first + np.arange(m)]  # (h, w, m)
        cand = pal_chroma[candidates]
        cand_conj = cand.conj()  # a·conj(c) has real part a_u c_u + a_v c_v
        # the terms that do not depend on the neighbours: luma, and |Δ|² Gᵢᵢ's new-colour part
        fixed_cost = (((luma[..., None] - pal[candidates, 0]) / LUMA_NOISE) ** 2
                      + self.change[..., None] * (cand * cand_conj).real)
        current = np.where(self.visible, pal_chroma[labels], 0.0)
        for _ in range(SWEEPS):
            gradient = self.gram_times(self.samples(current)) - self.target / CHROMA_NOISE  # G b − t
            changed = False
            for pixels, blocks, shown, weight, change, index in self.phase_list:
                if shown is not None and not shown.any():
                    continue
                here = current[pixels]
                options = candidates[pixels]
                di, dj = pixels[0].start, pixels[1].start
                n_rows, n_cols = index.shape
                agree = (padded[di::2, dj + 1::2][:n_rows, :n_cols, None] == options).astype(np.float64)
                for oi, oj in ((2, 1), (1, 0), (1, 2)):  # above (first), below, left, right
                    agree += padded[oi + di::2, oj + dj::2][:n_rows, :n_cols, None] == options
                linear = 2 * (weight * gradient[blocks] - change * here)
                cost = fixed_cost[pixels] - SMOOTHNESS * agree + (linear[..., None] * cand_conj[pixels]).real
                pick = np.argmin(cost, axis=-1) + index * m
                best = options.ravel()[pick]
                if shown is not None:
                    best = np.where(shown, best, -1)
                if (best != labels[pixels]).any():
                    changed = True
                    labels[pixels] = best
                    new = cand[pixels].ravel()[pick]
                    if shown is not None:
                        new = np.where(shown, new, 0.0)
                    gradient[blocks] += self.sample_diagonal[blocks] * weight * (new - here)
                    current[pixels] = new
            if not changed:
                break
        return labels.copy()

    def refit(self, luma: np.ndarray, pal: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """The palette (YUV) that best explains the labelling: each colour's luma is the
        mean luma of its pixels (robust: Cauchy weights at LUMA_NOISE, so that the blurred
        edges of a thin feature count less), its chroma the least-squares solution of
        "decoded chroma = U b(labels)", pulled towards the previous value (``RIDGE`` per
        pixel of the colour). With S the samples of each colour's indicator, that is
        (SᵀGS + ridge) x = Sᵀt + ridge x₀. Colours without pixels stay as they are."""
        k = len(pal)
        on = labels >= 0
        lab = labels[on]
        count = np.bincount(lab, minlength=k).astype(np.float64)
        y = luma[on]
        w_luma = 1 / (1 + ((y - pal[lab, 0]) / LUMA_NOISE) ** 2)
        mass = np.bincount(lab, weights=w_luma, minlength=k)
        new_luma = np.bincount(lab, weights=w_luma * y, minlength=k) / np.maximum(mass, 1e-12)

        # decoded chroma ≈ up(down(one-hot)) @ palette chroma, one equation per pixel; pixels the
        # decoder clipped to RGB's range tell little about the chroma it had (CLIPPED_WEIGHT)
        shares = np.bincount(self.sample_index[on] * k + lab, weights=self.weight[on],
                             minlength=self.target.size * k)  # each sample's share of each colour
        design = self.grid.up(shares.reshape(self.target.shape + (k,)), self.shape).reshape(-1, k)
        weighted = design * self.trust.reshape(-1, 1)
        # by einsum's own loops (not BLAS, see ChromaGrid)
        normal = np.einsum("pk,pl->kl", weighted, design) + np.diag(RIDGE * count + 1e-9)
        right = (np.einsum("pk,pc->kc", weighted, (self.chroma - self.offset).reshape(-1, 2))
                 + (RIDGE * count)[:, None] * pal[:, 1:])
        new_chroma = np.linalg.solve(normal, right)

        out = pal.copy()
        used = count > 0
        out[used, 0] = new_luma[used]
        out[used, 1:] = new_chroma[used]
        return rgb_to_yuv(np.clip(yuv_to_rgb(out), 0, 255))  # a colour the image could have
