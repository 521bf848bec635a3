"""What a simplified curve is checked against — the reference half of the SVG writer's fits.

:class:`Exact` holds the exact segments of the boundary pieces as cubics and their samples,
with each piece's tolerance; :class:`Protected` the points a fitted curve must keep on their
side (pixel centres and the lattice corners of diagonal links) and the segments near each.
:mod:`depixel.svg.curvefit` fits curves and tests them against these; the plane helpers at the
end are the layout both work in.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..arrays import batch_slices, nan_to_zero
from ..curves.bspline import cubic_weights, elevate
from ..graph.cells import link_corners
from ..vector import VectorImage
from .boundaries import CUBIC, QUAD, BoundaryPieces

T_ORIG = np.array([0.0, 0.25, 0.5, 0.75])  # samples of each exact segment
W_ORIG = cubic_weights(T_ORIG[:, None])  # their Bernstein weights, (4, 1) each as in flatten_cubic
#: a piece may deviate by at most this fraction of its size (the diagonal of its bounding
#: box), so a small closed curve — an eye, a dot — keeps its shape at any tolerance
_RELATIVE_TOLERANCE = 1 / 16


def _piece_tolerance(pieces: BoundaryPieces, exact: Exact, tolerance: float) -> np.ndarray:
    """(K,) the tolerance of every exact segment: ``tolerance``, or less on small pieces."""
    count = np.diff(pieces.ptr)
    has = count > 0
    # a piece's samples are consecutive: its extent by reduceat from its first (ufunc.at
    # would handle every sample on its own), the parts' starts and ends (so both ends of
    # the piece count, whichever way it runs)
    first = pieces.ptr[:-1].compress(has) * exact.part_start.shape[2]
    extent = []
    for axis in range(2):
        starts, ends = exact.part_start[axis].ravel(), exact.part_end[axis].ravel()
        extent.append(np.maximum(np.maximum.reduceat(starts, first), np.maximum.reduceat(ends, first))
                      - np.minimum(np.minimum.reduceat(starts, first), np.minimum.reduceat(ends, first)))
    size = np.sqrt(extent[0] ** 2 + extent[1] ** 2)
    return np.minimum(tolerance, _RELATIVE_TOLERANCE * size).repeat(count.compress(has))


#: ranges are fitted and checked in batches of about this many exact segments, to bound the
#: temporary memory (a few hundred bytes a sample and a protected point); the result does
#: not depend on it
BATCH = 1 << 12


class Exact:
    """The exact segments of every piece: ends, cubic control points, tangents, samples."""

    def __init__(self, pieces: BoundaryPieces, tolerance: float) -> None:
        n = pieces.kind.size
        piece = np.arange(len(pieces)).repeat(np.diff(pieces.ptr))
        first = pieces.ptr[:-1][piece] == np.arange(n)
        self.start = np.where(first[:, None], pieces.start.take(piece, axis=0), np.roll(pieces.end, 1, axis=0))
        self.end = pieces.end
        c1, c2 = _as_cubic(self.start, pieces.kind, pieces.ctrl, pieces.ctrl2, self.end)
        chord = self.end - self.start
        self.tan_start, self.tan_end = _tangent(c1 - self.start, chord), _tangent(self.end - c2, chord)
        # flatten_cubic's samples (the same products and sums) on x and y planes with the
        # segments innermost: (2, 4, K), then (2, 5, K) with the ends
        b0, b1, b2, b3 = W_ORIG
        p0, p1, p2, p3 = (planes(p)[:, None, :] for p in (self.start, c1, c2, self.end))
        polyline = np.concatenate([b0 * p0 + b1 * p1 + b2 * p2 + b3 * p3, p3], axis=1)
        del p0, p1, p2, p3
        #: (4, K, 4) the starts (x, y: the samples) and the ends (x, y) of the parts of each
        #: segment's polyline (:func:`parts`), one table so that one gather picks a part's both
        #: ends. Only this is kept (~128 bytes a segment; the writer holds it for every segment)
        self.parts = parts(polyline.transpose(0, 2, 1))
        #: (2, K, 4) views of :attr:`parts`: the parts' starts and ends
        self.part_start, self.part_end = self.parts[:2], self.parts[2:]
        del polyline
        dx, dy = self.part_end - self.part_start  # the same differences as np.diff of the polyline
        step = np.sqrt(dx * dx + dy * dy)
        del dx, dy
        self.length = step.sum(axis=1)  # polyline length of each segment
        self.arc = step.cumsum(axis=1) - step  # arc length of each sample within its segment
        self.tolerance = _piece_tolerance(pieces, self, tolerance)  # (K,) each segment's own limit


def _tangent(leg: np.ndarray, chord: np.ndarray) -> np.ndarray:
    """(K, 2) unit vectors along the control legs ``leg``, or along ``chord`` where a leg is
    zero: v / max(|v|, 1e-300), |v| written out (the numbers of ``np.linalg.norm``), a
    coordinate at a time (numpy runs an inner loop of 2 where a per-row number meets (K, 2)
    rows)."""
    has_leg = (np.abs(leg[:, 0]) > 0) | (np.abs(leg[:, 1]) > 0)
    x, y = np.where(has_leg, leg[:, 0], chord[:, 0]), np.where(has_leg, leg[:, 1], chord[:, 1])
    length = np.maximum(np.sqrt(x * x + y * y), 1e-300)
    unit = np.empty(leg.shape)
    np.divide(x, length, out=unit[:, 0])
    np.divide(y, length, out=unit[:, 1])
    return unit


def _as_cubic(start, kind, ctrl, ctrl2, end) -> tuple[np.ndarray, np.ndarray]:
    """Cubic control points of line, quadratic and cubic segments (degree elevation)."""
    quad = (kind == QUAD)[:, None]
    cubic = (kind == CUBIC)[:, None]
    q1, q2 = elevate(start, nan_to_zero(ctrl), end)
    c1 = np.where(quad, q1, start + (end - start) / 3.0)
    c2 = np.where(quad, q2, end - (end - start) / 3.0)
    c1 = np.where(cubic, nan_to_zero(ctrl), c1)
    c2 = np.where(cubic, nan_to_zero(ctrl2), c2)
    return c1, c2


class Protected:
    """Points the simplified curves must keep on their side, with their signed distance to
    the exact piece and the exact segment they are nearest to (sorted by it).

    Each point belongs to the cell edges beside it, so only the few exact segments of those
    edges (the two half spans of each) are searched for its nearest one."""

    def __init__(self, pieces: BoundaryPieces, image: VectorImage, exact: Exact, reach: float) -> None:
        cells = image.cells
        w = cells.shape[1]
        curved = (pieces.edge_piece >= 0).nonzero()[0]
        sides = cells.edge_pixels[curved]
        ends = cells.edges.take(curved, axis=0)
        corners = [_split_corner(cells.nodes.take(ends[:, j], axis=0)) for j in range(2)]
        segments_of = _SegmentsOfEdges(pieces, image)
        # the points, in this order: the pixel centres on either side of every curved edge,
        # the lattice corners at either end; all kinds together, a batch at a time, keeping
        # the near ones
        whiches, xys = [], []
        for j in range(2):
            which = (sides[:, j] >= 0).nonzero()[0]
            rows, cols = np.divmod(sides[which, j], w)
            whiches.append(which)
            xys.append(np.stack([cols + 0.5, rows + 0.5], axis=-1))
        for which, xy in corners:
            whiches.append(which)
            xys.append(xy)
        edge, xy = curved[np.concatenate(whiches)], np.concatenate(xys)
        near_xy, near_dist, near_seg = [], [], []
        for batch in batch_slices(edge.size, BATCH // 2):  # ~7 distances a point: (2, V, 4) arrays
            dist, signed, seg = _nearest_segment(xy[batch], segments_of(edge[batch]), exact)
            near = np.isfinite(dist) & (dist < reach) & (dist > 1e-9)
            near_xy.append(xy[batch].compress(near, axis=0))
            near_dist.append(signed[near])
            near_seg.append(seg[near])
        xy, signed, seg = (np.concatenate(x) for x in (near_xy, near_dist, near_seg))
        # one point per (segment, place in eighth pixels), the first of each, ordered by
        # segment, then x, then y (a stable sort; what np.unique(axis=0) does, without its
        # per-row copies)
        eighths = [(xy[:, axis] * 8).round() for axis in range(2)]
        order = np.lexsort((eighths[1], eighths[0], seg))
        first = np.zeros(order.size, bool)
        first[:1] = True
        for key in (seg, *eighths):  # a new (segment, x, y) where any of them changes
            key = key.take(order)
            first[1:] |= key[1:] != key[:-1]
        pick = order.compress(first)
        #: (2, P) the points as x and y planes
        self.xy, self.dist, self.seg = planes(xy.take(pick, axis=0)), signed[pick], seg[pick]


def _split_corner(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which of the nodes ``q`` (E, 2; quarter pixels) lie a quarter pixel off a lattice
    corner in both x and y (a diagonal link's nodes), and that corner (in pixels)."""
    split, lattice = link_corners(q)
    which = split.nonzero()[0]
    return which, lattice.take(which, axis=0) / 4.0


