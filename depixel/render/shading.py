"""Stage 7 — paper §3.5 — VectorImage → smoothly shaded RGBA raster.

The paper renders its vectors by interpolating the pixel colours with radial basis
functions that stop at the contours: a truncated Gaussian (σ = 1 pixel, radius 2) sits at
the centroid of every reshaped cell, and the colour at a point is the influence-weighted
average of the cells whose support reaches it. docs/rendering.md describes the practical
formulation implemented here:

* a cell influences a point only when both lie in the same region (cells joined by
  invisible edges, :func:`depixel.vector.regions`), so no colour leaks across a contour;
  not in the paper, the backdrop is a region of its own (:func:`shading_regions`);
* the region under a point comes from a scanline rasterization of the cell polygons, with
  every curved edge flattened to a polyline, at ``supersample × supersample`` samples per
  output pixel; contours are anti-aliased by averaging those samples;
* the Gaussian is lowered by its value at the radius so that it reaches zero continuously
  (a hard cut would draw faint rings in gradients);
* the result is pulled back towards the colour of the cell containing the point just far
  enough to stay within the paper's similarity thresholds of it: a region is only chained
  by pairwise similarity, so a long gradient could otherwise drift.

Colours are averaged premultiplied by alpha; a fully transparent region stays transparent.
Everything is vectorized per tile of output rows, so memory stays bounded at any scale.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import ranges
from ..colour import rgb_to_yuv
from ..curves.bspline import bend, edge_halves, flatten_edges, pieces_for
from ..errors import RenderError
from ..params import Params
from ..prepare.backdrop import backdrop_mask
from ..vector import VectorImage, regions
from .visibility import Occluders

FLATTEN_TOLERANCE = 0.1  # not in paper: polyline error of flattened curves, in output pixels
TILE_SAMPLES = 1 << 18  # not in paper: samples per tile; bounds memory (~40 MB) and fits caches
#: not in paper: polyline error (input pixels) of the contours that stop a cell's influence
VISIBILITY_TOLERANCE = 0.05
MAX_OUTPUT_PIXELS = 1 << 28  # not in paper: the RGBA result alone is 1 GiB at this size


def render_smooth(image: VectorImage, scale: float, supersample: int | None = None,
                  params: Params = Params()) -> np.ndarray:
    """Render a VectorImage with the paper's smooth shading.

    Parameters
    ----------
    image : any stage's VectorImage (cells, splines or optimized).
    scale : output pixels per input pixel; the output is ``round(H*scale) × round(W*scale)``.
    supersample : samples per output pixel along each axis for anti-aliased contours
        (odd values put a sample at the pixel centre); default ``params.shading_supersample``.
    params : the Gaussian's ``shading_sigma`` and ``shading_radius``, and the similarity
        thresholds that bound the shading.

    Returns
    -------
    ``(round(H*scale), round(W*scale), 4) uint8`` RGBA, straight (not premultiplied) alpha.
    """
    if supersample is None:
        supersample = params.shading_supersample
    if not scale > 0 or not np.isfinite(scale):
        raise ValueError(f"scale must be a positive number, got {scale!r}")
    if int(supersample) != supersample or supersample < 1:
        raise ValueError(f"supersample must be a positive integer, got {supersample!r}")
    supersample = int(supersample)
    h, w = image.shape
    out_h, out_w = max(1, round(h * scale)), max(1, round(w * scale))
    if out_h * out_w > MAX_OUTPUT_PIXELS:
        raise RenderError(f"a {out_w}×{out_h} render is too large (at most {MAX_OUTPUT_PIXELS} pixels)")
    pieces = _flatten(image, _pieces_per_curve(image, FLATTEN_TOLERANCE / max(out_h / h, out_w / w)))
    field = _ShadingField(image, pieces, params)
    segments = _Segments(image, pieces)
    rows_per_tile = max(1, TILE_SAMPLES // (out_w * supersample * supersample))
    out = np.empty((out_h, out_w, 4), np.uint8)
    for r0 in range(0, out_h, rows_per_tile):
        r1 = min(out_h, r0 + rows_per_tile)
        out[r0:r1] = _render_tile(field, segments, r0, r1, (out_h, out_w), supersample)
    return out


# --- geometry -----------------------------------------------------------------------------


def _pieces_per_curve(image: VectorImage, tolerance: float) -> int:
    """Line pieces per quadratic Bézier so that every flattened curve stays within
    ``tolerance`` input pixels of the true curve (chord error ≤ |P0 - 2C + P1| / 4n²)."""
    if not image.curved.any():
        return 1
    p = image.points
    u, v = image.cells.edges[image.curved, 0], image.cells.edges[image.curved, 1]
    first, second = edge_halves(p[u], image.controls[image.curved], p[v])
    worst = np.maximum(bend(*first), bend(*second)).max()
    return pieces_for(worst, tolerance)


class Pieces(NamedTuple):
    """Line pieces of flattened cell edges, each walked from the edge's u towards its v."""

    a: np.ndarray  # (S, 2) start of each piece
    b: np.ndarray  # (S, 2) end
    edge: np.ndarray  # (S,) int64 the cell edge it belongs to


