"""Which cell edges carry curves (paper §3.3), against a plain per-edge reading of the
similarity graph: linked, visible, shading and colour-band edges on random small images."""
from __future__ import annotations

import numpy as np

from depixel.colour import rgb_to_yuv
from depixel.curves.pairing import Chains, band_edges, chain_curves, cut_chains, shading_edges, visible_edges
from depixel.curves.splines import extract_splines
from depixel.graph.cells import DIAGONAL, build_cell_graph
from depixel.graph.crossings import resolve_crossings
from depixel.graph.similarity import build_similarity_graph
from depixel.params import Params
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


def test_cut_chains_are_the_walk_of_the_cut_pairing():
    """Cutting the chains at break nodes gives exactly the chains walked from the pairing
    with the pairs at those nodes undone: the same curves, slots, order, directions and
    dtypes (open pieces of open and closed curves, a closed curve cut once, none cut, all)."""
    rng = np.random.default_rng(12)
    params = Params()
    cut_closed = 0
    for _ in range(300):
        splines = extract_splines(_random_cells(rng, params), params)
        half_ends = splines.half_ends
        chains = Chains(splines.curve_ptr, splines.curve_nodes, splines.curve_closed, splines.slot_edges,
                        splines.slot_forward)
        n = len(splines.positions)
        for breaks in (rng.random(n) < 0.15, rng.random(n) < 0.6, np.zeros(n, bool), np.ones(n, bool)):
            partner = half_ends.partner.copy()
            partner[breaks[half_ends.node]] = -1
            want = chain_curves(half_ends._replace(partner=partner))
            got = cut_chains(chains, half_ends.edges, len(splines.cells.edges), breaks)
            for name, a, b in zip(Chains._fields, want, got):
                assert a.dtype == b.dtype and np.array_equal(a, b), name
            cut_closed += int(splines.curve_closed.sum() - want.curve_closed.sum())
    assert cut_closed > 50  # closed curves were cut, not only open ones
