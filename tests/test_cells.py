"""Stage 3: invariants of the reshaped cell graph, on fixtures, the corpus and random images."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import art, corpus_pngs, fixture_pngs
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from depixel.graph.cells import build_cell_graph
from depixel.graph.crossings import resolve_crossings
from depixel.graph.similarity import build_similarity_graph
from depixel.prepare.image import load_image
from depixel.svg.loops import trace_loops


def cells_of(rgba):
    return build_cell_graph(resolve_crossings(build_similarity_graph(rgba)))


def point_in_polygon(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd test of (P, 2) points against one polygon (k, 2)."""
    x, y = points[:, 0:1], points[:, 1:2]
    x0, y0 = poly[:, 0][None], poly[:, 1][None]
    x1, y1 = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    crosses = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return (crosses & (x < xi)).sum(axis=1) % 2 == 1


def check_invariants(rgba: np.ndarray) -> None:
    cg = cells_of(rgba)
    h, w = rgba.shape[:2]
    assert np.issubdtype(cg.nodes.dtype, np.integer)  # quarter-pixel units, exactly
    areas = cg.cell_areas()
    assert areas.min() > 0
    assert abs(areas.sum() - w * h) < 1e-9

    # every cell contains its own pixel centre and no other cell does; sample points off
    # the lattice lines are covered exactly once (no overlap, no gap)
    rng = np.random.default_rng(0)
    samples = rng.uniform(0, 1, size=(h * w * 6, 2)) * [w * 4, h * 4]
    centres = np.stack(np.meshgrid(np.arange(w) * 4 + 2, np.arange(h) * 4 + 2), -1).reshape(-1, 2)
    cover = np.zeros(len(samples), int)
    for p in range(h * w):
        poly = cg.cell_polygon(p).astype(float)
        cover += point_in_polygon(samples, poly)
        inside = point_in_polygon(centres.astype(float), poly)
        assert inside[p] and inside.sum() == 1, f"cell {p} and pixel centres"
    assert (cover == 1).all()

    # edges: positive length; shared by a pair of pixels exactly when 4-neighbours or linked
    g = cg.graph
    seg = cg.nodes[cg.edges[:, 1]] - cg.nodes[cg.edges[:, 0]]
    assert (np.abs(seg).sum(axis=1) > 0).all()
    left, right = cg.edge_pixels[:, 0], cg.edge_pixels[:, 1]
    both = (left >= 0) & (right >= 0)
    pairs = {tuple(sorted(p)) for p in cg.edge_pixels[both].tolist()}
    assert len(pairs) == both.sum()  # no pair shares two edges
    expected = set()
    idx = np.arange(h * w).reshape(h, w)
    for a, b in zip(idx[:, :-1].ravel(), idx[:, 1:].ravel()):
        expected.add((a, b))
    for a, b in zip(idx[:-1, :].ravel(), idx[1:, :].ravel()):
        expected.add((a, b))
    for a, b in zip(idx[:-1, :-1][g.diag_main], idx[1:, 1:][g.diag_main]):
        expected.add((a, b))
    for a, b in zip(idx[:-1, 1:][g.diag_anti], idx[1:, :-1][g.diag_anti]):
        expected.add((min(a, b), max(a, b)))
    assert pairs == {tuple(map(int, p)) for p in expected}


@pytest.mark.parametrize("path", fixture_pngs(), ids=lambda p: p.name)
def test_invariants_on_fixtures(path):
    check_invariants(load_image(path))


@pytest.mark.parametrize("path", corpus_pngs()[:12], ids=lambda p: p.name)
def test_invariants_on_corpus(path):
    check_invariants(load_image(path))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(arrays(np.uint8, st.tuples(st.integers(1, 7), st.integers(1, 7)), elements=st.integers(0, 3)))
def test_invariants_on_random_images(indices):
    palette = np.array([[0, 0, 0, 255], [40, 40, 40, 255], [255, 255, 255, 255], [0, 0, 0, 0]], np.uint8)
    check_invariants(palette[indices])


def test_diagonal_line_cells_share_edges():
    cg = cells_of(art("#..\n.#.\n..#"))
    left, right = cg.edge_pixels[:, 0], cg.edge_pixels[:, 1]
    shared = {tuple(sorted(p)) for p in zip(left.tolist(), right.tolist())}
    assert (0, 4) in shared and (4, 8) in shared  # the black pixels connect through edges
    # the diagonal edge is √2/2 pixel long: from P+(-1,1) to P+(1,-1) in quarter units
    diag = cg.edges[cg.edge_kind == 2]
    d = cg.nodes[diag[:, 1]] - cg.nodes[diag[:, 0]]
    assert (np.abs(d) == 2).all()


def test_single_pixel_cell_is_a_centred_half_square():
    cg = cells_of(art("...\n.#.\n..."))
    poly = cg.cell_polygon(4)
    assert sorted(map(tuple, poly.tolist())) == [(5, 5), (5, 7), (7, 5), (7, 7)]
    assert cg.cell_areas()[4] == 0.25


def _traced_polygons(cg):
    """The cell polygons as :func:`trace_loops` traces them from the half-edges with a
    pixel on their right (u → v), then those with one on their left (v → u)."""
    left, right = cg.edge_pixels[:, 0], cg.edge_pixels[:, 1]
    on_right, on_left = right >= 0, left >= 0
    owner = np.concatenate([right[on_right], left[on_left]])
    u = np.concatenate([cg.edges[on_right, 0], cg.edges[on_left, 1]])
    v = np.concatenate([cg.edges[on_right, 1], cg.edges[on_left, 0]])
    edge_of = np.concatenate([np.flatnonzero(on_right), np.flatnonzero(on_left)])
    loops = trace_loops(owner, u, v)
    assert np.array_equal(loops.owner, np.arange(cg.shape[0] * cg.shape[1]))  # one loop per cell
    return loops.ptr, u[loops.halfedges], edge_of[loops.halfedges]


@settings(max_examples=60, deadline=None, derandomize=True)
@given(arrays(np.uint8, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.integers(0, 3)))
def test_cell_polygons_are_the_traced_loops(indices):
    """The polygons read off the templates are exactly the loops tracing finds, each from the
    same first half-edge (so the cell stage's output did not change when it stopped tracing)."""
    palette = np.array([[0, 0, 0, 255], [40, 40, 40, 255], [255, 255, 255, 255], [0, 0, 0, 0]], np.uint8)
    cg = cells_of(palette[indices])
    ptr, nodes, edges = _traced_polygons(cg)
    assert np.array_equal(cg.cell_ptr, ptr)
    assert np.array_equal(cg.cell_nodes, nodes)
    assert np.array_equal(cg.cell_edges, edges)


def test_link_corners_are_the_nodes_a_quarter_pixel_off_a_lattice_point_in_x_and_y():
    from depixel.graph.cells import link_corners

    q = np.stack(np.meshgrid(np.arange(-9, 10), np.arange(-9, 10)), axis=-1).reshape(-1, 2).astype(np.int32)
    split, lattice = link_corners(q)
    assert np.array_equal(lattice, 4 * np.round(q / 4.0))
    for (x, y), s in zip(q.tolist(), split.tolist()):
        assert s == (x % 4 in (1, 3) and y % 4 in (1, 3)), (x, y)
    assert split.any() and not split.all()
    split2, _ = link_corners(q.reshape(19, 19, 2))  # any leading shape
    assert np.array_equal(split2.ravel(), split)