def _flatten(image: VectorImage, n: int) -> Pieces:
    """Line pieces of every edge: one per straight edge, ``n`` per quadratic Bézier of a
    curved edge."""
    p = image.points
    u, v = image.cells.edges[:, 0], image.cells.edges[:, 1]
    straight = np.flatnonzero(~image.curved)
    curved = np.flatnonzero(image.curved)
    poly = flatten_edges(p[u[curved]], image.controls[curved], p[v[curved]], n)  # (C, 2n+1, 2)
    a = np.concatenate([p[u[straight]], poly[:, :-1].reshape(-1, 2)])
    b = np.concatenate([p[v[straight]], poly[:, 1:].reshape(-1, 2)])
    edge = np.concatenate([straight, np.repeat(curved, 2 * n)])
    return Pieces(a, b, edge)


def cell_centroids(image: VectorImage, pieces: Pieces | None = None) -> np.ndarray:
    """``(H*W, 2)`` centroid (x, y) of every cell polygon, curved edges flattened."""
    a, b, edge = _flatten(image, _pieces_per_curve(image, FLATTEN_TOLERANCE / 8.0)) if pieces is None else pieces
    cells = image.cells
    n_cells, n_edges = cells.cell_ptr.size - 1, len(cells.edges)
    # shoelace sums per edge walked u → v; walking it backwards flips their signs
    cross = a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
    per_edge = np.stack([
        np.bincount(edge, cross, minlength=n_edges),
        np.bincount(edge, (a[:, 0] + b[:, 0]) * cross, minlength=n_edges),
        np.bincount(edge, (a[:, 1] + b[:, 1]) * cross, minlength=n_edges),
    ], axis=1)
    e = cells.cell_edges
    sign = np.where(cells.edges[e, 0] == cells.cell_nodes, 1.0, -1.0)
    owner = np.repeat(np.arange(n_cells), np.diff(cells.cell_ptr))
    sums = np.stack([np.bincount(owner, sign * per_edge[e, k], minlength=n_cells) for k in range(3)], axis=1)
    return sums[:, 1:] / (3.0 * sums[:, :1])


class _Segments:
    """The line pieces of every flattened edge that are not horizontal, oriented top to
    bottom, each with the cell on its east side (the cell a scanline enters there), sorted
    by their top so that a band of rows finds its pieces by bisection."""

    def __init__(self, image: VectorImage, pieces: Pieces):
        a, b, edge = pieces
        down = b[:, 1] > a[:, 1]
        keep = b[:, 1] != a[:, 1]
        top = np.where(down[:, None], a, b)[keep]
        bottom = np.where(down[:, None], b, a)[keep]
        # walking down the screen, the left-hand side is east (cells.py edge_pixels)
        left, right = image.cells.edge_pixels[edge, 0], image.cells.edge_pixels[edge, 1]
        order = np.argsort(top[:, 1], kind="stable")
        top, bottom = top[order], bottom[order]
        self.east = np.where(down, left, right)[keep][order]
        self.x_top, self.y_top, self.y_bottom = top[:, 0], top[:, 1], bottom[:, 1]
        self.slope = (bottom[:, 0] - top[:, 0]) / (bottom[:, 1] - top[:, 1])  # dx/dy
        self.tallest = float((self.y_bottom - self.y_top).max(initial=0.0))

    def band(self, y0: float, y1: float) -> slice:
        """The pieces that may cross a row with ``y0 ≤ y ≤ y1`` (a superset)."""
        lo = np.searchsorted(self.y_top, y0 - self.tallest - 1e-9, side="left")
        hi = np.searchsorted(self.y_top, y1 + 1e-9, side="right")
        return slice(int(lo), int(hi))


