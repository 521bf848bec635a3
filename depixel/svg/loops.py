"""Closed boundary loops from directed half-edges, vectorized.

Used by the SVG exporter (outlines of unions of cells); the cell stage reads its one loop
per pixel cell off the templates, the same loops this would trace (tests/test_cells.py).
Input: half-edges ``(owner, u, v)`` such that at every ``(owner, node)`` as many half-edges
enter as leave — true for the boundary of any union of cells. Output: the loops,
each as a run of half-edge indices in traversal order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import unique
from ..graph.components import cycle_leaders


@dataclass(frozen=True, eq=False)
class Loops:
    """Loops in CSR form: loop k is ``halfedges[ptr[k]:ptr[k+1]]``, owned by ``owner[k]``."""

    owner: np.ndarray  # (L,) int64, sorted ascending
    ptr: np.ndarray  # (L+1,) int64
    halfedges: np.ndarray  # (total,) int64 indices into the caller's half-edge arrays

    def __len__(self) -> int:
        return int(self.owner.size)


def trace_loops(owner: np.ndarray, u: np.ndarray, v: np.ndarray, points: np.ndarray | None = None) -> Loops:
    """Chain half-edges u→v of each owner into closed loops.

    Where an owner's boundary touches itself at a node (k > 1 half-edges in and out), the
    i-th incoming half-edge (in index order) continues with the i-th outgoing one; any such
    pairing closes every loop and leaves the enclosed area unchanged. With ``points`` (the
    node coordinates, y down, the owner's area on the right of each half-edge), each
    incoming half-edge continues with the outgoing one that turns most sharply around the
    area the other way, keeping the outside on its left: so the loops never cross, and a
    hole that touches the outer boundary (or another hole) at a node is a loop of its own.
    Every loop is then an outer boundary (clockwise on screen) or a hole (counter-clockwise).
    Loops are ordered by owner, then by their smallest half-edge index, and each loop starts
    at its smallest half-edge index, so the result is deterministic.
    """
    owner = np.asarray(owner, dtype=np.int64)
    u = np.asarray(u, dtype=np.int64)
    v = np.asarray(v, dtype=np.int64)
    n = owner.size
    if n == 0:
        empty = np.zeros(0, np.int64)
        return Loops(empty, np.zeros(1, np.int64), empty)
    out_order, in_order = _argsort_pairs(owner, u, v)
    # both orders list the owners sorted: the loops close when the nodes left and the nodes
    # entered agree, owner by owner
    if not np.logical_and.reduce(u.take(out_order) == v.take(in_order)):  # (np.array_equal: a Python wrapper)
        raise ValueError("half-edges do not form closed loops")
    nxt = np.empty(n, np.int64)
    nxt[in_order] = out_order
    if points is not None:
        _pair_by_angle(nxt, owner, u, v, out_order, in_order, points)
    leader, position = cycle_leaders(nxt)
    del nxt
    # the half-edges by owner, leader, then along the loop: the loops (one per leader, the
    # half-edge at position 0) ordered by owner and leader, each half-edge placed at its
    # loop's start plus its position (no sort of all the half-edges)
    leaders = (position == 0).nonzero()[0]  # ascending, so a stable sort by owner keeps them in order
    loop_owner = owner.take(leaders)
    by_owner = loop_owner.argsort(kind="stable")
    leaders, loop_owner = leaders.take(by_owner), loop_owner.take(by_owner)
    ptr = np.zeros(leaders.size + 1, np.int64)
    np.bincount(leader, minlength=n).take(leaders).cumsum(out=ptr[1:])
    start = np.empty(n, np.int64)  # at the leaders only
    start[leaders] = ptr[:-1]
    place = start.take(leader)
    place += position
    del start, leader, position
    order = np.empty(n, np.int64)
    order[place] = np.arange(n, dtype=np.int64)
    return Loops(owner=loop_owner, ptr=ptr, halfedges=order)


def _pair_by_angle(nxt: np.ndarray, owner: np.ndarray, u: np.ndarray, v: np.ndarray, out_order: np.ndarray,
                   in_order: np.ndarray, points: np.ndarray) -> None:
    """Re-pair the half-edges at every (owner, node) with several in and out, in place."""
    key = owner.take(out_order) * (int(np.maximum.reduce(u)) + 1) + u.take(out_order)
    crowded = (key[1:] == key[:-1]).nonzero()[0]
    if crowded.size == 0:
        return
    for group in unique(key[crowded]).tolist():
        lo, hi = key.searchsorted([group, group + 1])
        outs, ins = out_order[lo:hi], in_order[lo:hi]
        node = points[u[outs[0]]].astype(np.float64)
        out_angle = np.arctan2(*(points[v[outs]] - node)[:, ::-1].T)
        back_angle = np.arctan2(*(points[u[ins]] - node)[:, ::-1].T)
        # the outside lies counter-clockwise (on screen) from the way back to the way out
        turn = (out_angle[None, :] - back_angle[:, None]) % (2 * np.pi)
        turn[turn <= 0] = 2 * np.pi
        for i, j in zip(*_assign(turn)):
            nxt[ins[i]] = outs[j]


def _assign(cost: np.ndarray) -> tuple[list[int], list[int]]:
    """Pair rows with columns, each row with its cheapest free column, cheapest pairs first."""
    rows, cols = [], []
    free_r, free_c = set(range(cost.shape[0])), set(range(cost.shape[1]))
    for flat in cost.argsort(axis=None, kind="stable").tolist():
        i, j = divmod(flat, cost.shape[1])
        if i in free_r and j in free_c:
            rows.append(i)
            cols.append(j)
            free_r.discard(i)
            free_c.discard(j)
    return rows, cols


def _argsort_pairs(major: np.ndarray, *minors: np.ndarray) -> list[np.ndarray]:
    """For each of ``minors``: the stable argsort by (major, minor), i.e.
    ``np.lexsort((minor, major))`` (one key of both when it fits in an int64)."""
    # (ufunc reductions: the array methods go through a Python wrapper)
    low = min(int(np.minimum.reduce(a)) for a in (major,) + minors)
    width = max(int(np.maximum.reduce(a)) for a in minors) + 1
    if low >= 0 and int(np.maximum.reduce(major)) < (2**62) // width:
        base = major * width
        return [(base + minor).argsort(kind="stable") for minor in minors]
    return [np.lexsort((minor, major)) for minor in minors]
