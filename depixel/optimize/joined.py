"""The cell graphs of a pass's images as one (issue 44): what the steps after the relaxation read.

:func:`depixel.optimize.pack.optimize_many` relaxes the curves of several images joined; the
harmonic map and the walk-back (:func:`depixel.optimize.stage.finish`) then read the cells
too: their nodes, edges, the pixels beside each edge and each pixel's polygon. A
:class:`JoinedCells` holds those of several images one after another (nodes, edges and
pixels renumbered, each image in its own coordinates, never moved to an offset), with what
a single :class:`~depixel.graph.cells.CellGraph` computes from its shape: each pixel's centre
and which nodes lie on the image border. Every step that reads it works node by node, edge
by edge or pixel by pixel, so each image gets the numbers it gets alone.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..frozen import compact_repr
from ..graph.cells import INDEX, CellGraph


@dataclass(frozen=True, eq=False)
class JoinedCells:
    """The fields of several :class:`~depixel.graph.cells.CellGraph` that the steps after the
    relaxation read, joined (see the module), and the bounds of each image's nodes, edges and
    pixels in them, (S+1,) each."""

    __repr__ = compact_repr

    nodes: np.ndarray  # (N, 2) int32 quarter pixels, each image's own
    edges: np.ndarray  # (E, 2) node indices, renumbered
    edge_pixels: np.ndarray  # (E, 2) pixel indices, renumbered (-1 outside)
    cell_ptr: np.ndarray  # (H*W + 1,) every image's pixels one after another
    cell_edges: np.ndarray  # renumbered
    centre_x: np.ndarray  # (H*W,) float64 each pixel's centre, in its image's coordinates
    centre_y: np.ndarray
    border: np.ndarray  # (N,) bool: the node lies on its image's border
    node_bounds: np.ndarray
    edge_bounds: np.ndarray
    pixel_bounds: np.ndarray

    @property
    def n_pixels(self) -> int:
        return int(self.pixel_bounds[-1])


def join_cells(cells: Sequence[CellGraph]) -> JoinedCells:
    """The cell graphs ``cells`` as one :class:`JoinedCells`."""
    nodes = np.cumsum([0] + [len(c.nodes) for c in cells])
    edges = np.cumsum([0] + [len(c.edges) for c in cells])
    pixels = np.cumsum([0] + [c.cell_ptr.size - 1 for c in cells])
    links = np.cumsum([0] + [c.cell_edges.size for c in cells])
    centres = [pixel_centres(c, np.arange(c.cell_ptr.size - 1)) for c in cells]
    return JoinedCells(
        nodes=np.concatenate([c.nodes for c in cells]),
        edges=np.concatenate([c.edges + nodes[i] for i, c in enumerate(cells)]).astype(INDEX),
        edge_pixels=np.concatenate([np.where(c.edge_pixels >= 0, c.edge_pixels + pixels[i], -1)
                                    for i, c in enumerate(cells)]).astype(INDEX),
        cell_ptr=np.concatenate([c.cell_ptr[:-1] + links[i] for i, c in enumerate(cells)] + [links[-1:]]),
        cell_edges=np.concatenate([c.cell_edges + edges[i] for i, c in enumerate(cells)]).astype(INDEX),
        centre_x=np.concatenate([x for x, _ in centres]),
        centre_y=np.concatenate([y for _, y in centres]),
        border=np.concatenate([border_nodes(c) for c in cells]),
        node_bounds=nodes, edge_bounds=edges, pixel_bounds=pixels)


def pixel_count(cells: CellGraph | JoinedCells) -> int:
    """The pixels of ``cells`` (of all its images when joined)."""
    if isinstance(cells, JoinedCells):
        return cells.n_pixels
    return cells.shape[0] * cells.shape[1]


def largest_image(cells: CellGraph | JoinedCells) -> int:
    """The pixels of the largest image of ``cells``."""
    if isinstance(cells, JoinedCells):
        return int(np.diff(cells.pixel_bounds).max())
    return cells.shape[0] * cells.shape[1]


def pixel_centres(cells: CellGraph | JoinedCells, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the centres of the pixels ``px`` (flat indices), in their image's coordinates."""
    if isinstance(cells, JoinedCells):
        return cells.centre_x.take(px), cells.centre_y.take(px)
    rows, cols = np.divmod(px, cells.shape[1])
    return cols + 0.5, rows + 0.5


def border_nodes(cells: CellGraph | JoinedCells) -> np.ndarray:
    """(N,) bool: the nodes on their image's border."""
    if isinstance(cells, JoinedCells):
        return cells.border
    q = cells.nodes
    h, w = cells.shape
    return (q[:, 0] == 0) | (q[:, 1] == 0) | (q[:, 0] == 4 * w) | (q[:, 1] == 4 * h)
