"""The relaxation's random numbers (depixel/optimize/splitmix.py): SplitMix64, continued across calls,
spread evenly, and a fair shuffle."""
from __future__ import annotations

import numpy as np

from depixel.optimize.splitmix import SplitMix64

#: the first draws of SplitMix64 seeded with 1234567, as published with the generator's
#: reference C code (Vigna, prng.di.unimi.it) and on Rosetta Code
PUBLISHED = [6457827717110365317, 3203168211198807973, 9817491932198370423,
             4593380528125082431, 16408922859458223821]


def test_draws_are_splitmix64_and_continue_across_calls():
    stream = SplitMix64(1234567)
    assert stream.bits(3).tolist() + stream.bits(2).tolist() == PUBLISHED


def test_the_same_seed_gives_the_same_numbers_and_another_seed_others():
    assert np.array_equal(SplitMix64(7).unit_pairs(100), SplitMix64(7).unit_pairs(100))
    assert not np.array_equal(SplitMix64(7).unit_pairs(100), SplitMix64(8).unit_pairs(100))


def test_unit_pairs_spread_evenly_over_the_unit_interval():
    pairs = SplitMix64(0).unit_pairs(100_000)
    assert pairs.min() >= 0.0 and pairs.max() < 1.0
    for column in pairs.T:
        counts, _ = np.histogram(column, bins=20, range=(0.0, 1.0))
        assert np.all(np.abs(counts - 5000) < 300), counts  # ~4 standard deviations
    assert abs(np.corrcoef(pairs.T)[0, 1]) < 0.01  # the two halves of a draw are independent


def test_permutation_is_a_fair_shuffle():
    stream = SplitMix64(1)
    first = np.array([stream.permutation(5)[0] for _ in range(5000)])
    assert all(sorted(stream.permutation(n).tolist()) == list(range(n)) for n in (0, 1, 2, 9))
    counts = np.bincount(first, minlength=5)
    assert np.all(np.abs(counts - 1000) < 120), counts
