"""Which faces the SVG shades smoothly together.

Part of stage 6 (:mod:`depixel.svg.stacking`), for the SVG's smooth shading (paper §3.5).
The paper blends the colours of a region (cells joined by invisible edges) and stops at
every visible edge, the contour curves. An SVG blur cannot follow lines of sight, so the
SVG applies the rule to whole faces: a *smooth group* is a set of faces of one region
joined through invisible edges (similar colours) with no contour between two of its faces:
a visible boundary two pixel sides long or more, or any with a single pixel
(:data:`CONTOUR_EDGES`). A region whose chain of similar tones links two dissimilar faces
that touch along a contour (a bone, a middle grey, the backdrop) is split there, so no blur
crosses that contour. Not in the paper: the backdrop
(:func:`depixel.prepare.backdrop.backdrop_mask`) joins no group, so the art never blends
with it, however similar their colours (docs/rendering.md, "The backdrop"). The drawing
order keeps the faces of a group together (:class:`depixel.svg.stacking.FaceTopology`), so
a group is one ``<g>``.

Groups are grown like Kruskal's spanning tree: the face pairs that share invisible edges,
longest shared boundary first, join unless a contour lies between their groups. A face
left alone is drawn flat.
"""
from __future__ import annotations

import numpy as np

from ..arrays import sums_by_key, unique
from ..graph.cells import CellGraph
from ..prepare.backdrop import backdrop_mask
from ..vector import linked_edges

#: not in paper: two faces of a region stay in different groups when the visible boundary
#: between them is at least this many pixel sides, or when one of them is a single pixel.
#: At a single side between larger faces (two dissimilar tones touching at one pixel side, a
#: middle tone linking them all round) the paper's lines of sight are blocked along that side
#: alone and both faces see each other through the middle tone; splitting the whole region
#: there kept a crisp edge between a similar pair that the PNG renderer blends
#: (``gaxe2_axbattler_02``: 296 stepped pixels inside a region against the PNG renderer's
#: 188). A single pixel lies wholly within the blur's reach of that side, so joined it took
#: on its dissimilar neighbour's colour (``gaxe_skeleton``'s dithered bones: halo 0.007 % ->
#: 0.2 %; docs/svg.md, "Smooth groups")
CONTOUR_EDGES = 2


def smooth_groups(cells: CellGraph, labels: np.ndarray, face_region: np.ndarray, drawn: np.ndarray) -> np.ndarray:
    """(F,) int64 smooth group of every face (numbered from 0); -1 for a face drawn flat
    (alone in its group, or not drawn).

    ``labels`` (H*W,) face of every pixel; ``face_region`` (F,) and ``drawn`` (F,) bool
    (alpha above 0) of every face."""
    n = face_region.size
    drawn = drawn.copy()
    drawn[labels.compress(backdrop_mask(cells.graph.rgba).ravel())] = False  # the backdrop shades alone
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    inner = (left >= 0) & (right >= 0)
    a, b = labels.take(left.compress(inner)), labels.take(right.compress(inner))
    linked = linked_edges(cells).compress(inner)
    between = (a != b) & drawn.take(a) & drawn.take(b)
    between &= face_region.take(a) == face_region.take(b)  # (linked faces always share a region)
    a, b, linked = a.compress(between), b.compress(between), linked.compress(between)
    if a.size == 0:
        return np.full(n, -1, np.int64)
    key = np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)
    pairs, shared = sums_by_key(key, linked.astype(np.float64))
    _, edges = sums_by_key(key, np.ones(key.size))
    first, second = np.divmod(pairs, n)
    joinable = shared > 0
    # a visible boundary between the two faces that keeps them apart
    single = np.bincount(labels, minlength=n) == 1
    conflict = (edges - shared >= CONTOUR_EDGES) | ((edges > shared) & (single.take(first) | single.take(second)))
    # longest shared boundary first; ties by the pair's key (deterministic)
    order = np.lexsort((pairs, -shared))
    order = order.compress(joinable.take(order))
    # union-find over the faces of the pairs only (numbered densely)
    faces = unique(np.concatenate((first, second)))
    join_a, join_b, apart_a, apart_b = (faces.searchsorted(f).tolist() for f in (
        first.take(order), second.take(order), first.compress(conflict), second.compress(conflict)))
    group = _grow(faces.size, join_a, join_b, apart_a, apart_b)
    label = np.full(n, -1, np.int64)
    label[faces] = group
    return label


def _grow(n: int, join_a: list[int], join_b: list[int], apart_a: list[int], apart_b: list[int]) -> np.ndarray:
    """Union-find over ``n`` faces: join the pairs in order unless their groups hold a pair
    that must stay apart. Returns the group labels (faces alone get -1)."""
    parent = list(range(n))
    apart: dict[int, set[int]] = {}
    for x, y in zip(apart_a, apart_b):
        apart.setdefault(x, set()).add(y)
        apart.setdefault(y, set()).add(x)

    def root(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for x, y in zip(join_a, join_b):
        rx, ry = root(x), root(y)
        if rx == ry:
            continue
        kept_x, kept_y = apart.get(rx, set()), apart.get(ry, set())
        small, large = (kept_x, ry) if len(kept_x) <= len(kept_y) else (kept_y, rx)
        if any(root(z) == large for z in small):
            continue
        parent[ry] = rx
        if kept_y:
            apart[rx] = kept_x | kept_y
            apart.pop(ry, None)
    roots = np.array([root(x) for x in range(n)], np.int64)
    size = np.bincount(roots, minlength=n)
    grouped = size.take(roots) > 1
    label = np.full(n, -1, np.int64)
    leaders = np.zeros(n, bool)
    leaders[roots.compress(grouped)] = True
    number = leaders.cumsum() - 1
    label[grouped] = number.take(roots.compress(grouped))
    return label
