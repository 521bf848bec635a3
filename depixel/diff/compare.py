"""Perceptual comparison of two renders, for CI: do two images look the same?

Two opaque images of one size are compared pixel by pixel with the YIQ colour distance of
pixelmatch (Kotsarenko & Ramos, "Measuring perceived color difference using YIQ NTSC
transmission color space", 2010). A pixel differs when its distance exceeds
``35215 · threshold²`` (35215 is the largest distance there is, between cyan and red)
unless it is anti-aliasing: an edge rendered slightly differently, not a change.

A pixel is anti-aliasing when, in one of the images, it looks like an edge blend and the
other image shows the same colour next to it (docs/cli.md, "Anti-aliasing"):

1. pixelmatch's test: at most two neighbours share its brightness, some neighbour is darker
   and some brighter, and the darkest or the brightest of them sits in a flat area (3 or
   more identical neighbours) of both images;
2. it is a blend in both images, not a flat colour: in neither image does a neighbour that
   is flat there have the pixel's colour (within the threshold) — a pixel that took (or
   lost) a neighbouring area's colour is that area grown, not an edge drawn differently;
3. the other image has a matching colour nearby: one of the pixel's 8 neighbours in the
   other image is within the threshold of it — the edge moved by less than a pixel.

pixelmatch stops at 1, which misses small changes: a sprite pixel converted and rendered at
2x is a blob of a few pixels, each between a darker and a brighter flat neighbour, so
every one of them passed for anti-aliasing. Rules 2 and 3 keep the edges that truly moved.

The comparison runs in bands of rows (with the two rows around each band that the tests
look at), so its memory is the two 8-bit images and a few bytes a pixel of results,
whatever the size.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import unique
from ..colour import Colour
from ..frozen import compact_repr

DEFAULT_THRESHOLD = 0.1  # pixelmatch's default: about 1% of the largest YIQ distance
MAX_YIQ_DELTA = 35215.0  # the largest YIQ distance between two colours (cyan and red)
#: Backgrounds tried in order when none is given: the first colour neither image contains.
BACKGROUNDS: tuple[Colour, ...] = ((255, 0, 255), (0, 255, 255), (0, 255, 0), (255, 255, 0),
                                   (0, 0, 255), (255, 0, 0), (255, 128, 0), (128, 0, 255))
#: Pixels compared at once (a band of whole rows): bounds the float temporaries.
BAND_PIXELS = 1 << 16
#: Colours of the diff picture: differing pixels, anti-aliasing, ignored (masked) pixels.
RED, YELLOW, MASKED = (255, 0, 0), (255, 255, 0), (160, 200, 255)
# the 8 neighbours (dy, dx) in pixelmatch's scan order (column by column), which decides
# which of two equally dark neighbours is "the darkest"
_NEIGHBOURS = np.array([(dy, dx) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)])
_HALO = 2  # rows around a band: a neighbour's flatness looks one row further


@dataclass(frozen=True, eq=False)
class Comparison:
    """Result of :func:`compare` on two opaque images of the same size."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    a: np.ndarray  # (H, W, 4) uint8, flattened
    b: np.ndarray  # (H, W, 4) uint8, flattened
    different: np.ndarray  # (H, W) bool: perceptibly different pixels
    antialiased: np.ndarray  # (H, W) bool: over the threshold but judged anti-aliasing
    threshold: float
    ignored: np.ndarray | None = None  # (H, W) bool: masked out, never compared

    @property
    def different_pixels(self) -> int:
        return int(np.count_nonzero(self.different))

    @property
    def compared_pixels(self) -> int:
        """Pixels compared: all but the masked ones."""
        masked = 0 if self.ignored is None else int(np.count_nonzero(self.ignored))
        return self.different.size - masked

    @property
    def ratio(self) -> float:
        """Fraction of the compared pixels that differ."""
        return self.different_pixels / max(self.compared_pixels, 1)

    def diff_image(self) -> np.ndarray:
        """``(H, W, 4) uint8`` picture of the result, in pixelmatch's colours: image A faded
        to light grey, differences red, anti-aliasing yellow; masked pixels pale blue."""
        out = np.empty(self.a.shape, np.uint8)
        for rows in _bands(*self.a.shape[:2]):
            grey = 255.0 + (luma(self.a[rows, :, :3]) - 255.0) * 0.1
            out[rows, :, :3] = np.round(grey)[..., None].astype(np.uint8)
        out[..., 3] = 255
        if self.ignored is not None:
            out[self.ignored, :3] = MASKED
        out[self.antialiased, :3] = YELLOW
        out[self.different, :3] = RED
        return out


