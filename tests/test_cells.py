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


#: the offsets (rows, columns) of a pixel's 3 × 3 neighbourhood, which holds its cell
BLOCK = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
#: random sample points per pixel square
SAMPLES = 6


def inside_own_cells(cg, points: np.ndarray) -> np.ndarray:
    """Even-odd test of each cell's polygon against its own points: ``points`` (C, M, 2)
    (quarter pixels; NaN: no point) → (C, M) bool, point m inside the polygon of cell c."""
    nodes = cg.nodes[cg.cell_nodes].astype(float)
    owner = np.repeat(np.arange(cg.cell_ptr.size - 1), np.diff(cg.cell_ptr))
    nxt = np.arange(nodes.shape[0]) + 1
    nxt[cg.cell_ptr[1:] - 1] = cg.cell_ptr[:-1]
    (x0, y0), (x1, y1) = nodes.T[:, :, None], nodes[nxt].T[:, :, None]  # each edge (E, 1)
    x, y = points[owner, :, 0], points[owner, :, 1]  # the points of each edge's cell (E, M)
    with np.errstate(divide="ignore", invalid="ignore"):
        crosses = ((y0 > y) != (y1 > y)) & (x < x0 + (y - y0) * (x1 - x0) / (y1 - y0))
    counts = np.zeros(points.shape[:2], int)
    np.add.at(counts, owner, crosses)
    return counts % 2 == 1


def check_invariants(rgba: np.ndarray) -> None:
    cg = cells_of(rgba)
    h, w = rgba.shape[:2]
    assert np.issubdtype(cg.nodes.dtype, np.integer)  # quarter-pixel units, exactly
    areas = cg.cell_areas()
    assert areas.min() > 0
    assert abs(areas.sum() - w * h) < 1e-9

    # every cell lies in its pixel's 3 × 3 neighbourhood, so only the points there can be in
    # it: each cell contains its own pixel centre and no other, and random points off the
    # lattice lines are covered exactly once (no overlap, no gap)
    row, col = np.divmod(np.arange(h * w), w)
    owner = np.repeat(np.arange(h * w), np.diff(cg.cell_ptr))
    corner = np.stack([col, row], axis=1)[owner] * 4
    assert ((cg.nodes[cg.cell_nodes] >= corner - 4) & (cg.nodes[cg.cell_nodes] <= corner + 8)).all(), \
        "a cell reaches out of its pixel's neighbourhood"
    rng = np.random.default_rng(0)
    pixel_xy = np.stack(np.meshgrid(np.arange(w), np.arange(h)), -1)[:, :, None]  # (h, w, 1, 2)
    samples = (pixel_xy + rng.uniform(0, 1, size=(h, w, SAMPLES, 2))) * 4  # in each pixel's square
    points = np.full((h * w, len(BLOCK), SAMPLES + 1, 2), np.nan)  # each neighbour's samples, then its centre
    sample_id = np.full((h * w, len(BLOCK), SAMPLES), -1)
    for j, (dy, dx) in enumerate(BLOCK):
        r, c = row + dy, col + dx
        there = (r >= 0) & (r < h) & (c >= 0) & (c < w)
        q = r[there] * w + c[there]
        points[there, j, :SAMPLES] = samples.reshape(h * w, SAMPLES, 2)[q]
        points[there, j, SAMPLES] = np.stack([c[there], r[there]], axis=1) * 4 + 2
        sample_id[there, j] = q[:, None] * SAMPLES + np.arange(SAMPLES)
    inside = inside_own_cells(cg, points.reshape(h * w, -1, 2)).reshape(h * w, len(BLOCK), SAMPLES + 1)
    centre = inside[:, :, SAMPLES]
    own = BLOCK.index((0, 0))
    assert centre[:, own].all(), "a cell misses its own pixel centre"
    assert centre.sum(axis=1).max() == 1, "a cell holds another pixel's centre"
    listed = sample_id >= 0
    cover = np.bincount(sample_id[listed], weights=inside[:, :, :SAMPLES][listed], minlength=h * w * SAMPLES)
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
