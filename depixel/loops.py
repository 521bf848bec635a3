"""Closed boundary loops from directed half-edges, vectorized.

Shared by the cell stage (one loop per pixel cell) and the SVG exporter (outlines of unions
of cells). Input: half-edges ``(owner, u, v)`` such that at every ``(owner, node)`` as many
half-edges enter as leave — true for the boundary of any union of cells. Output: the loops,
each as a run of half-edge indices in traversal order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .graph import cycle_leaders


@dataclass(frozen=True, eq=False)
class Loops:
    """Loops in CSR form: loop k is ``halfedges[ptr[k]:ptr[k+1]]``, owned by ``owner[k]``."""

    owner: np.ndarray  # (L,) int64, sorted ascending
    ptr: np.ndarray  # (L+1,) int64
    halfedges: np.ndarray  # (total,) int64 indices into the caller's half-edge arrays

    def __len__(self) -> int:
        return int(self.owner.size)


def trace_loops(owner: np.ndarray, u: np.ndarray, v: np.ndarray) -> Loops:
    """Chain half-edges u→v of each owner into closed loops.

    Where an owner's boundary touches itself at a node (k > 1 half-edges in and out), the
    i-th incoming half-edge (in index order) continues with the i-th outgoing one; any such
    pairing closes every loop and leaves the enclosed area unchanged.
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
    out_order = _argsort_pairs(owner, u)
    in_order = _argsort_pairs(owner, v)
    if not (np.array_equal(owner[out_order], owner[in_order]) and np.array_equal(u[out_order], v[in_order])):
        raise ValueError("half-edges do not form closed loops")
    nxt = np.empty(n, np.int64)
    nxt[in_order] = out_order
    leader, position = cycle_leaders(nxt)
    order = _argsort_pairs(owner, leader * n + position)  # by owner, leader, then along the loop
    starts = np.flatnonzero(position[order] == 0)
    ptr = np.r_[starts, n].astype(np.int64)
    return Loops(owner=owner[order][starts], ptr=ptr, halfedges=order)


def _argsort_pairs(major: np.ndarray, minor: np.ndarray) -> np.ndarray:
    """Stable argsort by (major, minor), i.e. ``np.lexsort((arange, minor, major))``."""
    if minor.min() >= 0 and major.min() >= 0 and int(major.max()) < (2**62) // (int(minor.max()) + 1):
        return np.argsort(major * (int(minor.max()) + 1) + minor, kind="stable")
    return np.lexsort((minor, major))
