"""Perceptual comparison of two renders, for CI: do two SVG/PNG files look the same?

Both images are brought to the same size (SVGs rendered by cairosvg), flattened over an
opaque background colour that neither image contains — so a seam or an alpha leak shows
as that colour — and compared pixel by pixel with the YIQ colour distance of pixelmatch
(Kotsarenko & Ramos, "Measuring perceived color difference using YIQ NTSC transmission
color space", 2010). A pixel differs when its distance exceeds ``35215 · threshold²``
(35215 is the largest distance there is, between cyan and red) unless it looks like
anti-aliasing: a pixel whose neighbours contain both a darker and a brighter pixel, one of
which sits in a flat area of both images, is an edge rendered slightly differently, not
a change.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import validate
from ..api import flatten
from ..arrays import unique
from ..colour import Colour
from ..errors import InputError
from ..limits import DEFAULT_MAX_DIFF_PIXELS
from ..prepare.image import check_pixels, load_image, read_source

DEFAULT_THRESHOLD = 0.1  # pixelmatch's default: about 1% of the largest YIQ distance
MAX_YIQ_DELTA = 35215.0  # the largest YIQ distance between two colours (cyan and red)
#: Backgrounds tried in order when none is given: the first colour neither image contains.
BACKGROUNDS: tuple[Colour, ...] = ((255, 0, 255), (0, 255, 255), (0, 255, 0), (255, 255, 0),
                                   (0, 0, 255), (255, 0, 0), (255, 128, 0), (128, 0, 255))
# the 8 neighbours (dy, dx) in pixelmatch's scan order (column by column), which decides
# which of two equally dark neighbours is "the darkest"
_NEIGHBOURS = np.array([(dy, dx) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)])


class SizeMismatchError(InputError):
    """The two images have different sizes."""


@dataclass(frozen=True, eq=False)
class Comparison:
    """Result of :func:`compare` on two opaque images of the same size."""

    a: np.ndarray  # (H, W, 4) uint8, flattened
    b: np.ndarray  # (H, W, 4) uint8, flattened
    different: np.ndarray  # (H, W) bool: perceptibly different pixels
    antialiased: np.ndarray  # (H, W) bool: over the threshold but judged anti-aliasing
    threshold: float

    @property
    def different_pixels(self) -> int:
        return int(self.different.sum())

    @property
    def ratio(self) -> float:
        """Fraction of all pixels that differ."""
        return self.different_pixels / max(self.different.size, 1)

    def diff_image(self) -> np.ndarray:
        """``(H, W, 4) uint8`` picture of the result, in pixelmatch's colours: image A faded
        to light grey, differences red, anti-aliasing yellow."""
        grey = 255.0 + (luma(self.a[..., :3]) - 255.0) * 0.1
        out = np.empty(self.a.shape, np.uint8)
        out[..., :3] = np.round(grey)[..., None].astype(np.uint8)
        out[..., 3] = 255
        out[self.antialiased, :3] = (255, 255, 0)
        out[self.different, :3] = (255, 0, 0)
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
            include_antialiasing: bool = False) -> Comparison:
    """Compare two opaque ``(H, W, 4) uint8`` images of the same size pixel by pixel."""
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} vs {b.shape}")
    if not 0.0 <= threshold <= 1.0:
        raise ValueError(f"threshold must be within 0..1, not {threshold}")
    over = yiq_distance(a[..., :3], b[..., :3]) > MAX_YIQ_DELTA * threshold * threshold
    antialiased = np.zeros(over.shape, dtype=bool)
    if over.any() and not include_antialiasing:
        rows, cols = np.nonzero(over)
        flat_both = _flat(a) & _flat(b)
        aa = _antialiased(luma(a[..., :3]), flat_both, rows, cols)
        aa |= _antialiased(luma(b[..., :3]), flat_both, rows, cols)
        antialiased[rows[aa], cols[aa]] = True
    return Comparison(a, b, over & ~antialiased, antialiased, threshold)


def _flat(rgba: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixel has 3 or more identical neighbours (image borders count as one)."""
    h, w = rgba.shape[:2]
    q = rgba.astype(np.int64)
    key = (q[..., 0] << 24) | (q[..., 1] << 16) | (q[..., 2] << 8) | q[..., 3]
    padded = np.pad(key, 1, constant_values=-1)
    same = sum((padded[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] == key).astype(np.int64)
               for dy, dx in _NEIGHBOURS)
    return same + _on_border(h, w, *np.indices((h, w))) > 2


