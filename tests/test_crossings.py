"""Stage 2: crossing resolution and its three heuristics on hand-made patterns."""
from __future__ import annotations

import numpy as np
from conftest import art
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from depixel.graph.crossings import resolve_crossings
from depixel.graph.similarity import build_similarity_graph
from depixel.params import Params


def resolve(text, **params):
    return resolve_crossings(build_similarity_graph(art(text)), Params(**params))


def test_fully_connected_block_drops_both_diagonals():
    r = resolve("..\n..")
    assert r.flat[0, 0] and not r.graph.diag_main[0, 0] and not r.graph.diag_anti[0, 0]
    assert not r.ambiguous.any()


def test_curve_heuristic_keeps_the_long_curve():
    # a long black diagonal line crosses a short white diagonal at block (2, 2)
    text = """
    #rrrrrr
    r#rrrrr
    rr#.rrr
    rr.#rrr
    rrrr#rr
    rrrrr#r
    """
    r = resolve(text, sparse_weight=0.0, island_weight=0.0)
    assert r.ambiguous[2, 2]
    assert r.curve_vote[2, 2] == 5 - 1  # the black curve has 5 edges, the white link is alone
    assert r.graph.diag_main[2, 2] and not r.graph.diag_anti[2, 2]


def test_sparse_heuristic_keeps_the_dotted_line():
    # a sparse dark diagonal dotted line on a dense checker-free light background:
    # curves tie (both length 1 at this block), sparse votes for the dark pixels
    text = """
    ........
    ........
    ...#....
    ....#...
    ........
    ........
    """
    r = resolve(text, curve_weight=0.0, island_weight=0.0)
    # the block at (2, 3) holds [# .; . #]: dark diagonal vs the light anti-diagonal
    assert r.ambiguous[2, 3]
    assert r.sparse_vote[2, 3] > 0
    assert r.graph.diag_main[2, 3] and not r.graph.diag_anti[2, 3]


def test_island_heuristic_avoids_stranding_a_pixel():
    # the black pixel at (1, 1) touches its only similar neighbour diagonally
    text = """
    rrrr
    r#rr
    rr#r
    rrr#
    """
    r = resolve(text, curve_weight=0.0, sparse_weight=0.0)
    # block (1,1): [# r; r #], r's anti-diagonal has valence > 1 ends, # at (1,1) has valence 1
    assert r.island_vote[1, 1] == 5.0  # the paper's fixed weight, for the black diagonal
    assert r.graph.diag_main[1, 1]


def test_tie_removes_both():
    # an isolated 2x2 checkerboard: every vote is symmetric
    r = resolve("#.\n.#")
    assert r.ambiguous[0, 0]
    assert r.total_vote[0, 0] == 0
    assert not r.graph.diag_main[0, 0] and not r.graph.diag_anti[0, 0]


def test_non_transitive_block_does_not_crash():
    # greys 0, 40, 80: 0~40 and 40~80 but 0!~80: a block with both diagonals and some sides
    colours = {"a": (0, 0, 0, 255), "b": (40, 40, 40, 255), "c": (80, 80, 80, 255)}
    img = art("ab\nca", colours)
    g = build_similarity_graph(img)
    assert g.diag_main[0, 0] and g.diag_anti[0, 0]
    assert not (g.right[0, 0] and g.right[1, 0] and g.down[0, 0] and g.down[0, 1])
    r = resolve_crossings(g)
    assert not (r.graph.diag_main & r.graph.diag_anti).any()


@settings(max_examples=60, deadline=None, derandomize=True)
@given(arrays(np.uint8, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.integers(0, 2)))
def test_result_is_planar_and_a_subgraph(indices):
    palette = np.array([[0, 0, 0, 255], [40, 40, 40, 255], [80, 80, 80, 255]], np.uint8)
    g = build_similarity_graph(palette[indices])
    r = resolve_crossings(g)
    assert not (r.graph.diag_main & r.graph.diag_anti).any()
    for name in ("right", "down", "diag_main", "diag_anti"):
        assert not (getattr(r.graph, name) & ~getattr(g, name)).any()
    assert np.array_equal(r.graph.right, g.right) and np.array_equal(r.graph.down, g.down)
