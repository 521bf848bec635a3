"""Stage 5c — paper §3.4 (last paragraph) — the nodes off the curves follow them.

After the relaxation moves the curve nodes, the other nodes of the cell graph (inside
regions, between shading cells) move by the harmonic interpolation of the curve nodes'
displacements, so the cells next to a moved curve follow it instead of folding. Untouched
areas keep exactly their template geometry, since a zero displacement field is harmonic.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .arrays import set_rows
from .splines import SplineSet


def harmonic_map(splines: SplineSet, start: np.ndarray, positions: np.ndarray,
                 corners: np.ndarray, reach: int = 6, display: np.ndarray | None = None) -> np.ndarray:
    """(N, 2) ``positions`` with the free nodes moved by the harmonic interpolation of the
    constrained displacements (``start`` → ``positions`` (N, 2); ``corners`` (N,) bool).
    ``display``: the display points of ``positions`` when the caller has drawn them already.

    Constrained: every curve node (displaced from its initial place to its display point),
    the border and corners (not displaced). The system — each free node's displacement is
    the mean of its neighbours' (uniform weights) — is solved for the free nodes within
    ``reach`` edges of a displaced node; farther free nodes are held at their place (the
    harmonic field has decayed to nothing there), which keeps full frames cheap. The
    solver is conjugate gradients in numpy (the system is symmetric positive definite),
    run to well below the output precision (:func:`conjugate_gradients`).
    """
    cells = splines.cells
    n = len(start)
    q = cells.nodes
    h, w = cells.shape
    border = (q[:, 0] == 0) | (q[:, 1] == 0) | (q[:, 0] == 4 * w) | (q[:, 1] == 4 * h)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[splines.curve_nodes] = True
    if display is None:
        display = splines.display_points(positions)
    displacement = np.where(on_curve[:, None], display - start, 0.0)
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    near = np.abs(displacement).max(axis=1) > 1e-12
    for _ in range(reach):
        grown = near.copy()
        grown[u[near[v]]] = True
        grown[v[near[u]]] = True
        near = grown
    free = ~(on_curve | border | corners) & near
    if not free.any():
        return positions
    degree = np.bincount(u, minlength=n) + np.bincount(v, minlength=n)
    # the system on the free nodes only: compact indices, free–free edges for the operator,
    # free–fixed edges for the right-hand side
    index = np.cumsum(free) - 1
    m = int(free.sum())
    inner = free[u] & free[v]
    fu, fv = index[u[inner]], index[v[inner]]
    # the unknowns as two rows (x, y) of M: a (2,) factor broadcast over (M, 2) would run
    # numpy's inner loop two elements at a time
    rhs = np.zeros((2, m))
    for a, b in ((u, v), (v, u)):  # a free, b fixed
        edge = free[a] & ~free[b]
        for i in range(2):
            rhs[i] += np.bincount(index[a[edge]], displacement[b[edge], i], minlength=m)
    diagonal = degree[free].astype(np.float64)
    # x[:, fv] summed into the columns fu (and x[:, fu] into fv), both rows by one bincount
    # over the flattened (2, M) array: each bin adds its terms in the same order as a
    # bincount per row would
    to_u = np.concatenate([fu, fu + m])
    to_v = np.concatenate([fv, fv + m])

    def apply(x: np.ndarray) -> np.ndarray:
        neighbours = np.bincount(to_u, x.take(fv, axis=1).ravel(), minlength=2 * m)
        neighbours += np.bincount(to_v, x.take(fu, axis=1).ravel(), minlength=2 * m)
        out = diagonal * x
        out -= neighbours.reshape(2, m)
        return out

    out = positions.copy()
    out[free] = start[free] + conjugate_gradients(apply, rhs).T
    return out


def follow(display: np.ndarray, before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(N, 2) the display points of ``after`` from those of ``before`` (``display``), when
    ``after`` moved nodes off the curves alone (as :func:`harmonic_map` does): a moved node
    is shown where it is, the curves and their display points stay."""
    moved = np.flatnonzero((after[:, 0] != before[:, 0]) | (after[:, 1] != before[:, 1]))
    out = display.copy()
    set_rows(out, moved, after.take(moved, axis=0))
    return out


def conjugate_gradients(apply: Callable[[np.ndarray], np.ndarray], rhs: np.ndarray) -> np.ndarray:
    """Solve ``apply(x) = rhs`` for a symmetric positive definite operator, every row of
    ``rhs`` (K, M) at once, to a residual 1e-5 of the right-hand side's: on the paper
    corpus and the game frames the solution is then within 4e-5 px of the converged one,
    far below the SVG's 0.01 px (half the iterations of a 1e-9 residual)."""
    x = np.zeros_like(rhs)
    r = rhs.copy()
    p = r.copy()
    rr = row_dots(r, r)
    target = 1e-10 * max(float(rr.max()), 1e-30)
    for _ in range(4 * rhs.shape[1] + 10):
        if rr.max() <= target:
            break
        ap = apply(p)
        step = (rr / np.maximum(row_dots(p, ap), 1e-300))[:, None]
        x += step * p
        r -= step * ap
        rr_new = row_dots(r, r)
        p *= (rr_new / np.maximum(rr, 1e-300))[:, None]
        p += r
        rr = rr_new
    return x


def row_dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K,) the dot products of the rows of ``a`` and ``b`` (K, M), summed element after
    element in order (``cumsum``: the order of the sums this solver was first written with,
    ``(a * b).sum(axis=0)`` over (M, K) columns, which its output depends on)."""
    return (a * b).cumsum(axis=1)[:, -1]