def _on_border(h: int, w: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    return ((rows == 0) | (rows == h - 1) | (cols == 0) | (cols == w - 1)).astype(np.int64)


def _antialiased(y: np.ndarray, flat_both: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """For the pixels (rows, cols) of one image with luma ``y``: do they look like anti-aliasing?

    Yes when at most two neighbours share the pixel's brightness, some neighbour is darker
    and some brighter, and the darkest or the brightest of them is flat in both images.
    """
    h, w = y.shape
    padded = np.pad(y, 1, constant_values=np.nan)
    nr = rows[None, :] + _NEIGHBOURS[:, :1]  # (8, K)
    nc = cols[None, :] + _NEIGHBOURS[:, 1:]
    delta = y[rows, cols][None, :] - padded[nr + 1, nc + 1]  # centre minus neighbour, NaN outside
    inside = ~np.isnan(delta)
    equal = _on_border(h, w, rows, cols) + (delta == 0).sum(axis=0)
    k = np.arange(rows.size)
    darkest = np.argmin(np.where(inside, delta, np.inf), axis=0)  # first of equals, as pixelmatch
    brightest = np.argmax(np.where(inside, delta, -np.inf), axis=0)
    has_both = (delta[darkest, k] < 0) & (delta[brightest, k] > 0)
    r0, c0 = np.clip(nr[darkest, k], 0, h - 1), np.clip(nc[darkest, k], 0, w - 1)
    r1, c1 = np.clip(nr[brightest, k], 0, h - 1), np.clip(nc[brightest, k], 0, w - 1)
    return (equal <= 2) & has_both & (flat_both[r0, c0] | flat_both[r1, c1])


def pick_background(images: list[np.ndarray], candidates: tuple[Colour, ...] = BACKGROUNDS) -> Colour:
    """The first candidate colour that no visible pixel of any image has."""
    used = set()
    for rgba in images:
        visible = rgba[rgba[..., 3] > 0][:, :3].astype(np.int64)
        used.update(unique((visible[:, 0] << 16) | (visible[:, 1] << 8) | visible[:, 2]).tolist())
    for c in candidates:
        if (c[0] << 16) | (c[1] << 8) | c[2] not in used:
            return c
    return candidates[0]


def is_svg(data: bytes, path: str | os.PathLike = "") -> bool:
    """SVG by extension, or by content starting with an XML declaration or ``<svg``."""
    if Path(path).suffix.lower() == ".svg":
        return True
    head = data[:512].lstrip(b"\xef\xbb\xbf \t\r\n")
    return head.startswith(b"<?xml") or head.startswith(b"<svg")


def load_pair(path_a: str | os.PathLike, path_b: str | os.PathLike, *, scale: float = 1.0,
              allow_size_mismatch: bool = False,
              max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> tuple[np.ndarray, np.ndarray]:
    """Both files as ``(H, W, 4) uint8`` RGBA of the same size, not yet flattened.

    The comparison size is a raster's own size (or an SVG's width/height when both are
    SVGs) times ``scale``: a raster is enlarged by nearest-neighbour (each pixel a square,
    as pixel art is meant to be seen) and an SVG is rendered at that size. So
    ``scale=8`` compares a sprite's SVG with its 1x PNG at 8x. Different sizes raise
    :class:`SizeMismatchError` unless ``allow_size_mismatch``: then both are padded with
    transparency to the larger size, so the area only one image covers counts as changed.
    Every image, read or rendered, is refused over ``max_pixels`` before it is decoded.
    """
    from PIL import Image  # noqa: PLC0415

    from ..render.raster import render_rgba, svg_size  # noqa: PLC0415

    validate.positive("scale", scale)
    max_pixels = validate.limit("max_pixels", max_pixels)
    paths = (path_a, path_b)
    data = [read_source(p) for p in paths]
    svg = [is_svg(d, p) for d, p in zip(data, paths)]
    images: list[np.ndarray | None] = [None, None]
    for i, (d, p) in enumerate(zip(data, paths)):
        if svg[i]:
            continue
        rgba = load_image(d, max_pixels=max_pixels)
        size = max(1, round(rgba.shape[1] * scale)), max(1, round(rgba.shape[0] * scale))
        check_pixels(str(p), size[0], size[1], max_pixels)
        images[i] = rgba.copy() if size == rgba.shape[1::-1] else \
            np.asarray(Image.fromarray(rgba, "RGBA").resize(size, Image.Resampling.NEAREST))
    for i, (d, p) in enumerate(zip(data, paths)):
        if not svg[i]:
            continue
        other = images[1 - i]
        if not svg[1 - i] and other is not None:  # the other is a raster: its (scaled) size rules
            height, width = other.shape[:2]
        else:
            w, h = svg_size(d, name=str(p))
            width, height = max(1, round(w * scale)), max(1, round(h * scale))
        check_pixels(str(p), width, height, max_pixels)
        images[i] = render_rgba(d, width=width, height=height, name=str(p), max_output_pixels=max_pixels)
    a, b = images
    assert a is not None and b is not None  # every SVG was rendered above
    if a.shape != b.shape:
        if not allow_size_mismatch:
            raise SizeMismatchError(f"{path_a} is {a.shape[1]}x{a.shape[0]} but {path_b} is "
                                    f"{b.shape[1]}x{b.shape[0]}")
        height, width = max(a.shape[0], b.shape[0]), max(a.shape[1], b.shape[1])
        a, b = (np.pad(x, ((0, height - x.shape[0]), (0, width - x.shape[1]), (0, 0))) for x in (a, b))
    return a, b


def diff_files(path_a: str | os.PathLike, path_b: str | os.PathLike, *, scale: float = 1.0,
               threshold: float = DEFAULT_THRESHOLD, background: Colour | None = None,
               allow_size_mismatch: bool = False, include_antialiasing: bool = False,
               max_pixels: int | None = DEFAULT_MAX_DIFF_PIXELS) -> tuple[Comparison, Colour]:
    """Load, flatten and compare two SVG/PNG files; returns the comparison and the background used."""
    validate.number("threshold", threshold, low=0, high=1)
    a, b = load_pair(path_a, path_b, scale=scale, allow_size_mismatch=allow_size_mismatch, max_pixels=max_pixels)
    if background is None:
        background = pick_background([a, b])
    comparison = compare(flatten(a, background), flatten(b, background), threshold, include_antialiasing)
    return comparison, background


def within(comparison: Comparison, max_pixels_diff: int | None = None, max_ratio: float | None = None) -> bool:
    """The verdict: no pixel differs, or the differing pixels are within either bound given
    (at most ``max_pixels_diff`` pixels, or at most the fraction ``max_ratio`` of all)."""
    count = comparison.different_pixels
    if count == 0:
        return True
    by_count = max_pixels_diff is not None and count <= max_pixels_diff
    by_ratio = max_ratio is not None and comparison.ratio <= max_ratio
    return by_count or by_ratio
