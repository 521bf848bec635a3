"""Stage 7 — paper §3.5 — what each cell's centroid sees, for the smooth renderer.

The paper sets the support of a cell's influence "to zero outside the region visible from
the cell centroid": a point gets a cell's colour only if the straight segment from the
cell's centroid to the point crosses no visible edge (no contour curve). Regions alone
(cells joined by invisible edges) let colour travel along a chain of similar tones around
the end of a contour, into a colour that is not similar to it — a bone's grey into the
backdrop through one middle grey; the segment test stops it.

Only segments shorter than the influence radius matter, so each cell keeps the line
pieces of the visible edges that come within that radius of its centroid (:class:`Occluders`),
and only the cells of regions of more than one colour need any: elsewhere every cell a
point sees has the same colour, seen or not.
"""
from __future__ import annotations

import numpy as np

from ..arrays import ranges, unique
from ..vector import VectorImage, linked_edges


class Occluders:
    """The pieces of visible edges that may hide a cell's centroid from a point, listed by
    the point's pixel P and the offset o of the cell's pixel from P: the pieces within the
    influence radius of the cell's centroid whose bounding box meets the box around P's
    square and the centroid (in sorted ``keys`` P * len(offsets) + o, CSR ``ptr``)."""

    def __init__(self, image: VectorImage, lines: tuple[np.ndarray, np.ndarray, np.ndarray], centroid: np.ndarray,
                 region: np.ndarray, colour: np.ndarray, radius: float, offsets: np.ndarray) -> None:
        """``lines``: ``(a, b, edge)``, the flattened line pieces of every cell edge and their
        edge; ``centroid`` (H*W, 2), ``region`` (H*W,) and ``colour`` (H*W, 4) of every cell;
        ``radius`` of the influence; ``offsets`` (K, 2) the (dy, dx) of the cells looked up."""
        a, b, edge = lines
        cells = image.cells
        h, w = cells.shape
        self.width, self.n_offsets, self.centroid = w, len(offsets), centroid
        left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
        visible = ~linked_edges(cells) & (left >= 0) & (right >= 0)
        # the inner walls between the cells of one region: where a point's colour jumps
        self.wall = np.zeros(h * w, bool)
        inner = visible & (region.take(np.maximum(left, 0)) == region.take(np.maximum(right, 0)))
        self.wall[left.compress(inner)] = True
        self.wall[right.compress(inner)] = True
        # only the cells of regions of more than one colour: elsewhere what a point sees has
        # its colour anyway
        member = np.zeros(int(region.max(initial=0)) + 1, np.int64)
        member[region] = np.arange(region.size)  # one cell of each region (any)
        shaded = np.zeros(member.size, bool)
        shaded[region.compress((colour != colour.take(member.take(region), axis=0)).any(axis=1))] = True
        shaded = shaded.take(region)
        keep = visible.take(edge)
        a, b = a.compress(keep, axis=0), b.compress(keep, axis=0)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        # (cell, piece): pieces within the radius of the cell's centroid
        shift = float(np.abs(centroid - _pixel_centres(h, w)).max(initial=0.0))
        reach = radius + shift + 0.5
        first = np.clip(np.floor(lo - reach), 0, [w - 1, h - 1]).astype(np.int64)
        last = np.clip(np.floor(hi + reach), 0, [w - 1, h - 1]).astype(np.int64)
        # the pieces with a shaded cell within reach (a summed-area table of the shaded
        # cells), so that art without shading (a game frame) lists nothing
        table = np.zeros((h + 1, w + 1), np.int64)
        table[1:, 1:] = shaded.reshape(h, w).cumsum(axis=0).cumsum(axis=1)
        (x0, y0), (x1, y1) = first.T, last.T + 1
        some = (table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]) > 0
        a, b, lo, hi, first, last = (v.compress(some, axis=0) for v in (a, b, lo, hi, first, last))
        nx, ny = last[:, 0] - first[:, 0] + 1, last[:, 1] - first[:, 1] + 1
        piece = np.arange(a.shape[0]).repeat(nx * ny)
        k = ranges(0, nx * ny)
        span = nx.take(piece)
        cell = (first[:, 1].take(piece) + k // span) * w + first[:, 0].take(piece) + k % span
        near = shaded.take(cell)
        piece, cell = piece.compress(near), cell.compress(near)
        near = _distance(centroid.take(cell, axis=0), a.take(piece, axis=0), b.take(piece, axis=0)) < radius
        piece, cell = piece.compress(near), cell.compress(near)
        # (pixel P, offset o, piece) for the cell at P + o
        keys, pieces = [], []
        row, col = np.divmod(cell, w)
        c = centroid.take(cell, axis=0)
        for o, (dy, dx) in enumerate(offsets.tolist()):
            py, px = row - dy, col - dx
            inside = (py >= 0) & (py < h) & (px >= 0) & (px < w)
            box_lo = np.minimum(c, np.stack([px, py], axis=1))
            box_hi = np.maximum(c, np.stack([px + 1, py + 1], axis=1))
            meets = inside & (lo.take(piece, axis=0) <= box_hi).all(axis=1)
            meets &= (hi.take(piece, axis=0) >= box_lo).all(axis=1)
            keys.append((py * w + px).compress(meets) * self.n_offsets + o)
            pieces.append(piece.compress(meets))
        key, piece = np.concatenate(keys), np.concatenate(pieces)
        order = np.argsort(key, kind="stable")
        key, piece = key.take(order), piece.take(order)
        self.keys = unique(key)
        self.ptr = key.searchsorted(np.concatenate((self.keys, [np.iinfo(np.int64).max])))
        self.listed = np.zeros(h * w * self.n_offsets, bool)  # which keys have pieces
        self.listed[self.keys] = True
        self.ax, self.ay = a[:, 0].take(piece), a[:, 1].take(piece)
        self.bx, self.by = b[:, 0].take(piece), b[:, 1].take(piece)

    def hidden(self, pixel: np.ndarray, offset: int, cell: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(P,) bool: the segment from the centroid of ``cell`` (at ``offsets[offset]`` from
        each point's ``pixel``) to the point (x, y) crosses a visible edge."""
        out = np.zeros(pixel.size, bool)
        if self.keys.size == 0:
            return out
        key = pixel * self.n_offsets + offset
        some = self.listed.take(key).nonzero()[0]
        if some.size == 0:
            return out
        at = self.keys.searchsorted(key.take(some))
        lo = self.ptr.take(at)
        count = self.ptr.take(at + 1) - lo
        pair = ranges(lo, count)
        which = np.arange(some.size).repeat(count)
        c = cell.take(some)
        px, py = self.centroid[:, 0].take(c).take(which), self.centroid[:, 1].take(c).take(which)
        qx, qy = x.take(some).take(which), y.take(some).take(which)
        ax, ay, bx, by = self.ax.take(pair), self.ay.take(pair), self.bx.take(pair), self.by.take(pair)
        # the piece's ends on either side of the line p→q, then p and q on either side of the
        # piece's line (an end on a line counts on one side, so a path through a node where
        # two pieces meet crosses exactly one of them)
        dx, dy = qx - px, qy - py
        cross = (dx * (ay - py) - dy * (ax - px) > 0) != (dx * (by - py) - dy * (bx - px) > 0)
        ex, ey = bx - ax, by - ay
        cross &= (ex * (py - ay) - ey * (px - ax) > 0) != (ex * (qy - ay) - ey * (qx - ax) > 0)
        out[some] = np.bincount(which, weights=cross, minlength=some.size) > 0
        return out


def _pixel_centres(h: int, w: int) -> np.ndarray:
    rows, cols = np.divmod(np.arange(h * w), w)
    return np.stack([cols + 0.5, rows + 0.5], axis=1)


def _distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` to segments ``a``–``b`` (all ``(K, 2)``)."""
    d = b - a
    length2 = np.maximum((d * d).sum(axis=1), 1e-300)
    t = np.clip(((p - a) * d).sum(axis=1) / length2, 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * d - p).T)
