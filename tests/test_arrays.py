"""depixel/arrays.py: set operations without numpy.ma, sorted-key lookups, row writes, batches."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from depixel.arrays import (
    batch_bounds,
    batch_slices,
    both,
    consecutive_slices,
    either,
    flat_rows,
    in_sorted,
    nan_to_zero,
    ranges,
    set_rows,
    sums_by_key,
    unique,
)


@given(st.lists(st.integers(0, 50), max_size=60), st.integers(1, 120))
def test_batches_cover_every_item_once_in_order_and_stay_within_the_batch(sizes, batch):
    bounds = batch_bounds(np.array(sizes, dtype=np.int64), batch)
    assert [i for a, b in bounds for i in range(a, b)] == list(range(len(sizes)))
    assert all(b > a for a, b in bounds)
    for a, b in bounds:
        assert b - a == 1 or sum(sizes[a:b]) <= batch + max(sizes[a:b])


@given(st.integers(0, 300), st.integers(1, 120))
def test_slices_cover_every_item_once_in_order_in_full_batches(n, batch):
    parts = batch_slices(n, batch)
    assert [i for part in parts for i in range(n)[part]] == list(range(n))
    assert all(len(range(n)[part]) == batch for part in parts[:-1])


@given(st.lists(st.integers(0, 9), max_size=20))
def test_consecutive_slices_cut_a_table_into_its_pieces_in_order(sizes):
    table = [i for i, size in enumerate(sizes) for _ in range(size)]  # piece i: size rows of i
    parts = consecutive_slices(sizes)
    assert [table[part] for part in parts] == [[i] * size for i, size in enumerate(sizes)]


def test_unique_is_numpys():
    a = np.array([3, 1, 3, 2])
    assert unique(a).tolist() == np.unique(a).tolist()
    rows = np.array([[1, 2], [0, 5], [1, 2]])
    assert unique(rows, axis=0).tolist() == [[0, 5], [1, 2]]


def test_in_sorted_finds_exactly_the_keys_present_and_takes_an_empty_table():
    table = np.array([2, 5, 9, 40], np.int64)
    keys = np.array([0, 2, 3, 9, 40, 41, 5], np.int64)
    assert in_sorted(table, keys).tolist() == [False, True, False, True, True, False, True]
    assert in_sorted(np.zeros(0, np.int64), keys).tolist() == [False] * keys.size


@pytest.mark.parametrize("write", [set_rows, lambda target, rows, values: target.put(flat_rows(rows, target.shape[1]),
                                                                                     values)],
                         ids=["set_rows", "put at flat_rows"])
@pytest.mark.parametrize("k", [2, 3])
def test_row_writes_write_the_rows_given_as_fancy_assignment_would(write, k):
    rng = np.random.default_rng(k)
    target = rng.random((30, k))
    rows = np.array([4, 0, 29, 17, 9])
    values = rng.random((rows.size, k))
    expected = target.copy()
    expected[rows] = values
    write(target, rows, values)
    assert np.array_equal(target, expected)


@given(st.lists(st.tuples(st.integers(-20, 20), st.integers(0, 6)), max_size=30))
def test_ranges_are_the_aranges_of_each_item_in_turn(items):
    first = np.array([f for f, _ in items], np.int64)
    count = np.array([c for _, c in items], np.int64)
    expected = [v for f, c in items for v in range(f, f + c)]
    assert ranges(first, count).tolist() == expected
    assert ranges(0, count).tolist() == [v for _, c in items for v in range(c)]


@given(st.lists(st.integers(-5, 5), max_size=60), st.integers(0, 2**31))
def test_sums_by_key_are_uniques_keys_and_bincounts_sums_to_the_bit(keys, seed):
    keys = np.array(keys, np.int64)
    weights = np.random.default_rng(seed).normal(size=keys.size) * 10.0 ** np.arange(keys.size) % 7
    distinct, sums = sums_by_key(keys, weights)
    expected, inverse = np.unique(keys, return_inverse=True)
    assert np.array_equal(distinct, expected)
    assert sums.tobytes() == np.bincount(inverse, weights=weights, minlength=expected.size).tobytes()
    assert flat_rows(np.array([], dtype=np.int64), 2).size == 0


@given(st.lists(st.one_of(st.floats(allow_infinity=False), st.just(-0.0)), max_size=40))
def test_nan_to_zero_is_nan_to_num_without_infinities(values):
    array = np.array(values, dtype=np.float64).reshape(-1, 1)
    got, expected = nan_to_zero(array), np.nan_to_num(array)
    assert got.shape == expected.shape and got.tobytes() == expected.tobytes()  # -0.0 stays -0.0


@pytest.mark.parametrize("shape", [(0, 2), (7, 2), (3, 5, 2)])
def test_both_and_either_read_a_pair_of_tests_as_the_reductions_do(shape):
    pairs = np.random.default_rng(1).integers(0, 2, shape).astype(bool)
    assert np.array_equal(both(pairs), pairs.all(axis=-1))
    assert np.array_equal(either(pairs), pairs.any(axis=-1))
