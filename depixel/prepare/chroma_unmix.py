"""Stage 0b (preparation) for lossy 1× pixels — the joint labelling through the decoder's
chroma model — RGBA, a palette and a :class:`depixel.prepare.chroma.ChromaGrid` → the palette colour
of every pixel, and the palette refitted.

Once :func:`depixel.prepare.chroma.chroma_grid` has found how chroma was subsampled, :func:`unmix`
gives every pixel the palette colour that explains both its own luma and, through the
decoder's model, the chroma of the pixels around it; with a smoothness prior (pixel art is
made of runs of one colour), alternating with a refit of the palette's colours to that
labelling (least squares through the same model), so that a colour seen only in thin
features, mixed in every block, comes back unmixed. Apart from :mod:`depixel.prepare.chroma` (the
model and its detection) because this half has its own constants and its own solver.

Not in the paper; docs/inputs.md has the measurements. Arrays are ``(row, column)``; a
*block* is the set of pixels that share one chroma sample.
"""
from __future__ import annotations

import numpy as np

from ..colour import rgb_to_yuv
from .chroma import ChromaGrid, yuv_to_rgb

# --- constants (measured on the 54 paper sprites saved as JPEG, docs/inputs.md) ------------------
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


def fits(shape: tuple[int, int], colours: int) -> bool:
    """Whether :func:`unmix` takes an image of this size and palette (``MAX_CELLS``)."""
    return shape[0] * shape[1] * colours <= MAX_CELLS



def _tridiagonal(x: np.ndarray, diagonal: np.ndarray, off: np.ndarray) -> np.ndarray:
    """A symmetric tridiagonal matrix times ``x`` along axis 0."""
    shape = (-1,) + (1,) * (x.ndim - 1)
    out = diagonal.reshape(shape) * x
    out[1:] += off.reshape(shape) * x[:-1]
    out[:-1] += off.reshape(shape) * x[1:]
    return out



# --- joint labelling ------------------------------------------------------------------------------

def unmix(rgba: np.ndarray, palette: np.ndarray, grid: ChromaGrid, min_count: float = 3.0,
          radius: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The palette colour of every visible pixel of a decoded image whose chroma was
    subsampled on ``grid``, and the palette refitted.

    Parameters
    ----------
    rgba : ``(H, W, 4) uint8``, as decoded.
    palette : ``(K, 3)`` RGB (0-255) to start from (``depixel.prepare.palette``'s mode seeking).
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
