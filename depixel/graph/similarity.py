"""Stage 1 — paper §3.2 (first part) — RGBA image → similarity graph.

Each pixel is linked to its eight neighbours; a link is dropped when the two colours are
dissimilar by the hqx YUV test. The graph is stored as four boolean arrays, one per link
direction, so every rule is a vectorized comparison of shifted arrays::

    right[r, c]     (r, c) — (r, c+1)        shape (H, W-1)
    down[r, c]      (r, c) — (r+1, c)        shape (H-1, W)
    diag_main[r, c] (r, c) — (r+1, c+1)      shape (H-1, W-1)   the "\\" diagonal of block (r, c)
    diag_anti[r, c] (r, c+1) — (r+1, c)      shape (H-1, W-1)   the "/" diagonal of block (r, c)

Transparency is part of the colour (docs/colour.md): two fully transparent pixels are
always similar, a fully transparent and a visible pixel never are, and two visible pixels
are similar when the YUV test passes and their alphas differ by at most ``threshold_alpha``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..colour import rgb_to_yuv
from ..frozen import compact_repr
from ..params import Params
from ..prepare.image import as_rgba


@dataclass(frozen=True, eq=False)
class SimilarityGraph:
    """Pixels and their 8-neighbour similarity links (see module docstring for layout)."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    rgba: np.ndarray  # (H, W, 4) uint8
    right: np.ndarray  # (H, W-1) bool
    down: np.ndarray  # (H-1, W) bool
    diag_main: np.ndarray  # (H-1, W-1) bool
    diag_anti: np.ndarray  # (H-1, W-1) bool

    @property
    def shape(self) -> tuple[int, int]:
        return self.rgba.shape[0], self.rgba.shape[1]

    def yuv(self) -> np.ndarray:
        """``(H, W, 3) float64`` hqx YUV of the pixels on a 0-255 scale, computed on each call:
        the graph lives until the SVG is written, and YUV is needed only by the first stages."""
        return rgb_to_yuv(self.rgba[..., :3])

    def degree(self) -> np.ndarray:
        """Valence of every pixel in the graph, ``(H, W) int``."""
        h, w = self.shape
        deg = np.zeros((h, w), dtype=np.int64)
        deg[:, :-1] += self.right
        deg[:, 1:] += self.right
        deg[:-1, :] += self.down
        deg[1:, :] += self.down
        deg[:-1, :-1] += self.diag_main
        deg[1:, 1:] += self.diag_main
        deg[:-1, 1:] += self.diag_anti
        deg[1:, :-1] += self.diag_anti
        return deg

    def edge_list(self) -> np.ndarray:
        """All links as ``(M, 2) int64`` pairs of flat pixel indices (row-major)."""
        return np.stack(self.edge_ends(), axis=1)

    def edge_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """The two columns of :meth:`edge_list`, ``(M,) int64`` each (rows picked from each
        column once, not as pairs)."""
        h, w = self.shape
        idx = np.arange(h * w).reshape(h, w)
        links = ((self.right, idx[:, :-1], idx[:, 1:]), (self.down, idx[:-1, :], idx[1:, :]),
                 (self.diag_main, idx[:-1, :-1], idx[1:, 1:]), (self.diag_anti, idx[:-1, 1:], idx[1:, :-1]))
        return (np.concatenate([a[link] for link, a, _ in links]),
                np.concatenate([b[link] for link, _, b in links]))

    def with_diagonals(self, diag_main: np.ndarray, diag_anti: np.ndarray) -> SimilarityGraph:
        """The same graph with other diagonal links (used by crossing resolution)."""
        return SimilarityGraph(self.rgba, self.right, self.down, diag_main, diag_anti)


def similar(yuv_a: np.ndarray, alpha_a: np.ndarray, yuv_b: np.ndarray, alpha_b: np.ndarray,
            params: Params) -> np.ndarray:
    """The paper's colour test extended to alpha; broadcasts over leading axes → bool."""
    delta = np.abs(yuv_a - yuv_b)
    colour_ok = (
        (delta[..., 0] <= params.threshold_y)
        & (delta[..., 1] <= params.threshold_u)
        & (delta[..., 2] <= params.threshold_v)
    )
    alpha_a = alpha_a.astype(np.int32)
    alpha_b = alpha_b.astype(np.int32)
    clear_a, clear_b = alpha_a == 0, alpha_b == 0
    visible_ok = colour_ok & (np.abs(alpha_a - alpha_b) <= params.threshold_alpha)
    return np.where(clear_a | clear_b, clear_a & clear_b, visible_ok)


def build_similarity_graph(image, params: Params = Params()) -> SimilarityGraph:
    """Link every pixel to each of its 8 neighbours whose colour is similar.

    ``image`` is an ``(H, W, 4) uint8`` RGBA array (or anything :func:`as_rgba` accepts).
    """
    rgba = as_rgba(image)
    yuv = rgb_to_yuv(rgba[..., :3])
    alpha = rgba[..., 3]

    def link(sl_a: tuple, sl_b: tuple) -> np.ndarray:
        return similar(yuv[sl_a], alpha[sl_a], yuv[sl_b], alpha[sl_b], params)

    every, head, tail = slice(None), slice(None, -1), slice(1, None)
    return SimilarityGraph(
        rgba=rgba,
        right=link((every, head), (every, tail)),
        down=link((head, every), (tail, every)),
        diag_main=link((head, head), (tail, tail)),
        diag_anti=link((head, tail), (tail, head)),
    )
