"""Stage 5c — paper §3.4 (last paragraph) — the nodes off the curves follow them.

After the relaxation moves the curve nodes, the other nodes of the cell graph (inside
regions, between shading cells) move by the harmonic interpolation of the curve nodes'
displacements, so the cells next to a moved curve follow it instead of folding. Untouched
areas keep exactly their template geometry, since a zero displacement field is harmonic.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..arrays import either, set_rows
from ..curves.splines import SplineSet
from .joined import JoinedCells, border_nodes

#: unknowns from which the operator sums the neighbours by a padded table (:class:`_NeighbourSums`)
#: rather than a scatter: the table's setup (two sorts) and its extra calls cost more on a
#: sprite's small system (+13 % on the paper corpus) than its gathers save; a frame's system
#: (~29,000 unknowns) is 13-14 % faster. The two give the same sums.
TABLE_UNKNOWNS = 2048


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

    The curves of several images joined (:class:`depixel.optimize.joined.JoinedCells`) are
    mapped as one system whose images' parts are solved apart (each its own iterations and
    dot products): each image gets the numbers it gets alone.
    """
    cells = splines.cells
    n = len(start)
    border = border_nodes(cells)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[splines.curve_nodes] = True
    if display is None:
        display = splines.display_points(positions)
    # the displacements as x and y columns (an (N, 2) array would run numpy's inner loops
    # two elements at a time)
    moved_x = np.where(on_curve, display[:, 0] - start[:, 0], 0.0)
    moved_y = np.where(on_curve, display[:, 1] - start[:, 1], 0.0)
    u, v = cells.edges.T.astype(np.intp)  # contiguous, and converted once for every gather below
    near = (np.abs(moved_x) > 1e-12) | (np.abs(moved_y) > 1e-12)
    # grown one edge at a time; an edge with a near end has both ends near after its round,
    # so only the edges with neither end near are looked at again
    open_u, open_v = u, v
    for _ in range(reach):
        if open_u.size == 0:  # every edge has a near end: nothing more to reach
            break
        near_u, near_v = near.take(open_u), near.take(open_v)
        near[open_u.compress(near_v)] = True
        near[open_v.compress(near_u)] = True
        rest = ~(near_u | near_v)
        open_u, open_v = open_u.compress(rest), open_v.compress(rest)
    free = ~(on_curve | border | corners) & near
    if not np.logical_or.reduce(free):
        return positions
    degree = np.bincount(u, minlength=n) + np.bincount(v, minlength=n)
    # the system on the free nodes only: compact indices, free–free edges for the operator,
    # free–fixed edges for the right-hand side
    index = free.cumsum() - 1
    m = int(free.sum())
    free_u, free_v = free.take(u), free.take(v)
    inner = free_u & free_v
    fu, fv = index.take(u.compress(inner)), index.take(v.compress(inner))
    # the unknowns as two rows (x, y) of M: a (2,) factor broadcast over (M, 2) would run
    # numpy's inner loop two elements at a time
    rhs = np.zeros((2, m))
    for a, b, edge in ((u, v, free_u & ~free_v), (v, u, free_v & ~free_u)):  # a free, b fixed
        at, fixed = index.take(a.compress(edge)), b.compress(edge)
        for i, moved in enumerate((moved_x, moved_y)):
            rhs[i] += np.bincount(at, moved.take(fixed), minlength=m)
    diagonal = degree.compress(free).astype(np.float64)
    diagonal = np.concatenate([diagonal, diagonal])  # both rows (np.tile is a Python function)
    if m >= TABLE_UNKNOWNS:
        table = _NeighbourSums(fu, fv, m)

        def apply(x: np.ndarray, out: np.ndarray) -> None:
            flat = out.reshape(-1)
            np.multiply(diagonal, x.reshape(-1), out=flat)
            flat -= table.of(x)
    else:
        # x[:, fv] summed into the columns fu (and x[:, fu] into fv), both rows by one
        # bincount over the flattened (2, M) array, into bins 0..2M for the first sums and
        # 2M..4M for the second (each bin adds its terms in the same order as a bincount
        # per row and sum would), then the two halves added; both gathers are one take of
        # the flattened x
        to = np.concatenate([fu, fu + m, fv + 2 * m, fv + 3 * m])
        gather = np.concatenate([fv, fv + m, fu, fu + m])

        def apply(x: np.ndarray, out: np.ndarray) -> None:
            flat_x = x.reshape(-1)
            sums = np.bincount(to, flat_x.take(gather), minlength=4 * m)
            flat = out.reshape(-1)
            np.multiply(diagonal, flat_x, out=flat)
            flat -= np.add(sums[:2 * m], sums[2 * m:], out=sums[:2 * m])

    parts = None if not isinstance(cells, JoinedCells) else index.take(cells.node_bounds[1:] - 1) + 1
    x = conjugate_gradients(apply, rhs, None if parts is None else np.concatenate([[0], parts]))
    out = positions.copy()
    nodes = free.nonzero()[0]
    before = start.take(nodes, axis=0)  # (rows gathered: a column's take copies the whole column first)
    for i in range(2):  # a column at a time: the same sums as start[free] + x.T, without row copies
        out[nodes, i] = before[:, i] + x[i]
    return out