def _cell_labels(seg: _Segments, k0: int, k1: int, fy: float, fx: float, width: int) -> np.ndarray:
    """Cell under every sample of sample rows ``k0 ≤ k < k1`` (``(k1-k0, width)`` int64).

    Sample (k, j) sits at ``((j + .5) / fx, (k + .5) / fy)``. A segment crosses row k when
    ``y_top ≤ y_k < y_bottom``; along a row, each sample lies in the east cell of the last
    crossing at or before it. At a node the row passes exactly through, the crossings tie
    and the segment turning most to the east is the one that borders the samples after it,
    so ties are broken by dx/dy.
    """
    band = seg.band((k0 + 0.5) / fy, (k1 - 0.5) / fy)
    first = np.maximum(np.ceil(seg.y_top[band] * fy - 0.5), k0).astype(np.int64)
    stop = np.minimum(np.ceil(seg.y_bottom[band] * fy - 0.5), k1).astype(np.int64)
    count = np.maximum(stop - first, 0)
    hit = np.flatnonzero(count)
    count, first = count[hit], first[hit]
    which = np.repeat(hit + band.start, count)  # one entry per (segment, row) crossing
    row = ranges(first, count)
    x = seg.x_top[which] + ((row + 0.5) / fy - seg.y_top[which]) * seg.slope[which]
    col = np.clip(np.ceil(x * fx - 0.5), 0, width).astype(np.int64)
    order = np.lexsort((seg.slope[which], x, row))
    row, col, east = row[order] - k0, col[order], seg.east[which][order]
    last = np.r_[(row[1:] != row[:-1]) | (col[1:] != col[:-1]), True]
    start = np.full((k1 - k0, width + 1), -1, np.int64)
    start[row[last], col[last]] = east[last]
    start = start[:, :width]
    source = np.where(start >= 0, np.arange(width), 0)
    np.maximum.accumulate(source, axis=1, out=source)
    return np.take_along_axis(start, source, axis=1)


# --- colour -------------------------------------------------------------------------------


