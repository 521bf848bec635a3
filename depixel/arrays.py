"""Set operations on arrays that do not load ``numpy.ma``.

numpy 2.x's ``np.unique`` (and ``union1d``, which calls it) imports ``numpy.ma`` on its
first call without ``return_index``/``return_inverse``/``return_counts``, to check for a
masked array: ~45 ms of every process, a tenth of a whole ``depixel convert``. Asking for
the indices takes the sorting path instead and returns the same values.
"""
from __future__ import annotations

import numpy as np


def unique(values: np.ndarray, axis: int | None = None) -> np.ndarray:
    """``np.unique(values, axis=axis)``: the distinct values (rows along ``axis``), sorted."""
    return np.unique(values, return_index=True, axis=axis)[0]


def union(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.union1d(a, b)``: the distinct values of both, sorted."""
    return unique(np.concatenate([np.ravel(a), np.ravel(b)]))


def batch_slices(n: int, batch: int) -> list[slice]:
    """Consecutive slices of ``n`` like items, ``batch`` at a time (the last one shorter): to
    bound the temporary memory of work done a batch at a time. No items, no slices."""
    return [slice(lo, lo + batch) for lo in range(0, n, batch)]


def batch_bounds(sizes: np.ndarray, batch: int) -> list[tuple[int, int]]:
    """Consecutive slices ``[a, b)`` of items of the given ``sizes``, each holding about
    ``batch`` in all (an item larger than that alone): to bound the temporary memory of
    work done a batch of items at a time. No items, no slices."""
    total = np.cumsum(sizes)
    if total.size == 0:
        return []
    cuts = unique(np.r_[0, np.searchsorted(total, np.arange(batch, int(total[-1]), batch)), total.size])
    return list(zip(cuts[:-1].tolist(), cuts[1:].tolist()))
