"""Stage 3 — paper §3.2 (end) — planar similarity graph → reshaped cell graph.

The simplified generalized Voronoi diagram of the resolved similarity graph, built directly
from local templates (docs/cells.md has the drawings). Coordinates are integers in
quarter-pixel units, ``(x, y)`` with y down: pixel ``(r, c)`` is the square
``[4c, 4c+4] × [4r, 4r+4]`` and its centre is ``(4c+2, 4r+2)``.

Every lattice point P (a corner shared by up to four pixels) has at most one diagonal link
after crossing resolution, so its template is one of three:

* no diagonal: one node at P, where the pixel edges meet;
* "\\" link (top-left — bottom-right): two nodes, A = P + (-1, +1) towards the bottom-left
  pixel and B = P + (+1, -1) towards the top-right one; A—B is the edge the two linked
  pixels now share, and the unlinked pixels lose their corner to it;
* "/" link (top-right — bottom-left): C = P + (-1, -1) and D = P + (+1, +1) likewise.

Each pixel edge of the square lattice becomes one straight cell edge between the template
nodes at its two ends (the exact Voronoi diagram's valence-2 nodes are collapsed by
construction); the links' shared edges are added. No other valence-2 node arises except at
the four image corners, which stay as the image's corners. Every edge knows the pixel on
its left and on its right as seen on screen when walking from ``u`` to ``v`` (-1 outside).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import both
from ..frozen import compact_repr, freeze
from .crossings import CrossingResolution
from .similarity import SimilarityGraph

# edge kinds
HORIZONTAL, VERTICAL, DIAGONAL = 0, 1, 2

#: the integer type of the cell graph's and the curves' index arrays: the image limits keep
#: every count far below 2**31, and these arrays live until the SVG is written
INDEX = np.int32


def link_corners(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For nodes ``q`` (..., 2) in quarter pixels: whether each is a diagonal link's node (a
    quarter pixel off a lattice point in both x and y: the point the link splits), and the
    nearest lattice point (quarter pixels, float)."""
    lattice = 4 * (q / 4.0).round()
    return both(np.abs(q - lattice) == 1), lattice


