"""Thin lenses: faces whose drawn area is a sliver, drawn first among the faces of their depth.

Part of stage 6 (:mod:`depixel.svg.stacking`). A face Q of a pixel or two that anti-aliases
the art (a grey pixel between a black outline S and a white backdrop X) often comes out of
the relaxation as a lens a third of a pixel wide or less. Drawn after S (order X, S, Q), S
lies under Q and must stop short of Q's edge with X, which in a lens that thin it cannot do
everywhere: near the lens's tips one render pixel holds all three faces, and S's colour
shows through Q's anti-aliased edge (docs/svg.md, "Threads": the error scales with |S − X|).
Drawn before S (order X, Q, S), Q lies under S instead and S anti-aliases its own edge: the
same error scales with |Q − X|, a fraction of it, since such a Q lies between S and X in
colour. Ranking a lens before the other faces of its depth keeps every rule of the stacked
layout (a face enclosing another is still drawn first).
"""
from __future__ import annotations

import numpy as np

from ..vector import VectorImage

#: a face is a thin lens when its drawn area over its drawn perimeter is at most this: a
#: lens of length L and width t has area 2/3·L·t and perimeter about 2·L, a ratio of t / 3,
#: so a lens a third of a pixel wide or less (a unit square: 0.25, a one-pixel line: ~0.5)
THIN = 1.0 / 9.0
CONTRAST = 160
SMALL = 64


def thin_lenses(image: VectorImage, entry_ptr: np.ndarray, entry_from: np.ndarray, entry_to: np.ndarray,
                entry_edge: np.ndarray) -> np.ndarray:
    """(F,) bool: the face's area, bounded by its drawn curves (the half-edges
    ``entry_ptr[f]:entry_ptr[f+1]`` with the face on their right, y down), over the length
    of their control polygons is at most :data:`THIN`."""
    n = entry_ptr.size - 1
    face = np.arange(n).repeat(entry_ptr[1:] - entry_ptr[:-1])
    forward = (image.cells.edges.take(2 * entry_edge.astype(np.int64)) == entry_from)[:, None]
    p0, p1 = image.points.take(entry_from, axis=0), image.points.take(entry_to, axis=0)
    c = image.controls.take(entry_edge, axis=0)
    # a curved edge is two quadratics, points[u] c0 c1 and c1 c2 points[v]: taken the other
    # way, c2 and c0 swap
    c0, mid, c2 = np.where(forward, c[:, 0], c[:, 2]), c[:, 1], np.where(forward, c[:, 2], c[:, 0])
    curved = image.curved.take(entry_edge)
    # the shoelace of a quadratic (a, b, c): (2 a×b + 2 b×c + a×c) / 6 (a line: a×c / 2)
    twice = np.where(curved, (2 * _cross(p0, c0) + 2 * _cross(c0, mid) + _cross(p0, mid)
                              + 2 * _cross(mid, c2) + 2 * _cross(c2, p1) + _cross(mid, p1)) / 3.0, _cross(p0, p1))
    length = np.where(curved, _length(c0 - p0) + _length(mid - c0) + _length(c2 - mid) + _length(p1 - c2),
                      _length(p1 - p0))
    area = np.bincount(face, weights=twice, minlength=n) / 2.0
    perimeter = np.bincount(face, weights=length, minlength=n)
    return area <= THIN * perimeter


def lenses_before(order: np.ndarray, pairs: np.ndarray, lens: np.ndarray, group: np.ndarray,
                  rgb: np.ndarray, opaque: np.ndarray, area: np.ndarray) -> np.ndarray:
    """The drawing order (faces, back to front) with every lens Q moved just before S: of Q's
    neighbours (``pairs``: (a, b) both ways), X drawn first and S second, both opaque, S drawn
    before Q, X not in S's smooth group and Q nearer X than S is in colour (largest channel
    difference). If S is in a smooth ``group`` (>= 0), Q goes before the whole group, which
    stays together. ``lens``: the faces that may move (thin, opaque, in no group, no pocket)."""
    n = order.size
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(n)
    near = pairs.compress(lens.take(pairs[:, 0]), axis=0)
    if near.size == 0:
        return order
    near = near.take(np.lexsort((rank.take(near[:, 1]), near[:, 0])), axis=0)
    first = np.concatenate(([True], near[1:, 0] != near[:-1, 0])).nonzero()[0]
    second = first + 1
    two = second < np.concatenate((first[1:], [near.shape[0]]))  # Q has a second neighbour
    q, x, s = near[first.compress(two), 0], near[first.compress(two), 1], near[second.compress(two), 1]
    # the first face of S's group (S itself if in none)
    start = rank.copy()
    grouped = (group >= 0).nonzero()[0]
    if grouped.size:
        first_of = np.full(int(group.max()) + 1, n, np.int64)
        np.minimum.at(first_of, group.take(grouped), rank.take(grouped))
        start[grouped] = first_of.take(group.take(grouped))
    colour = rgb.astype(np.int64)
    move = opaque.take(x) & opaque.take(s) & (rank.take(s) < rank.take(q)) & (start.take(s) > rank.take(x))
    qx = np.abs(colour.take(q, axis=0) - colour.take(x, axis=0)).max(axis=1)
    sx = np.abs(colour.take(s, axis=0) - colour.take(x, axis=0)).max(axis=1)
    move &= (sx >= CONTRAST) & (qx * 2 <= sx) & (area.take(s) <= SMALL)
    if not move.any():
        return order
    # a moved lens sorts as the start of S's group less a half, the others at their rank
    key = 2 * rank + 1
    key[q.compress(move)] = 2 * start.take(s.compress(move))
    return np.lexsort((rank, key))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _length(d: np.ndarray) -> np.ndarray:
    return np.hypot(d[:, 0], d[:, 1])
