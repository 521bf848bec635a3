"""Graph kernels in plain numpy: connected components (:func:`depixel.arrays.component_roots`,
which prepare/ uses too) and the cycles of a permutation.

Written out rather than taken from ``scipy.sparse.csgraph`` because importing scipy costs
about 0.3 s of CPU per process, more than converting a sprite. Both kernels are
label-pointer iterations (hooking and pointer jumping) whose round count grows with the
logarithm of the component or cycle size, each round a handful of whole-array operations.
A round's test is ``np.logical_or.reduce(mask)``: ``mask.any()`` goes through a Python
wrapper in numpy, ~1.5 µs a call more, and a sprite's writer runs ~50 rounds.
"""
from __future__ import annotations

import numpy as np

from ..arrays import component_roots  # noqa: F401 (the graph's kernel, kept on the ground floor for prepare/)


def cycle_leaders(nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For a permutation ``nxt`` of fewer than 2^31 elements (an image's half-edges): the
    smallest index on each element's cycle, and each element's number of steps from that
    leader along ``nxt`` (both ``(n,)`` int32).

    One doubling loop on a packed int64 key per element, ``leader << 32 | steps to it``:
    the key's minimum over a window of the next 2^t elements is the window's smallest
    element and its first place there, so a round is one gather and one ``np.minimum``
    (list ranking after finding the leaders took as many rounds again). The round's
    buffers are reused (a fresh array of a frame's size costs more in page faults than the
    gather that fills it)."""
    n = nxt.size  # (< 2**31: an image has at most limits.MAX_INDEXED_PIXELS, ~10 half-edges each)
    nxt = nxt.astype(np.int32)
    key = np.arange(n, dtype=np.int64)  # the window of element i alone: itself, 0 steps
    key <<= 32
    ahead = np.empty(n, np.int64)
    moved = np.empty(n, bool)
    spares = (np.empty(n, np.int32), np.empty(n, np.int32))  # (the jumps of odd and even rounds)
    jump, window = nxt, 1
    while True:
        key.take(jump, out=ahead, mode="clip")  # every index is valid: "clip" is not buffered
        ahead += window  # (the next window starts that many steps ahead)
        # the leader stops changing once every cycle is shorter than the window; a smaller
        # key with the same leader is never ahead (its steps are at least the window's)
        if not np.logical_or.reduce(np.less(ahead, key, out=moved)):
            break
        np.minimum(key, ahead, out=key)
        jump = jump.take(jump, out=spares[window.bit_length() % 2], mode="clip")
        window *= 2
    del jump, spares, ahead, moved
    leader = (key >> 32).astype(np.int32)
    key &= 0xFFFFFFFF
    to_leader = key.astype(np.int32)
    del key
    # the leader's place is 0, the element before it (1 step to it) the cycle's length - 1
    position = to_leader.take(nxt.take(leader))
    position += 1
    position -= to_leader
    position *= to_leader != 0
    return leader, position
