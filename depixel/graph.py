"""Graph kernels in plain numpy: connected components and the cycles of a permutation.

Written out rather than taken from ``scipy.sparse.csgraph`` because importing scipy costs
about 0.3 s of CPU per process, more than converting a sprite. Both kernels are
label-pointer iterations (hooking and pointer jumping) whose round count grows with the
logarithm of the component or cycle size, each round a handful of whole-array operations.
"""
from __future__ import annotations

import numpy as np


def component_roots(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) int64: the smallest node of each node's connected component (edges a[i]—b[i]).

    Invariant: ``root[x] <= x`` is a node of x's component. Each round hooks the larger of
    two different roots joined by an edge under the smaller, then jumps pointers until
    every node points at a root; at the fixed point each component has one root, its
    smallest node.
    """
    root = np.arange(n, dtype=np.int64)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    while a.size:
        ra, rb = root[a], root[b]
        differ = ra != rb
        if not differ.any():
            break
        a, b, ra, rb = a[differ], b[differ], ra[differ], rb[differ]  # settled edges stay settled
        np.minimum.at(root, np.maximum(ra, rb), np.minimum(ra, rb))
        root = _jump_to_roots(root)
    return root


def cycle_leaders(nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For a permutation ``nxt``: the smallest index on each element's cycle, and each
    element's number of steps from that leader along ``nxt`` (both ``(n,) int64``)."""
    n = nxt.size
    index = np.arange(n, dtype=np.int64)
    # leader: min over the next 2^t elements, doubling t until it stops changing (then
    # every cycle is shorter than the window)
    leader, jump = np.minimum(index, nxt), nxt[nxt]
    while True:
        wider = np.minimum(leader, leader[jump])
        if np.array_equal(wider, leader):
            break
        leader, jump = wider, jump[jump]
    # steps to the cycle's last element (the one before its leader), by list ranking on
    # the cycle cut open there; position from the leader follows from the cycle length
    last = nxt == leader
    succ = np.where(last, index, nxt)
    to_end = (~last).astype(np.int64)
    while True:
        ahead = succ[succ]
        if np.array_equal(ahead, succ):  # everything points at its cycle's last element
            break
        to_end = to_end + to_end[succ]
        succ = ahead
    length = to_end[leader] + 1
    return leader, length - 1 - to_end


def _jump_to_roots(parent: np.ndarray) -> np.ndarray:
    """Pointer jumping until every element points at a root (``parent[r] == r``)."""
    while True:
        grand = parent[parent]
        if np.array_equal(grand, parent):
            return parent
        parent = grand
