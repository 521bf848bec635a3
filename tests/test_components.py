"""The numpy graph kernels against scipy and a plain walk."""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from depixel.graph.components import component_roots, cycle_leaders


def test_component_roots_match_scipy():
    rng = np.random.default_rng(3)
    for _ in range(100):
        n = int(rng.integers(1, 200))
        m = int(rng.integers(0, 2 * n))
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        _, label = connected_components(coo_matrix((np.ones(m), (a, b)), shape=(n, n)), directed=False)
        smallest = np.full(label.max() + 1, n)
        np.minimum.at(smallest, label, np.arange(n))
        assert np.array_equal(component_roots(n, a, b), smallest[label])


def test_component_roots_of_a_long_path_with_shuffled_ids():
    n = 5000
    ids = np.random.default_rng(0).permutation(n)
    root = component_roots(n, ids[:-1], ids[1:])
    assert np.array_equal(root, np.zeros(n))


def test_cycle_leaders_match_a_walk():
    rng = np.random.default_rng(4)
    for _ in range(50):
        nxt = rng.permutation(int(rng.integers(1, 120)))
        leader, position = cycle_leaders(nxt)
        for i in range(nxt.size):
            cycle, j = [i], nxt[i]
            while j != i:
                cycle.append(j)
                j = nxt[j]
            smallest = min(cycle)
            steps, j = 0, smallest
            while j != i:
                j, steps = nxt[j], steps + 1
            assert (leader[i], position[i]) == (smallest, steps)