class _ShadingField:
    """The colour field: per-cell centroids, colours and regions, evaluated at points."""

    def __init__(self, image: VectorImage, pieces: Pieces, params: Params):
        h, w = image.shape
        self.shape = (h, w)
        self.centroid = cell_centroids(image, pieces)
        self.region = shading_regions(image)
        rgba = image.rgba.reshape(-1, 4).astype(np.float64)
        alpha = rgba[:, 3:] / 255.0
        self.premultiplied = np.concatenate([rgba[:, :3] * alpha, alpha], axis=1)
        self.rgba = rgba
        self.yuva = np.concatenate([rgb_to_yuv(rgba[:, :3]), rgba[:, 3:]], axis=1)
        self.limit = np.array([params.threshold_y, params.threshold_u, params.threshold_v,
                               params.threshold_alpha])
        self.sigma, self.radius = params.shading_sigma, params.shading_radius
        rows, cols = np.divmod(np.arange(h * w), w)
        centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
        shift = np.abs(self.centroid - centre).max()
        # offsets (dy, dx) of every pixel whose cell centroid may lie within the radius of a
        # point in pixel (0, 0): the nearest approach per axis is |d| - 1/2 - shift
        reach = int(np.ceil(self.radius + 0.5 + shift))
        d = np.arange(-reach, reach + 1)
        near = np.maximum(np.abs(d) - 0.5 - shift, 0.0)
        dy, dx = np.meshgrid(d, d, indexing="ij")
        close = near[:, None] ** 2 + near[None, :] ** 2 < self.radius**2
        self.offsets = np.stack([dy[close], dx[close]], axis=1)
        self.flat = self._flat_cells(reach + 1)
        # the cells on a grid padded by `reach` (region -1, no colour), so that neighbour
        # (dy, dx) of a padded index q is simply q + dy * padded_width + dx
        self.reach = reach
        pad = ((reach, reach), (reach, reach))
        # (float32 halves the memory traffic of the hot loop; weights need no more precision)
        self.pad_x = np.pad(self.centroid[:, 0].reshape(h, w), pad).ravel().astype(np.float32)
        self.pad_y = np.pad(self.centroid[:, 1].reshape(h, w), pad).ravel().astype(np.float32)
        self.pad_region = np.pad(self.region.reshape(h, w), pad, constant_values=-1).ravel()
        self.pad_colour = np.pad(self.premultiplied.reshape(h, w, 4), pad + ((0, 0),)).reshape(-1, 4).astype(np.float32)
        coarse = _flatten(image, _pieces_per_curve(image, VISIBILITY_TOLERANCE))
        self.occluders = Occluders(image, coarse, self.centroid, self.region, self.premultiplied, self.radius,
                                   self.offsets)

    def _flat_cells(self, radius: int) -> np.ndarray:
        """``(H*W,)`` bool: every cell of the same region within ``radius`` pixels (Chebyshev)
        has this cell's colour, so any point of the cell less than a pixel outside its square
        gets exactly this colour (most of pixel art: regions of one colour)."""
        h, w = self.shape
        region = self.region.reshape(h, w)
        colour = self.premultiplied.reshape(h, w, 4)
        flat = np.ones((h, w), dtype=bool)
        for dy in range(-min(radius, h - 1), min(radius, h - 1) + 1):
            for dx in range(-min(radius, w - 1), min(radius, w - 1) + 1):
                a = (slice(max(0, -dy), min(h, h - dy)), slice(max(0, -dx), min(w, w - dx)))
                b = (slice(max(0, dy), min(h, h + dy)), slice(max(0, dx), min(w, w + dx)))
                differs = (region[b] == region[a]) & (colour[b] != colour[a]).any(axis=-1)
                flat[a] &= ~differs
        return flat.ravel()

    def premultiplied_at(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray) -> np.ndarray:
        """``(P, 4)`` premultiplied RGBA (alpha 0-1) at points (x, y) lying in ``cell``."""
        h, w = self.shape
        result = self.premultiplied[cell]
        row, col = np.divmod(cell, w)
        near = (np.abs(np.floor(y) - row) <= 1) & (np.abs(np.floor(x) - col) <= 1)
        shaded = np.flatnonzero(~(near & self.flat[cell]))
        if shaded.size:
            result[shaded] = self._blend(x[shaded], y[shaded], cell[shaded])
        return result

    def _blend(self, x: np.ndarray, y: np.ndarray, cell: np.ndarray) -> np.ndarray:
        """The influence-weighted average at points, without the flat-cell shortcut."""
        h, w = self.shape
        region = self.region[cell]
        stride = w + 2 * self.reach
        i0 = np.clip(np.floor(y).astype(np.int64), 0, h - 1)
        j0 = np.clip(np.floor(x).astype(np.int64), 0, w - 1)
        base = (i0 + self.reach) * stride + (j0 + self.reach)
        x32, y32 = x.astype(np.float32), y.astype(np.float32)
        total = np.zeros(x.size, np.float32)
        acc = np.zeros((x.size, 4), np.float32)
        floor = np.float32(np.exp(-(self.radius**2) / (2 * self.sigma**2)))
        pixel = i0 * w + j0
        for o, (dy, dx) in enumerate(self.offsets.tolist()):
            q = base + (dy * stride + dx)
            d2 = (self.pad_x[q] - x32) ** 2 + (self.pad_y[q] - y32) ** 2
            weight = np.exp(d2 * np.float32(-0.5 / self.sigma**2)) - floor
            weight *= (self.pad_region[q] == region) & (weight > 0)
            seen = weight.nonzero()[0]  # by the paper's visibility: no visible edge on the way
            hidden = self.occluders.hidden(pixel[seen], o, pixel[seen] + (dy * w + dx), x[seen], y[seen])
            weight[seen[hidden]] = 0
            total += weight
            acc += weight[:, None] * self.pad_colour[q]
        acc, total = acc.astype(np.float64), total.astype(np.float64)
        lonely = total <= 0  # no centroid of the region within reach: the cell's own colour
        acc[lonely] = self.premultiplied[cell[lonely]]
        total[lonely] = 1.0
        acc /= total[:, None]
        return self._within_thresholds(acc, cell)

    def _within_thresholds(self, premultiplied: np.ndarray, cell: np.ndarray) -> np.ndarray:
        """Move each colour towards its cell's colour until it is similar to it.

        The blend ``own + t (colour - own)`` with the largest t ≤ 1 inside the threshold box
        (|ΔY|, |ΔU|, |ΔV|, |Δalpha|) stays in gamut and is the identity where the shading
        is already similar to the cell, which is almost everywhere.
        """
        alpha = premultiplied[:, 3]
        straight = np.zeros((alpha.size, 4))
        visible = alpha > 0
        straight[visible, :3] = premultiplied[visible, :3] / alpha[visible, None]
        straight[:, 3] = alpha * 255.0
        own = self.rgba[cell]
        delta = np.concatenate([rgb_to_yuv(straight[:, :3]), straight[:, 3:]], axis=1) - self.yuva[cell]
        delta[~visible, :3] = 0.0  # the colour of a transparent point is irrelevant
        with np.errstate(divide="ignore"):
            t = np.min(np.where(np.abs(delta) > 0, self.limit / np.abs(delta), np.inf), axis=1)
        t = np.minimum(t, 1.0)
        pulled = t < 1.0
        if not pulled.any():
            return premultiplied
        blend = own[pulled] + t[pulled, None] * (straight[pulled] - own[pulled])
        result = premultiplied.copy()
        a = blend[:, 3] / 255.0
        result[pulled] = np.concatenate([blend[:, :3] * a[:, None], a[:, None]], axis=1)
        return result