class _NeighbourSums:
    """The sum of the free neighbours' values at every free node, for both rows of a (2, M)
    array: at node j, the values at ``fv`` of the edges with ``fu`` = j, in edge order, plus
    the values at ``fu`` of the edges with ``fv`` = j, in edge order — the additions of a
    ``bincount`` over the edges, in the same order, but as a table of neighbours padded with
    a zero (a cell graph node has at most four edges): one gather into a reused table and a
    few whole-row additions, instead of a gather and a scatter into fresh arrays."""

    def __init__(self, fu: np.ndarray, fv: np.ndarray, m: int) -> None:
        (rank_u, self.ahead), (rank_v, behind) = _ranks(fu, m), _ranks(fv, m)
        # indices into the (2M + 1,) padded values: the edges at u, then those at v; a
        # column per unknown, x row then y row
        self.table = np.full((self.ahead + behind, 2 * m), 2 * m)
        flat = self.table.reshape(-1)
        for rank, at, other in ((rank_u, fu, fv), (rank_v + self.ahead, fv, fu)):
            place = rank * (2 * m) + at
            flat.put(place, other)
            flat.put(place + m, other + m)
        self.padded = np.zeros(2 * m + 1)  # the values, then the zero
        self.gathered = np.empty(self.table.shape)

    def of(self, x: np.ndarray) -> np.ndarray:
        """(2M,) the neighbour sums of ``x`` (2, M), flattened: a buffer the next call reuses."""
        self.padded[:-1] = x.reshape(-1)
        rows = self.padded.take(self.table, out=self.gathered, mode="clip")  # in range; "raise" copies first
        ahead, behind = rows[0], rows[self.ahead]
        for row in rows[1:self.ahead]:
            ahead += row
        for row in rows[self.ahead + 1:]:
            behind += row
        ahead += behind
        return ahead


def _ranks(at: np.ndarray, m: int) -> tuple[np.ndarray, int]:
    """Each edge's place among the edges at the same node ``at`` (of M), in edge order, and
    the most edges at a node (at least 1): the first edge at each node found by a minimum
    per node, then the first of the rest, and so on (a cell graph node has at most four
    edges; no sort)."""
    rank = np.zeros(at.size, np.int64)
    rest = np.arange(at.size)
    width = 0
    while rest.size:
        nodes = at.take(rest)
        first = np.full(m, at.size)
        np.minimum.at(first, nodes, rest)
        later = first.take(nodes) != rest
        rest = rest.compress(later)
        width += 1
        rank[rest] = width
    return rank, max(width, 1)


