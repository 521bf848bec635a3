"""Graph kernels in plain numpy: connected components and the cycles of a permutation.

Written out rather than taken from ``scipy.sparse.csgraph`` because importing scipy costs
about 0.3 s of CPU per process, more than converting a sprite. Both kernels are
label-pointer iterations (hooking and pointer jumping) whose round count grows with the
logarithm of the component or cycle size, each round a handful of whole-array operations.
A round's test is ``np.logical_or.reduce(mask)``: ``mask.any()`` goes through a Python
wrapper in numpy, ~1.5 µs a call more, and a sprite's writer runs ~50 rounds.
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
        ra, rb = root.take(a), root.take(b)
        differ = ra != rb
        if not np.logical_or.reduce(differ):
            break
        # settled edges stay settled
        a, b, ra, rb = a.compress(differ), b.compress(differ), ra.compress(differ), rb.compress(differ)
        np.minimum.at(root, np.maximum(ra, rb), np.minimum(ra, rb))
        root = _jump_to_roots(root)
    return root


def cycle_leaders(nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For a permutation ``nxt``: the smallest index on each element's cycle, and each
    element's number of steps from that leader along ``nxt`` (both ``(n,)``, int32 when
    ``n < 2**31``, else int64).

    Works on 32-bit indices where they suffice, and in a few buffers reused by every round
    (a fresh array of a frame's size costs more in page faults than the gather that fills
    it): the caller's permutation can be as large as every half-edge of an image."""
    n = nxt.size
    index = np.int32 if n < 2**31 else np.int64
    nxt = nxt.astype(index)
    ahead, spare = np.empty(n, index), np.empty(n, index)
    moved = np.empty(n, bool)
    # leader: min over the next 2^t elements, doubling t until it stops changing (then
    # every cycle is shorter than the window)
    leader = np.minimum(np.arange(n, dtype=index), nxt)
    jump = nxt.take(nxt)
    while True:
        leader.take(jump, out=ahead, mode="clip")  # every index is valid: "clip" is not buffered
        if not np.logical_or.reduce(np.less(ahead, leader, out=moved)):
            break
        np.minimum(leader, ahead, out=leader)
        jump.take(jump, out=spare, mode="clip")
        jump, spare = spare, jump
    del jump
    # steps to the cycle's last element (the one before its leader), by list ranking on
    # the cycle cut open there; position from the leader follows from the cycle length
    last = np.equal(nxt, leader, out=moved)
    succ = np.where(last, np.arange(n, dtype=index), nxt)
    del nxt
    to_end = np.logical_not(last).astype(index)
    while True:
        succ.take(succ, out=ahead, mode="clip")
        # done when everything points at its cycle's last element
        if not np.logical_or.reduce(np.not_equal(ahead, succ, out=moved)):
            break
        to_end.take(succ, out=spare, mode="clip")
        to_end += spare
        succ, ahead = ahead, succ
    del succ, ahead, spare, moved
    position = to_end.take(leader)  # the cycle's length - 1, minus the steps to its end
    position -= to_end
    return leader, position


def _jump_to_roots(parent: np.ndarray) -> np.ndarray:
    """Pointer jumping until every element points at a root (``parent[r] == r``)."""
    while True:
        grand = parent.take(parent)
        if not np.logical_or.reduce(grand != parent):  # (np.array_equal's checks cost more on a sprite)
            return parent
        parent = grand