@dataclass(frozen=True, eq=False)
class CellGraph:
    """Reshaped pixel cells: nodes, edges with the pixel on each side, and cell polygons;
    arrays are read-only."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    graph: SimilarityGraph  # the resolved (planar) similarity graph it was built from
    nodes: np.ndarray  # (N, 2) int32, (x, y) in quarter pixels
    edges: np.ndarray  # (E, 2) int32 node indices (u, v)
    edge_pixels: np.ndarray  # (E, 2) int32 flat pixel index on the (left, right) of u→v; -1 outside
    edge_kind: np.ndarray  # (E,) uint8: HORIZONTAL, VERTICAL or DIAGONAL
    cell_ptr: np.ndarray  # (H*W + 1,) int32: cell p is cell_nodes[cell_ptr[p]:cell_ptr[p+1]]
    cell_nodes: np.ndarray  # int32 node indices of every cell polygon, clockwise on screen
    cell_edges: np.ndarray  # int32 matching edge indices: cell_edges[k] joins cell_nodes[k] to the next node

    def __post_init__(self) -> None:
        freeze(self)

    @property
    def shape(self) -> tuple[int, int]:
        return self.graph.shape

    def cell_polygon(self, pixel: int) -> np.ndarray:
        """``(k, 2)`` node coordinates (quarter pixels) of one cell, clockwise on screen."""
        return self.nodes[self.cell_nodes[self.cell_ptr[pixel] : self.cell_ptr[pixel + 1]]]

    def cell_areas(self) -> np.ndarray:
        """Area of every cell in square pixels (shoelace on quarter units / 16)."""
        pts = self.nodes[self.cell_nodes].astype(np.float64)
        owner = np.repeat(np.arange(self.cell_ptr.size - 1), np.diff(self.cell_ptr))
        nxt = np.arange(pts.shape[0]) + 1
        ends = self.cell_ptr[1:] - 1
        nxt[ends] = self.cell_ptr[:-1]
        cross = pts[:, 0] * pts[nxt, 1] - pts[nxt, 0] * pts[:, 1]
        return np.bincount(owner, weights=cross, minlength=self.cell_ptr.size - 1) / 32.0


def build_cell_graph(resolved: CrossingResolution | SimilarityGraph) -> CellGraph:
    """Build the reshaped cell graph of a planar similarity graph."""
    graph = resolved.graph if isinstance(resolved, CrossingResolution) else resolved
    if np.logical_or.reduce(graph.diag_main & graph.diag_anti, axis=None):
        raise ValueError("similarity graph still has crossing diagonals; resolve them first")
    h, w = graph.shape
    split_main = np.zeros((h + 1, w + 1), dtype=bool)
    split_anti = np.zeros((h + 1, w + 1), dtype=bool)
    split_main[1:-1, 1:-1] = graph.diag_main
    split_anti[1:-1, 1:-1] = graph.diag_anti
    nodes = _template_nodes(split_main, split_anti)
    edges, edge_pixels, edge_kind = _pixel_edges(split_main, split_anti)
    cell_ptr, cell_nodes, cell_edges = _cell_polygons(split_main, split_anti, edges)
    del split_main, split_anti
    return CellGraph(graph, nodes, edges, edge_pixels, edge_kind, cell_ptr, cell_nodes, cell_edges)


def _template_nodes(split_main: np.ndarray, split_anti: np.ndarray) -> np.ndarray:
    """(N, 2) node positions: slot 0 at every lattice point, then slot 1 of every lattice
    point a link splits (``split_*`` (H+1, W+1) bool), in scanline order. Slot 0 is moved
    by (-1, +1) at a "\\" link (A) and by (-1, -1) at a "/" link (C); slot 1 lies at
    (+1, -1) (B) or (+1, +1) (D). Written a coordinate at a time."""
    split = split_main | split_anti
    rows, cols = split.shape
    x = np.arange(0, 4 * cols, 4, dtype=INDEX)
    y = np.arange(0, 4 * rows, 4, dtype=INDEX)[:, None]
    at = split.ravel().nonzero()[0]
    nodes = np.empty((rows * cols + at.size, 2), dtype=INDEX)
    lattice = nodes[: rows * cols]
    lattice[:, 0] = (x - split).ravel()
    lattice[:, 1] = (y + (split_main.view(np.int8) - split_anti.view(np.int8))).ravel()
    second = nodes[rows * cols :]
    second[:, 0] = x.take(at % cols) + 1
    second[:, 1] = y.ravel().take(at // cols) + np.where(split_main.ravel().take(at), -1, 1)
    return nodes


def _pixel_edges(split_main: np.ndarray, split_anti: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edges ``(E, 2)`` (u, v), the pixels on their (left, right) ``(E, 2)`` and their kinds
    ``(E,)``: the horizontal pixel edges, the vertical ones, then the links' edges."""
    h, w = split_main.shape[0] - 1, split_main.shape[1] - 1
    n_lattice = (h + 1) * (w + 1)
    lattice = np.arange(n_lattice, dtype=INDEX).reshape(h + 1, w + 1)
    split = split_main | split_anti
    second = np.full((h + 1, w + 1), -1, dtype=INDEX)
    second[split] = n_lattice + np.arange(int(split.sum()))

    # which template node each pixel edge ends at, per direction leaving the lattice point
    up_end = np.where(split_main, second, lattice)  # between TL and TR: B for "\\", C for "/"
    right_end = np.where(split, second, lattice)  # between TR and BR: B or D
    down_end = np.where(split_anti, second, lattice)  # between BL and BR: A for "\\", D for "/"
    left_end = lattice  # between TL and BL: A or C, always slot 0

    pixel = np.full((h + 2, w + 2), -1, dtype=INDEX)
    pixel[1:-1, 1:-1] = np.arange(h * w, dtype=INDEX).reshape(h, w)

    # written a column at a time into the (E, 2) arrays: the horizontal edges, the vertical
    # ones, then the links'
    at = split.ravel().nonzero()[0]
    n_h, n_v = (h + 1) * w, h * (w + 1)
    edges = np.empty((n_h + n_v + at.size, 2), dtype=INDEX)
    edge_pixels = np.empty_like(edges)
    h_e, v_e, d_e = edges[:n_h], edges[n_h : n_h + n_v], edges[n_h + n_v :]
    h_p, v_p, d_p = edge_pixels[:n_h], edge_pixels[n_h : n_h + n_v], edge_pixels[n_h + n_v :]
    # horizontal edges (i, j) → (i, j+1): pixel above on the left, pixel below on the right
    h_e[:, 0], h_e[:, 1] = right_end[:, :-1].ravel(), left_end[:, 1:].ravel()
    h_p[:, 0], h_p[:, 1] = pixel[:-1, 1:-1].ravel(), pixel[1:, 1:-1].ravel()
    # vertical edges (i, j) → (i+1, j): pixel to the east on the left, west on the right
    v_e[:, 0], v_e[:, 1] = down_end[:-1, :].ravel(), up_end[1:, :].ravel()
    v_p[:, 0], v_p[:, 1] = pixel[1:-1, 1:].ravel(), pixel[1:-1, :-1].ravel()
    # link edges: "\\" A → B with top-left on the left; "/" C → D with top-right on the left
    d_e[:, 0], d_e[:, 1] = at, second.ravel().take(at)  # a lattice point's slot 0 is its scanline index
    top_left = at + at // (w + 1)  # pixel[i, j] in the padded (h + 2, w + 2) pixel array, flat
    is_main = split_main.ravel().take(at)
    pixel = pixel.ravel()
    d_p[:, 0] = np.where(is_main, pixel.take(top_left), pixel.take(top_left + 1))
    d_p[:, 1] = np.where(is_main, pixel.take(top_left + w + 3), pixel.take(top_left + w + 2))
    edge_kind = np.full(len(edges), DIAGONAL, np.uint8)
    edge_kind[:n_h] = HORIZONTAL
    edge_kind[n_h : n_h + n_v] = VERTICAL
    return edges, edge_pixels, edge_kind


