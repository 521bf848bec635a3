"""The walk-back of the fidelity guard (depixel/optimize/fidelity.py): a node next to a bad cell
goes back to where it was before the latest relaxation round it moved in and has not gone
back past yet, else to its start."""
from __future__ import annotations

import numpy as np
import pytest

from depixel.optimize.walkback import History, Moves, walk_back


def _reference(positions, start, nodes, back, moves) -> None:
    """The walk-back written node by node, round by round."""
    rounds = len(moves)
    for node in nodes:
        level = back[node]
        while True:
            if level >= rounds:
                positions[node] = start[node]
                back[node] = level
                break
            undo = moves[rounds - 1 - level]
            rows = (undo.nodes == node).nonzero()[0]
            level += 1
            if rows.size:
                positions[node] = undo.before[rows[-1]]
                back[node] = level
                break


@pytest.mark.parametrize("seed", range(20))
def test_nodes_go_back_to_the_place_before_their_latest_round_not_gone_back_past(seed):
    rng = np.random.default_rng(seed)
    n, rounds = 30, int(rng.integers(0, 6))
    moves = []
    for _ in range(rounds):
        nodes = rng.choice(n, size=int(rng.integers(0, 12)), replace=False).astype(np.int32)
        moves.append(Moves(nodes, rng.random((nodes.size, 2))))
    start, here = rng.random((n, 2)), rng.random((n, 2))
    back = rng.integers(0, rounds + 2, n).astype(np.int64)
    nodes = np.sort(rng.choice(n, size=int(rng.integers(1, n)), replace=False))
    expected, expected_back = here.copy(), back.copy()
    _reference(expected, start, nodes, expected_back, moves)
    walk_back(here, start, nodes, back, History(moves))
    assert np.array_equal(here, expected) and np.array_equal(back, expected_back)