def luma(rgb: np.ndarray) -> np.ndarray:
    """The Y of YIQ for an ``(..., 3)`` RGB array on 0-255 → ``(...) float64``."""
    rgb = rgb.astype(np.float64)
    return rgb[..., 0] * 0.29889531 + rgb[..., 1] * 0.58662247 + rgb[..., 2] * 0.11448223


def yiq_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Weighted squared YIQ distance of two ``(..., 3)`` RGB arrays → ``(...) float64`` in [0, 35215]."""
    a, b = a.astype(np.float64), b.astype(np.float64)
    d = a - b
    y = luma(a) - luma(b)
    i = d[..., 0] * 0.59597799 - d[..., 1] * 0.27417610 - d[..., 2] * 0.32180189
    q = d[..., 0] * 0.21147017 - d[..., 1] * 0.52261711 + d[..., 2] * 0.31114694
    return 0.5053 * y * y + 0.299 * i * i + 0.1957 * q * q


def compare(a: np.ndarray, b: np.ndarray, threshold: float = DEFAULT_THRESHOLD,
            include_antialiasing: bool = False, ignore: np.ndarray | None = None) -> Comparison:
    """Compare two opaque ``(H, W, 4) uint8`` images of the same size pixel by pixel.

    ``include_antialiasing`` counts every pixel over the threshold; ``ignore`` is an
    ``(H, W)`` bool mask of pixels never compared."""
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} vs {b.shape}")
    if not 0.0 <= threshold <= 1.0:
        raise ValueError(f"threshold must be within 0..1, not {threshold}")
    if ignore is not None and ignore.shape != a.shape[:2]:
        raise ValueError(f"mask is {ignore.shape[1]}x{ignore.shape[0]}, the images {a.shape[1]}x{a.shape[0]}")
    h, w = a.shape[:2]
    limit = MAX_YIQ_DELTA * threshold * threshold
    different = np.zeros((h, w), dtype=bool)
    antialiased = np.zeros((h, w), dtype=bool)
    for rows in _bands(h, w):
        over = yiq_distance(a[rows, :, :3], b[rows, :, :3]) > limit
        if ignore is not None:
            over &= ~ignore[rows]
        if not over.any():
            continue
        if include_antialiasing:
            different[rows] = over
            continue
        lo, hi = max(rows.start - _HALO, 0), min(rows.stop + _HALO, h)
        r, c = np.nonzero(over)
        aa = _antialiasing(a[lo:hi], b[lo:hi], r + rows.start - lo, c, lo, h, limit)
        antialiased[r[aa] + rows.start, c[aa]] = True
        different[r[~aa] + rows.start, c[~aa]] = True
    return Comparison(a, b, different, antialiased, threshold, ignore)


def _bands(h: int, w: int) -> list[slice]:
    step = max(1, BAND_PIXELS // max(w, 1))
    return [slice(r, min(r + step, h)) for r in range(0, h, step)]


def _antialiasing(a: np.ndarray, b: np.ndarray, rows: np.ndarray, cols: np.ndarray, top: int, height: int,
                  limit: float) -> np.ndarray:
    """For the pixels (rows, cols) of the bands ``a`` and ``b`` (rows ``top``… of images
    ``height`` rows high), over the threshold: are they anti-aliasing (module docstring)?"""
    flat_a, flat_b = _flat(a, top, height), _flat(b, top, height)
    flat_both = flat_a & flat_b
    result = np.zeros(rows.size, dtype=bool)
    for x, y in ((a, b), (b, a)):
        edge = _edge_blend(luma(x[..., :3]), flat_both, rows, cols, top, height)  # rule 1
        if edge.any():
            k = edge.nonzero()[0]
            edge[k] = _matches_neighbour(x, y, rows[k], cols[k], limit)  # rule 3
        result |= edge
    if result.any():  # rule 2, in either image
        k = result.nonzero()[0]
        grown = _matches_neighbour(a, a, rows[k], cols[k], limit, flat_a)
        grown |= _matches_neighbour(b, b, rows[k], cols[k], limit, flat_b)
        result[k] = ~grown
    return result


def _flat(rgba: np.ndarray, top: int, height: int) -> np.ndarray:
    """(h, w) bool: the pixel has 3 or more identical neighbours (image borders count as one)."""
    h, w = rgba.shape[:2]
    q = rgba.astype(np.int64)
    key = (q[..., 0] << 24) | (q[..., 1] << 16) | (q[..., 2] << 8) | q[..., 3]
    padded = np.pad(key, 1, constant_values=-1)
    same = sum((padded[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] == key).astype(np.int64)
               for dy, dx in _NEIGHBOURS)
    rows, cols = np.indices((h, w))
    return same + _on_border(height, w, rows + top, cols) > 2


def _on_border(h: int, w: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    return ((rows == 0) | (rows == h - 1) | (cols == 0) | (cols == w - 1)).astype(np.int64)


def _edge_blend(y: np.ndarray, flat_both: np.ndarray, rows: np.ndarray, cols: np.ndarray, top: int,
                height: int) -> np.ndarray:
    """pixelmatch's test for the pixels (rows, cols) of one image band with luma ``y``:
    at most two neighbours share the pixel's brightness, some neighbour is darker and some
    brighter, and the darkest or the brightest of them is flat in both images."""
    h, w = y.shape
    padded = np.pad(y, 1, constant_values=np.nan)
    nr = rows[None, :] + _NEIGHBOURS[:, :1]  # (8, K)
    nc = cols[None, :] + _NEIGHBOURS[:, 1:]
    delta = y[rows, cols][None, :] - padded[nr + 1, nc + 1]  # centre minus neighbour, NaN outside
    inside = ~np.isnan(delta)
    equal = _on_border(height, w, rows + top, cols) + (delta == 0).sum(axis=0)
    k = np.arange(rows.size)
    darkest = np.argmin(np.where(inside, delta, np.inf), axis=0)  # first of equals, as pixelmatch
    brightest = np.argmax(np.where(inside, delta, -np.inf), axis=0)
    has_both = (delta[darkest, k] < 0) & (delta[brightest, k] > 0)
    r0, c0 = np.clip(nr[darkest, k], 0, h - 1), np.clip(nc[darkest, k], 0, w - 1)
    r1, c1 = np.clip(nr[brightest, k], 0, h - 1), np.clip(nc[brightest, k], 0, w - 1)
    return (equal <= 2) & has_both & (flat_both[r0, c0] | flat_both[r1, c1])


def _matches_neighbour(x: np.ndarray, y: np.ndarray, rows: np.ndarray, cols: np.ndarray, limit: float,
                       where: np.ndarray | None = None) -> np.ndarray:
    """Whether some neighbour of each pixel (rows, cols) in ``y`` (only those ``where``
    is true, when given) is within the threshold of the pixel's colour in ``x``."""
    h, w = x.shape[:2]
    centre = x[rows, cols, :3]
    found = np.zeros(rows.size, dtype=bool)
    for dy, dx in _NEIGHBOURS:
        r, c = rows + dy, cols + dx
        k = ((r >= 0) & (r < h) & (c >= 0) & (c < w)).nonzero()[0]
        close = yiq_distance(centre[k], y[r[k], c[k], :3]) <= limit
        if where is not None:
            close &= where[r[k], c[k]]
        found[k] |= close
    return found


