"""Stage 1: the YUV similarity test and the 8-neighbour graph."""
from __future__ import annotations

import numpy as np
import pytest

from depixel.colour import rgb_to_yuv
from depixel.graph.similarity import build_similarity_graph, similar
from depixel.params import Params

YUV_TO_RGB = np.linalg.inv(np.array([[0.299, 0.587, 0.114], [-0.169, -0.331, 0.5], [0.5, -0.419, -0.081]]))


def pair_with_yuv_offset(delta) -> np.ndarray:
    """A 1×2 image whose pixels differ by ``delta`` in YUV (float RGB, no rounding)."""
    base = np.array([120.0, 128.0, 110.0])
    other = base + YUV_TO_RGB @ np.asarray(delta, dtype=np.float64)
    return np.stack([base, other])[None]


@pytest.mark.parametrize("channel,limit", [(0, 48.0), (1, 7.0), (2, 6.0)])
def test_threshold_inside_and_outside(channel, limit):
    for offset, expected in ((limit - 0.01, True), (limit + 0.01, False)):
        delta = np.zeros(3)
        delta[channel] = offset
        rgb = pair_with_yuv_offset(delta)
        yuv = rgb_to_yuv(rgb)
        assert abs(abs(yuv[0, 1, channel] - yuv[0, 0, channel]) - offset) < 1e-6
        alpha = np.full((1, 2), 255)
        assert bool(similar(yuv[0, 0], alpha[0, 0], yuv[0, 1], alpha[0, 1], Params())) is expected


def test_thresholds_on_uint8_images():
    # Y differs by exactly 48 for grey 0 vs 48 (U = V = 0): similar; 49 is not
    for grey, linked in ((48, True), (49, False)):
        img = np.array([[[0, 0, 0, 255], [grey, grey, grey, 255]]], dtype=np.uint8)
        assert bool(build_similarity_graph(img).right[0, 0]) is linked


def test_alpha_rules():
    clear_red = [255, 0, 0, 0]
    clear_blue = [0, 0, 255, 0]
    red = [255, 0, 0, 255]
    half_red = [255, 0, 0, 128]
    img = np.array([[clear_red, clear_blue, red, half_red]], dtype=np.uint8)
    g = build_similarity_graph(img)
    assert g.right.tolist() == [[True, False, False]]  # clear~clear, clear!~red, |Δα| = 127 > 48


def test_graph_arrays_and_degree():
    img = np.zeros((3, 4, 4), np.uint8)
    img[..., 3] = 255
    g = build_similarity_graph(img)
    assert g.right.shape == (3, 3) and g.down.shape == (2, 4) and g.diag_main.shape == (2, 3)
    deg = g.degree()
    assert deg[1, 1] == 8 and deg[0, 0] == 3 and deg[0, 1] == 5
    assert len(g.edge_list()) == deg.sum() // 2


def test_edge_ends_are_the_links():
    """Every link once, as a pair of flat pixel indices, right, down, "\\" then "/" links."""
    rng = np.random.default_rng(5)
    palette = np.array([[0, 0, 0, 255], [255, 255, 255, 255], [0, 0, 0, 0]], np.uint8)
    for _ in range(30):
        h, w = (int(x) for x in rng.integers(1, 7, 2))
        g = build_similarity_graph(palette[rng.integers(0, 3, (h, w))])
        expected = []
        for link, (dr, dc), (r0, c0) in ((g.right, (0, 1), (0, 0)), (g.down, (1, 0), (0, 0)),
                                         (g.diag_main, (1, 1), (0, 0)), (g.diag_anti, (1, -1), (0, 1))):
            for r, c in zip(*np.nonzero(link)):
                a = (r + r0) * w + c + c0
                expected.append((a, a + dr * w + dc))
        a, b = g.edge_ends()
        assert list(zip(a.tolist(), b.tolist())) == expected
        assert np.array_equal(g.edge_list(), np.array(expected, np.int64).reshape(-1, 2))
