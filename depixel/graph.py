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
    element's number of steps from that leader along ``nxt`` (both ``(n,) int64``).

    Works on 32-bit indices where they suffice and updates in place: the caller's
    permutation can be as large as every half-edge of an image."""
    n = nxt.size
    index = np.int32 if n < 2**31 else np.int64
    nxt = nxt.astype(index)
    # leader: min over the next 2^t elements, doubling t until it stops changing (then
    # every cycle is shorter than the window)
    leader = np.minimum(np.arange(n, dtype=index), nxt)
    jump = nxt[nxt]
    while True:
        ahead = leader[jump]
        if not (ahead < leader).any():
            break
        np.minimum(leader, ahead, out=leader)
        del ahead
        jump = jump[jump]
    del jump, ahead
    # steps to the cycle's last element (the one before its leader), by list ranking on
    # the cycle cut open there; position from the leader follows from the cycle length
    last = nxt == leader
    succ = np.where(last, np.arange(n, dtype=index), nxt)
    del nxt
    to_end = (~last).astype(index)
    del last
    while True:
        ahead = succ[succ]
        if np.array_equal(ahead, succ):  # everything points at its cycle's last element
            break
        to_end += to_end[succ]
        succ = ahead
    del succ, ahead
    position = to_end[leader].astype(np.int64)  # the cycle's length - 1, minus the steps to its end
    position -= to_end
    return leader.astype(np.int64), position


def _jump_to_roots(parent: np.ndarray) -> np.ndarray:
    """Pointer jumping until every element points at a root (``parent[r] == r``)."""
    while True:
        grand = parent[parent]
        if np.array_equal(grand, parent):
            return parent
        parent = grand
