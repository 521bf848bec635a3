"""The vector image every drawing stage produces, and its faces.

A :class:`VectorImage` is the reshaped cell graph's topology with final geometry: a display
position per node and, per edge, either a straight segment or a curve written as two
quadratic Béziers. All shapes that use an edge draw exactly this geometry, so abutting
shapes never leave a geometric gap.

Faces are what the SVG draws: maximal groups of cells of identical RGBA that are joined
through shared edges of linked pixels. A region (paper §3.3) is a group of cells joined by
invisible edges; it holds one or more faces (per-cell flat colours approximate the paper's
smooth shading, as the design card says).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .frozen import compact_repr, freeze
from .graph.cells import DIAGONAL, HORIZONTAL, VERTICAL, CellGraph
from .graph.components import component_roots


@dataclass(frozen=True, eq=False)
class CurveTable:
    """The quadratic B-splines behind the curved edges of a :class:`VectorImage`, slot by
    slot (a slot is one place of one curve in the flat curve arrays of
    :class:`depixel.curves.splines.SplineSet`; an open curve has a slot for each end node).

    Span j of a curve (interior slot j) is the quadratic Bézier ``(P0_j, C_j, P2_j)`` with
    ``C_j = ctrl[j]`` and ``P0_j``/``P2_j`` the midpoints of its control legs, or the
    neighbouring control point itself where that neighbour is an open end (clamped); the
    curve passes through the display point of slot j's node at the span's middle.
    Read-only arrays.
    """

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    node: np.ndarray  # (P,) int32 cell-graph node of each slot
    curve: np.ndarray  # (P,) int32 curve of each slot
    closed: np.ndarray  # (C,) bool: the curve is closed (periodic)
    prev: np.ndarray  # (P,) int32 previous slot along the curve, -1 before an open start
    next: np.ndarray  # (P,) int32 next slot along the curve, -1 after an open end
    ctrl: np.ndarray  # (P, 2) float64 control points (T-junction ends snapped)
    edge_slot: np.ndarray  # (E,) int32 slot at the start of each curved edge, in curve direction; -1 if straight
    edge_forward: np.ndarray  # (E,) bool: the edge is stored u → v in the curve's direction

    def __post_init__(self) -> None:
        freeze(self)

    def is_end(self) -> np.ndarray:
        """(P,) bool: the slot is an open curve's end (its control point is on the curve)."""
        return (self.prev < 0) | (self.next < 0)


@dataclass(frozen=True, eq=False)
class VectorImage:
    """Final geometry of a depixelized image (coordinates in input pixels, y down); arrays
    are read-only."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    cells: CellGraph  # topology: nodes, edges, pixels on each side, cell polygons
    points: np.ndarray  # (N, 2) float64 display position of every node, in pixels
    curved: np.ndarray  # (E,) bool: edge drawn as a curve rather than a straight segment
    controls: np.ndarray  # (E, 3, 2) float64: points[u] Q c0 c1 Q c2 points[v], for curved edges
    stage: str  # "cells", "splines" or "optimized"
    curves: CurveTable | None = None  # the B-splines of the curved edges (None: all straight)

    def __post_init__(self) -> None:
        freeze(self)

    @property
    def shape(self) -> tuple[int, int]:
        return self.cells.shape

    @property
    def rgba(self) -> np.ndarray:
        return self.cells.graph.rgba


def straight_image(cells: CellGraph, stage: str = "cells") -> VectorImage:
    """The cell graph as drawn: every edge straight, nodes at their quarter-pixel places."""
    n_edges = len(cells.edges)
    return VectorImage(
        cells=cells,
        points=cells.nodes.astype(np.float64) / 4.0,
        curved=np.zeros(n_edges, dtype=bool),
        controls=np.zeros((n_edges, 3, 2), dtype=np.float64),
        stage=stage,
    )


def linked_edges(cells: CellGraph) -> np.ndarray:
    """(E,) bool: the edge lies between two pixels linked in the resolved similarity graph.

    Diagonal edges exist only between linked pixels; a pixel edge is linked exactly when the
    two 4-neighbours are similar. These are the invisible edges of paper §3.3.
    """
    g = cells.graph
    h, w = g.shape
    # per edge kind and pixel, the link to the pixel below (HORIZONTAL: a horizontal pixel
    # edge has its pixels above and below it), to the right (VERTICAL) or across (DIAGONAL):
    # the smaller pixel of an edge picks its link from its kind's row
    link = np.zeros((3, h, w), dtype=bool)
    link[HORIZONTAL, :-1, :] = g.down
    link[VERTICAL, :, :-1] = g.right
    link[DIAGONAL] = True
    first = np.minimum(cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]).astype(np.intp)  # -1: outside
    inside = first >= 0
    np.maximum(first, 0, out=first)
    first += cells.edge_kind.astype(np.intp) * (h * w)
    return link.ravel().take(first) & inside


def regions(cells: CellGraph) -> np.ndarray:
    """(H*W,) region label per pixel: components of cells joined by invisible edges."""
    region = faces_and_regions(cells)[1]
    assert region is not None
    return region


def faces(cells: CellGraph, per_cell: bool = False) -> np.ndarray:
    """(H*W,) face label per pixel: linked cells of identical RGBA (or one face per cell)."""
    return faces_and_regions(cells, per_cell, with_regions=False)[0]


def faces_and_regions(cells: CellGraph, per_cell: bool = False,
                      with_regions: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`faces` and :func:`regions` together, finding the linked edges once. Both are
    numbered in order of their first pixel (FaceTopology reads each face's first pixel off it)."""
    n = cells.shape[0] * cells.shape[1]
    linked = linked_edges(cells)
    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    if per_cell:
        face_root = np.arange(n, dtype=np.int64)
        across = linked
    else:
        key = _colour_key(cells.graph.rgba).ravel()
        same = linked & (key.take(np.maximum(left, 0)) == key.take(np.maximum(right, 0)))
        face_root = component_roots(n, left.compress(same), right.compress(same))
        across = linked & ~same
    face = _labels(face_root)
    if not with_regions:
        return face, None
    # the regions join faces: their components over the face roots (each face's smallest
    # pixel) by the linked edges between faces, so the smallest root of a region is its
    # smallest pixel — the same roots as the components of all linked edges, in fewer rounds
    root_of_root = component_roots(n, face_root.take(left.compress(across)), face_root.take(right.compress(across)))
    return face, _labels(root_of_root.take(face_root))


def _labels(root: np.ndarray) -> np.ndarray:
    """(n,) the components of :func:`component_roots`' ``root``, numbered in order of their
    smallest item."""
    label = (root == np.arange(root.size)).cumsum()
    label -= 1
    return label.take(root)


def _colour_key(rgba: np.ndarray) -> np.ndarray:
    q = rgba.astype(np.int64)
    return (q[..., 0] << 24) | (q[..., 1] << 16) | (q[..., 2] << 8) | q[..., 3]