def _nearest_segment(xy: np.ndarray, seg_of: np.ndarray, exact: Exact
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance of points ``xy`` (P, 2) to the nearest of their candidate segments ``seg_of``
    (P, 4) (the polylines of their samples and end), that distance signed by the side, and
    that segment."""
    # the distances to the parts of the candidates that exist (less than half of them), in
    # a (P, 4, 4) table where the others are infinite
    valid = np.flatnonzero(seg_of >= 0)  # (point, candidate) pairs, flat
    n_parts = exact.part_start.shape[2]
    seg = seg_of.ravel().take(valid)
    ab = exact.parts.take(seg, axis=1)  # (4, V, 4)
    a, b = ab[:2], ab[2:]
    q = planes(xy).take(valid // seg_of.shape[1], axis=1).repeat(n_parts, axis=1).reshape(a.shape)
    d = np.full((seg_of.shape[0], seg_of.shape[1], n_parts), np.inf)
    # the rows of distances put whole, each as one opaque item of n_parts floats (the same
    # bytes; a flat index per element costs ~10 times more)
    row = np.dtype((np.void, d.itemsize * n_parts))
    d.view(row).put(valid, np.ascontiguousarray(segment_distance(q, a, b)).view(row))
    # each point's nearest part (the first minimum), as flat indices of d, then of seg_of
    cell = d.reshape(d.shape[0], -1).argmin(axis=1) + np.arange(0, d.size, seg_of.shape[1] * n_parts)
    dist = d.ravel().take(cell)
    candidate, part = np.divmod(cell, n_parts)
    nearest_seg = seg_of.ravel().take(candidate)
    nearest = np.maximum(nearest_seg, 0) * n_parts + part  # flat part
    pab = exact.parts.reshape(4, -1).take(nearest, axis=1)
    pa, pb = pab[:2], pab[2:]
    ab, aq = pb - pa, planes(xy) - pa
    side = np.sign(ab[0] * aq[1] - ab[1] * aq[0])
    return dist, dist * np.where(side == 0, 1.0, side), nearest_seg


class _SegmentsOfEdges:
    """``(edges)`` → (len(edges), 4): indices of the exact segments of each curved edge's two
    spans (the half spans, or the full span when a joint was merged), -1 where there is none.

    A span has at most two segments, its halves (in index order, which is the order of the
    pieces), in one piece or one in each of two: a table of every slot's first and second
    segment, and each segment's piece to check against the edge's."""

    def __init__(self, pieces: BoundaryPieces, image: VectorImage) -> None:
        curves = image.curves
        assert curves is not None  # pieces exist only where there are curves
        self.curves, self.edge_piece = curves, pieces.edge_piece
        n_seg, n_slots = pieces.span_slot.size, curves.next.size
        # the tables end in a -1 that slot -1 (no next slot) and segment -1 (none) read
        piece = np.empty(n_seg + 1, np.int32)
        piece[:-1] = np.arange(len(pieces), dtype=np.int32).repeat(np.diff(pieces.ptr))
        piece[-1] = -1
        self.seg_piece = piece
        slot, seg = pieces.span_slot, np.arange(n_seg, dtype=np.int32)
        first, last = np.full(n_slots + 1, n_seg, np.int32), np.full(n_slots + 1, -1, np.int32)
        np.minimum.at(first, slot, seg)
        np.maximum.at(last, slot, seg)
        first[-1], last[-1] = n_seg, -1  # (a simplified segment's slot -1 does not count)
        self.first = np.where(first < n_seg, first, -1)
        self.second = np.where(last > first, last, -1)

    def __call__(self, edge: np.ndarray) -> np.ndarray:
        slots = np.empty((2, edge.size), np.int64)  # the edge's two slots
        slots[0] = self.curves.edge_slot.take(edge)
        slots[1] = self.curves.next.take(slots[0])
        piece = self.edge_piece.take(edge)
        first, second = self.first.take(slots), self.second.take(slots)
        in_first = self.seg_piece.take(first) == piece
        in_second = self.seg_piece.take(second) == piece
        # each of the four candidates on a plane (2 slots × 2), the piece's segments first
        found = np.empty((2, 2, edge.size), np.int64)
        found[:, 0] = np.where(in_first, first, np.where(in_second, second, -1))
        found[:, 1] = np.where(in_first & in_second, second, -1)
        return np.ascontiguousarray(found.reshape(4, -1).T)


# --- the planes both halves work in ----------------------------------------------------------


def segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points ``q`` to segments ``ab``, all x and y planes ``(2, ...)`` of one
    shape. In place where it can: these arrays are large, and fresh memory costs more here
    than the arithmetic."""
    ab = b - a
    qa = q - a
    t = np.multiply(qa[0], ab[0])
    t += np.multiply(qa[1], ab[1], out=qa[1])
    length2 = np.multiply(ab[0], ab[0], out=qa[0])
    length2 += np.multiply(ab[1], ab[1], out=qa[1])
    t /= np.maximum(length2, 1e-300, out=length2)
    np.minimum(np.maximum(t, 0.0, out=t), 1.0, out=t)  # np.clip without its Python overhead
    for axis in range(2):  # a plane at a time: no broadcast of t over the two (see _between)
        np.multiply(ab[axis], t, out=ab[axis])
    off = np.subtract(q, np.add(a, ab, out=ab), out=ab)
    dist = np.multiply(off[0], off[0], out=t)
    dist += np.multiply(off[1], off[1], out=off[1])
    return np.sqrt(dist, out=dist)


def per_sample(planes: np.ndarray, count: np.ndarray, axis: int = 1) -> np.ndarray:
    """``planes`` (2, M, ...) of M items, each repeated ``count`` times along ``axis``: what
    ``planes.take(np.repeat(np.arange(M), count), axis=1)`` gives, 2–3 times faster."""
    return planes.repeat(count, axis=axis)


def planes(points: np.ndarray) -> np.ndarray:
    """``(2, N)`` x and y planes of ``(N, 2)`` points. The numerics work on planes: an
    operation on (N, 2) points that broadcasts a per-point number, or picks rows by index,
    runs an inner loop of 2 per point in numpy, several times slower; the arithmetic per
    coordinate is the same, so are the numbers."""
    return np.ascontiguousarray(points.T)


def parts(polylines: np.ndarray) -> np.ndarray:
    """The starts and the ends of the parts of polylines ``(2, R, V)`` (x and y planes): one
    ``(4, R, V - 1)`` array, starts (x, y) then ends (x, y), each plane contiguous (numpy's
    loops then run over whole rows), so one gather picks both ends of a part."""
    parts = np.empty((4, polylines.shape[1], polylines.shape[2] - 1))
    parts[:2] = polylines[:, :, :-1]
    parts[2:] = polylines[:, :, 1:]
    return parts


def joined(exacts: Sequence[Exact], protected: Sequence[Protected]) -> tuple[Exact, Protected]:
    """The exact segments and the protected points of several images' pieces as one set, each
    image's segments after the one before's (its protected points' segments renumbered so):
    every array of the same rows, concatenated."""
    exact = Exact.__new__(Exact)
    for name in ("start", "end", "tan_start", "tan_end", "length", "arc", "tolerance"):
        setattr(exact, name, np.concatenate([getattr(e, name) for e in exacts]))
    exact.parts = np.concatenate([e.parts for e in exacts], axis=1)
    exact.part_start, exact.part_end = exact.parts[:2], exact.parts[2:]
    offsets = np.cumsum([0] + [e.end.shape[0] for e in exacts])
    points = Protected.__new__(Protected)
    points.xy = np.concatenate([p.xy for p in protected], axis=1)
    points.dist = np.concatenate([p.dist for p in protected])
    points.seg = np.concatenate([p.seg + offsets[i] for i, p in enumerate(protected)])
    return exact, points
