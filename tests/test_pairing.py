"""Which cell edges carry curves (paper §3.3), against a plain per-edge reading of the
similarity graph: linked, visible, shading and colour-band edges on random small images."""
from __future__ import annotations

import numpy as np

from depixel.cells import DIAGONAL, build_cell_graph
from depixel.crossings import resolve_crossings
from depixel.image import rgb_to_yuv
from depixel.pairing import band_edges, shading_edges, visible_edges
from depixel.params import Params
from depixel.similarity import build_similarity_graph
from depixel.vector import linked_edges


def _random_cells(rng: np.random.Generator, params: Params):
    h, w = (int(x) for x in rng.integers(1, 9, 2))
    palette = rng.integers(0, 256, (int(rng.integers(1, 5)), 4), dtype=np.uint8)
    palette[:, 3] = 255
    palette[0, 3] = rng.choice([0, 255])
    palette[-1] = palette[0] + rng.integers(0, 20, 4, dtype=np.uint8)  # a similar colour now and then
    rgba = palette[rng.integers(0, len(palette), (h, w))]
    return build_cell_graph(resolve_crossings(build_similarity_graph(rgba, params), params))


def _reference_linked(cells) -> np.ndarray:
    """Edge by edge: a diagonal edge joins linked pixels; a pixel edge is linked when its
    two pixels are 4-neighbours linked in the resolved graph."""
    g = cells.graph
    w = g.shape[1]
    linked = np.zeros(len(cells.edges), bool)
    for e, (p, q) in enumerate(cells.edge_pixels.tolist()):
        if p < 0 or q < 0:
            continue
        if cells.edge_kind[e] == DIAGONAL:
            linked[e] = True
            continue
        (ra, ca), (rb, cb) = sorted([divmod(p, w), divmod(q, w)])
        linked[e] = g.right[ra, ca] if ra == rb else g.down[ra, ca]
    return linked


def test_curve_edges_match_a_per_edge_reading():
    params = Params()
    rng = np.random.default_rng(12)
    for _ in range(150):
        cells = _random_cells(rng, params)
        linked = _reference_linked(cells)
        assert np.array_equal(linked_edges(cells), linked)
        left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
        inside = (left >= 0) & (right >= 0)
        visible = inside & ~linked
        assert np.array_equal(visible_edges(cells), visible)
        assert np.array_equal(visible_edges(cells, linked), visible)
        rgba = cells.graph.rgba.reshape(-1, 4)
        a, b = rgba[np.maximum(left, 0)], rgba[np.maximum(right, 0)]
        band = inside & linked & (a != b).any(axis=1)
        assert np.array_equal(band_edges(cells), band)
        assert np.array_equal(band_edges(cells, linked), band)
        yuv = rgb_to_yuv(rgba)
        near = np.linalg.norm(yuv[np.maximum(left, 0)] - yuv[np.maximum(right, 0)], axis=1) <= params.shading_distance
        same_clarity = (a[:, 3] == 0) == (b[:, 3] == 0)
        assert np.array_equal(shading_edges(cells, visible, params), visible & near & same_clarity)
