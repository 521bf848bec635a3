"""Closed boundary loops from directed half-edges, vectorized.

Shared by the cell stage (one loop per pixel cell) and the SVG exporter (outlines of unions
of cells). Input: half-edges ``(owner, u, v)`` such that at every ``(owner, node)`` as many
half-edges enter as leave — true for the boundary of any union of cells. Output: the loops,
each as a run of half-edge indices in traversal order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
    out_order = np.lexsort((np.arange(n), u, owner))
    in_order = np.lexsort((np.arange(n), v, owner))
    if not (np.array_equal(owner[out_order], owner[in_order]) and np.array_equal(u[out_order], v[in_order])):
        raise ValueError("half-edges do not form closed loops")
    nxt = np.empty(n, np.int64)
    nxt[in_order] = out_order

    # Leader of each cycle = its smallest index, by pointer doubling.
    leader = np.arange(n)
    jump = nxt.copy()
    for _ in range(int(np.ceil(np.log2(n + 1))) + 1):
        leader = np.minimum(leader, leader[jump])
        jump = jump[jump]
    # Steps from each half-edge back to its leader, walking forward: list ranking on the
    # cycle broken just before the leader.
    is_last = nxt == leader
    succ = np.where(is_last, np.arange(n), nxt)
    dist = np.where(is_last, 0, 1).astype(np.int64)
    for _ in range(int(np.ceil(np.log2(n + 1))) + 1):
        dist = dist + np.where(succ == np.arange(n), 0, dist[succ])
        succ = succ[succ]
    # order: by owner, leader, then decreasing distance to the end of the cycle
    order = np.lexsort((-dist, leader, owner))
    sorted_leader = leader[order]
    starts = np.flatnonzero(np.r_[True, sorted_leader[1:] != sorted_leader[:-1]])
    ptr = np.r_[starts, n].astype(np.int64)
    return Loops(owner=owner[order][starts], ptr=ptr, halfedges=order)
