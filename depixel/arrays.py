"""Array helpers around numpy's slow or costly paths.

numpy 2.x's ``np.unique`` (and ``union1d``, which calls it) imports ``numpy.ma`` on its
first call without ``return_index``/``return_inverse``/``return_counts``, to check for a
masked array: ~45 ms of every process, a tenth of a whole ``depixel convert``. Asking for
the indices takes the sorting path instead and returns the same values. numpy 2.4 copies
the rows of an (N, k) array one at a time under fancy-index assignment (``a[i] = b``), so
:func:`set_rows` writes them a column at a time. A reduction along a short last axis (a
minimum over each row of an (N, 7) array) runs one short inner loop a row, ~10x slower than
over the rows of its transposed copy: :func:`row_min`, :func:`row_count`, :func:`row_any`.
"""
from __future__ import annotations

from collections.abc import Iterable
from itertools import accumulate

import numpy as np


def unique(values: np.ndarray, axis: int | None = None) -> np.ndarray:
    """``np.unique(values, axis=axis)``: the distinct values (rows along ``axis``), sorted."""
    return np.unique(values, return_index=True, axis=axis)[0]


def sums_by_key(keys: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct ``keys`` (sorted) and the sum of the ``weights`` of each, added in the
    order given: ``np.unique(keys, return_inverse=True)`` then ``np.bincount`` of the
    inverse, the same sums, with a third of the numpy calls (a stable sort keeps each
    key's weights in order)."""
    order = keys.argsort(kind="stable")
    ranked = keys.take(order)
    first = np.empty(ranked.size, bool)
    first[:1] = True
    np.not_equal(ranked[1:], ranked[:-1], out=first[1:])
    group = first.cumsum()  # (from 1: the sums are bincount's bins from 1, no subtraction)
    return ranked.compress(first), np.bincount(group, weights=weights.take(order))[1:]


def in_sorted(sorted_keys: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """(len(keys),) bool: whether each of ``keys`` is among ``sorted_keys`` (sorted, 1-d): one
    binary search each, for integer keys packed from several numbers."""
    if sorted_keys.size == 0:
        return np.zeros(keys.shape, bool)
    # a key past the last one finds the last one ("clip"), which differs from it
    return sorted_keys.take(sorted_keys.searchsorted(keys), mode="clip") == keys


def nan_to_zero(values: np.ndarray) -> np.ndarray:
    """``np.nan_to_num(values)`` of an array without infinities (the missing control points
    of lines are NaN): a fifth of its cost (~45 µs a call on a sprite's segments, which
    also tests for both infinities)."""
    return np.where(np.isnan(values), 0.0, values)


def both(pairs: np.ndarray) -> np.ndarray:
    """(...,) bool: both tests of each pair ``pairs`` (..., 2) bool (C-contiguous), read as
    one 2-byte word (0x0101) instead of a reduction over an axis of two or two strided columns."""
    return pairs.view(np.uint16)[..., 0] == 0x0101


def either(pairs: np.ndarray) -> np.ndarray:
    """(...,) bool: either test of each pair ``pairs`` (..., 2) bool (C-contiguous), as :func:`both`."""
    return pairs.view(np.uint16)[..., 0] != 0


def set_rows(target: np.ndarray, rows: np.ndarray, values: np.ndarray) -> None:
    """``target[rows] = values`` for an (N, k) ``target``, a column at a time (the same
    result, several times faster than numpy's row-by-row copy)."""
    for column in range(target.shape[1]):
        target[rows, column] = values[:, column]


def row_min(values: np.ndarray) -> np.ndarray:
    """(N,) ``values.min(axis=1)`` of an (N, k) array, the same numbers (a minimum is exact in
    any order, NaN wins either way), reduced over the rows of the transposed copy."""
    return np.ascontiguousarray(values.T).min(axis=0)


def row_count(flags: np.ndarray) -> np.ndarray:
    """(N,) uint8 ``flags.sum(axis=1)`` of an (N, k) bool array with k < 256 (the True of each
    row), as :func:`row_min`, added as bytes (a sum cast to int64 runs buffered, ~4x slower)."""
    return np.add.reduce(np.ascontiguousarray(flags.T).view(np.uint8), axis=0, dtype=np.uint8)


def row_any(flags: np.ndarray) -> np.ndarray:
    """(N,) ``flags.any(axis=1)`` of an (N, k) bool array, as :func:`row_min`."""
    return np.asarray(np.ascontiguousarray(flags.T).any(axis=0))


def flat_rows(rows: np.ndarray, k: int) -> np.ndarray:
    """(len(rows) * k,) the flat indices of the elements of ``rows`` in a C-contiguous (N, k)
    array: ``a.put(flat_rows(rows, k), values)`` is ``set_rows(a, rows, values)`` in one
    call, for indices used again and again."""
    return (rows[:, None] * k + np.arange(k)).ravel()


def ranges(first: np.ndarray | int, count: np.ndarray) -> np.ndarray:
    """``first[i], first[i] + 1, …, first[i] + count[i] - 1`` for every ``i`` in turn (the
    counts ≥ 0): ``np.concatenate([np.arange(f, f + c) for f, c in zip(first, count)])`` in a
    few whole-array calls. ``first`` 0: each item's place within its own run."""
    end = count.cumsum()
    start = end - count
    return np.arange(int(end[-1]) if end.size else 0) - (start - first).repeat(count)


def batch_slices(n: int, batch: int) -> list[slice]:
    """Consecutive slices of ``n`` like items, ``batch`` at a time (the last one shorter): to
    bound the temporary memory of work done a batch at a time. No items, no slices."""
    return [slice(lo, lo + batch) for lo in range(0, n, batch)]


def consecutive_slices(sizes: Iterable[int]) -> list[slice]:
    """One slice for each of ``sizes``, end to end from 0: the parts of a table whose rows
    hold several pieces one after another."""
    ends = list(accumulate(sizes))
    return [slice(lo, hi) for lo, hi in zip([0] + ends[:-1], ends)]


def batch_bounds(sizes: np.ndarray, batch: int) -> list[tuple[int, int]]:
    """Consecutive slices ``[a, b)`` of items of the given ``sizes``, each holding about
    ``batch`` in all (an item larger than that alone): to bound the temporary memory of
    work done a batch of items at a time. No items, no slices."""
    total = sizes.cumsum()
    if total.size == 0:
        return []
    if int(total[-1]) <= batch:  # one batch (a sprite's): no search
        return [(0, int(total.size))]
    cuts = unique(np.concatenate(([0], total.searchsorted(np.arange(batch, int(total[-1]), batch)), [total.size])))
    return list(zip(cuts[:-1].tolist(), cuts[1:].tolist()))


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



def _jump_to_roots(parent: np.ndarray) -> np.ndarray:
    """Pointer jumping until every element points at a root (``parent[r] == r``)."""
    while True:
        grand = parent.take(parent)
        if not np.logical_or.reduce(grand != parent):  # (np.array_equal's checks cost more on a sprite)
            return parent
        parent = grand