def pick_background(images: list[np.ndarray], candidates: tuple[Colour, ...] = BACKGROUNDS) -> Colour:
    """The first candidate colour that no visible pixel of any image has."""
    used: set[int] = set()
    for rgba in images:
        for rows in _bands(*rgba.shape[:2]):
            band = rgba[rows]
            visible = band[band[..., 3] > 0][:, :3].astype(np.int64)
            used.update(unique((visible[:, 0] << 16) | (visible[:, 1] << 8) | visible[:, 2]).tolist())
    for c in candidates:
        if (c[0] << 16) | (c[1] << 8) | c[2] not in used:
            return c
    return candidates[0]


def flatten_in_place(rgba: np.ndarray, background: Colour) -> np.ndarray:
    """Composite ``(H, W, 4) uint8`` straight RGBA over an opaque colour, in place, band by
    band (the arithmetic of :func:`depixel.api.flatten`, without its full-size int64 copies); returns it."""
    colour = np.asarray(background, dtype=np.int32)
    for rows in _bands(*rgba.shape[:2]):
        band = rgba[rows]
        alpha = band[..., 3:4].astype(np.int32)
        band[..., :3] = (band[..., :3] * alpha + colour * (255 - alpha) + 127) // 255
        band[..., 3] = 255
    return rgba


def within(comparison: Comparison, max_pixels_diff: int | None = None, max_ratio: float | None = None) -> bool:
    """The verdict: no pixel differs, or the differing pixels are within either bound given
    (at most ``max_pixels_diff`` pixels, or at most the fraction ``max_ratio`` of all)."""
    count = comparison.different_pixels
    if count == 0:
        return True
    by_count = max_pixels_diff is not None and count <= max_pixels_diff
    by_ratio = max_ratio is not None and comparison.ratio <= max_ratio
    return by_count or by_ratio