def follow(display: np.ndarray, before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(N, 2) the display points of ``after`` from those of ``before`` (``display``), when
    ``after`` moved nodes off the curves alone (as :func:`harmonic_map` does): a moved node
    is shown where it is, the curves and their display points stay."""
    moved = either(after != before).nonzero()[0]
    out = display.copy()
    set_rows(out, moved, after.take(moved, axis=0))
    return out


def conjugate_gradients(apply: Callable[[np.ndarray, np.ndarray], None], rhs: np.ndarray,
                        parts: np.ndarray | None = None) -> np.ndarray:
    """Solve ``A x = rhs`` for a symmetric positive definite operator (``apply(x, out)``
    writes A x into ``out``), every row of ``rhs`` (K, M) at once, to a residual 1e-5 of the
    right-hand side's: on the paper corpus and the game frames the solution is then within
    4e-5 px of the converged one, far below the SVG's 0.01 px (half the iterations of a
    1e-9 residual).

    Per iteration a fixed set of whole-array operations into preallocated buffers (the
    cost of a sprite's small system is the number of numpy calls, of a frame's the fresh
    memory): x and r are updated together as one (2, K, M) array, the per-row numbers are
    Python floats (r − s·Ap is computed as r + (−s)·Ap, which rounds the same).

    ``parts`` (S+1,): the bounds of independent systems among the columns (several images'
    maps joined): each is solved as alone (:func:`_conjugate_parts`)."""
    if parts is not None:
        bounds = np.unique(parts).tolist()  # an image with no unknowns has no part
        if len(bounds) > 2:
            return _conjugate_parts(apply, rhs, bounds)
    state, directions, change, product = _buffers(rhs)
    x, r = state
    p, ap = directions
    k = rhs.shape[0]
    step = np.empty((2, k, 1))  # the per-row factors (s, -s), written in place: no array built per iteration
    ratio = np.empty((k, 1))
    rr = row_dots(r, r, product)
    target = 1e-10 * max(max(rr), 1e-30)
    for _ in range(4 * rhs.shape[1] + 10):
        if max(rr) <= target:
            break
        apply(p, ap)
        for i, (a, b) in enumerate(zip(rr, row_dots(p, ap, product))):
            step[0, i, 0] = s = a / max(b, 1e-300)
            step[1, i, 0] = -s
        np.multiply(directions, step, out=change)
        state += change
        rr_new = row_dots(r, r, product)
        for i, (a, b) in enumerate(zip(rr_new, rr)):
            ratio[i, 0] = a / max(b, 1e-300)
        p *= ratio
        p += r
        rr = rr_new
    return x


def _buffers(rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The conjugate gradients' arrays for ``rhs`` (K, M): x and r (x = 0, r = rhs), p and A p
    (p = rhs), a buffer for their changes, one for products."""
    state = np.zeros((2,) + rhs.shape)
    state[1] = rhs
    directions = np.empty_like(state)
    directions[0] = rhs
    return state, directions, np.empty_like(state), np.empty_like(rhs)


def row_dots(a: np.ndarray, b: np.ndarray, product: np.ndarray | None = None) -> list[float]:
    """The dot products of the rows of ``a`` and ``b`` (K, M), by numpy's pairwise sum
    (``product`` (K, M): a buffer to work in). An in-order sum (``cumsum``) was 3–6× slower
    per call, and its last bits did not show in any output (benchmarks/check_output_stable.py)."""
    return np.add.reduce(np.multiply(a, b, out=product), axis=1).tolist()


def _conjugate_parts(apply: Callable[[np.ndarray, np.ndarray], None], rhs: np.ndarray, bounds: list[int]
                     ) -> np.ndarray:
    """:func:`conjugate_gradients` of the systems whose columns ``bounds`` (S+1,) cut ``rhs``
    (K, M) into, the operator's whole-array steps shared: each part's dot products are its
    own (:func:`part_dots`, numpy's pairwise sum of its columns alone), its factors are
    spread over its columns, and a part that has converged (or run out of iterations) takes
    steps of zero from then on (x + 0·p is x: x and r are never −0). The numbers of each part
    are those of its system solved alone."""
    state, directions, change, product = _buffers(rhs)
    x, r = state
    p, ap = directions
    widths = np.diff(bounds)
    step = np.empty((2,) + rhs.shape)
    rr = part_dots(r, r, product, bounds)  # (K, S)
    target = 1e-10 * np.maximum(rr.max(axis=0), 1e-30)
    limit = 4 * widths + 10
    for i in range(int(limit.max(initial=0))):
        live = ~(rr.max(axis=0) <= target) & (i < limit)
        if not live.any():
            break
        apply(p, ap)
        s = np.where(live, rr / np.maximum(part_dots(p, ap, product, bounds), 1e-300), 0.0)
        step[0] = s.repeat(widths, axis=1)
        np.negative(step[0], out=step[1])
        np.multiply(directions, step, out=change)
        state += change
        rr_new = part_dots(r, r, product, bounds)
        p *= np.where(live, rr_new / np.maximum(rr, 1e-300), 0.0).repeat(widths, axis=1)
        p += r
        rr = np.where(live, rr_new, rr)
    return x


def part_dots(a: np.ndarray, b: np.ndarray, product: np.ndarray, bounds: list[int]) -> np.ndarray:
    """(K, S) :func:`row_dots` of the columns of each part that ``bounds`` (S+1,) cut ``a`` and
    ``b`` (K, M) into, each summed alone (the same numbers as the part's own array)."""
    np.multiply(a, b, out=product)
    out = np.empty((a.shape[0], len(bounds) - 1))
    for j in range(len(bounds) - 1):
        np.add.reduce(product[:, bounds[j]:bounds[j + 1]], axis=1, out=out[:, j])
    return out