def shading_regions(image: VectorImage) -> np.ndarray:
    """(H*W,) the regions a cell's influence stays in: the paper's (cells joined by invisible
    edges), with the backdrop (:func:`depixel.prepare.backdrop.backdrop_mask`) a region of
    its own. Not in the paper: a backdrop similar to the art's darkest tone would otherwise
    blend into it and the outline would dissolve into a glow (docs/rendering.md, "The backdrop")."""
    region = regions(image.cells)
    backdrop = backdrop_mask(image.rgba).ravel()
    if backdrop.any():
        region = np.where(backdrop, int(region.max()) + 1, region)
    return region


def _render_tile(field: _ShadingField, seg: _Segments, r0: int, r1: int, out_shape: tuple[int, int],
                 s: int) -> np.ndarray:
    """Output rows ``r0 ≤ r < r1``: one shading evaluation per output pixel whose samples
    all lie in one region (at its central sample), one per sample elsewhere."""
    h, w = field.shape
    out_h, out_w = out_shape
    fy, fx = out_h * s / h, out_w * s / w  # samples per input pixel
    labels = _cell_labels(seg, r0 * s, r1 * s, fy, fx, out_w * s)
    rows = r1 - r0
    k = np.arange(r0 * s, r1 * s)
    j = np.arange(out_w * s)
    missing = labels < 0  # only if the outline leaves the image frame: take the pixel below
    if missing.any():
        ki, ji = np.nonzero(missing)
        pi = np.clip(((k[ki] + 0.5) / fy).astype(np.int64), 0, h - 1)
        pj = np.clip(((j[ji] + 0.5) / fx).astype(np.int64), 0, w - 1)
        labels[ki, ji] = pi * w + pj
    block = labels.reshape(rows, s, out_w, s).transpose(0, 2, 1, 3).reshape(rows, out_w, s * s)
    reg = field.region[block]
    # one evaluation where every sample lies in one region and no wall between two of its
    # cells (a visible edge inside the region) crosses the pixel
    uniform = (reg == reg[..., :1]).all(axis=2)
    uniform &= ~(field.occluders.wall[block].any(axis=2) & (block != block[..., :1]).any(axis=2))

    colour = np.empty((rows, out_w, 4))
    centre = (s // 2) * s + s // 2
    ui, uj = np.nonzero(uniform)
    ys = (r0 * s + ui * s + s // 2 + 0.5) / fy
    xs = (uj * s + s // 2 + 0.5) / fx
    colour[ui, uj] = field.premultiplied_at(xs, ys, block[ui, uj, centre])

    mi, mj = np.nonzero(~uniform)
    if mi.size:
        sub = np.arange(s * s)
        sy, sx = np.divmod(sub, s)
        ys = ((r0 * s + mi[:, None] * s + sy[None]) + 0.5) / fy
        xs = ((mj[:, None] * s + sx[None]) + 0.5) / fx
        cells = block[mi, mj]
        samples = field.premultiplied_at(xs.ravel(), ys.ravel(), cells.ravel())
        colour[mi, mj] = samples.reshape(mi.size, s * s, 4).mean(axis=1)

    alpha = colour[..., 3]
    rgb = np.zeros((rows, out_w, 3))
    np.divide(colour[..., :3], alpha[..., None], out=rgb, where=alpha[..., None] > 0)
    out = np.concatenate([rgb, alpha[..., None] * 255.0], axis=-1)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)