def _cell_polygons(split_main: np.ndarray, split_anti: np.ndarray,
                   edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each cell's boundary with the cell on the right (clockwise on screen): ``cell_ptr``,
    ``cell_nodes`` and ``cell_edges`` (see :class:`CellGraph`).

    Read off the templates instead of traced: going clockwise round pixel (r, c) from its
    top edge, its boundary is that edge, the "/" link's edge at its top-right corner (it is
    that link's bottom-left pixel), its right edge, the "\\" link's edge at its
    bottom-right corner, its bottom edge, the "/" edge at its bottom-left corner, its left
    edge and the "\\" edge at its top-left corner, each where it exists. These are the
    loops :func:`depixel.svg.loops.trace_loops` finds, each from the same half-edge: its first
    among the edges with a pixel on their right (run u → v), then those with one on their
    left (v → u), in edge order, is always the top edge (the horizontal edges come first)."""
    h, w = split_main.shape[0] - 1, split_main.shape[1] - 1
    n_horizontal, n_vertical = (h + 1) * w, h * (w + 1)
    split = split_main | split_anti
    diagonal = np.zeros((h + 1, w + 1), dtype=INDEX)  # the link's edge at each split lattice point
    diagonal[split] = n_horizontal + n_vertical + np.arange(int(split.sum()), dtype=INDEX)
    pixel = np.arange(h * w, dtype=INDEX).reshape(h, w)
    west = n_horizontal + pixel + np.arange(h, dtype=INDEX)[:, None]  # vertical edge (r, c): r (w + 1) + c
    # per slot: the edge, whether the pixel is on its right (then it runs u → v), where it
    # exists (None: always)
    slots = ((pixel, True, None), (diagonal[:-1, 1:], True, split_anti[:-1, 1:]), (west + 1, True, None),
             (diagonal[1:, 1:], False, split_main[1:, 1:]), (pixel + w, False, None),
             (diagonal[1:, :-1], False, split_anti[1:, :-1]), (west, False, None),
             (diagonal[:-1, :-1], True, split_main[:-1, :-1]))
    edge = np.empty((h * w, len(slots)), dtype=INDEX)
    present = np.ones((h * w, len(slots)), dtype=bool)
    for k, (slot_edge, _, there) in enumerate(slots):
        edge[:, k] = slot_edge.ravel()
        if there is not None:
            present[:, k] = there.ravel()
    present = present.ravel()
    backward = np.array([not right for _, right, _ in slots])
    cell_edges = edge.ravel().compress(present)
    # where each half-edge starts: u where the pixel is on the edge's right, else v, read
    # from the flattened (E, 2) edges at 2e or 2e + 1 (one gather of the present slots, no
    # strided column gathers of every slot)
    end = edge.astype(np.int64)
    end *= 2
    end += backward
    start = edges.ravel().take(end.ravel().compress(present))
    del end
    cell_ptr = np.zeros(h * w + 1, dtype=INDEX)
    # a pixel's eight presence flags (bytes 0 or 1) are one 8-byte word: their sum is the
    # word's top byte after a multiplication by 0x0101010101010101 (no carries: a sum ≤ 8)
    flags = present.reshape(h * w, len(slots)).view(np.uint64).ravel()
    np.cumsum(flags * np.uint64(0x0101010101010101) >> np.uint64(56), dtype=INDEX, out=cell_ptr[1:])
    return cell_ptr, start, cell_edges
