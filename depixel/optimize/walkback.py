"""The walk-back of :func:`depixel.optimize.fidelity.keep_centres_inside`: the relaxation's
record of moves as tables, and a node's way back one round at a time.

The record is an image's rounds (:class:`Moves`, a round each), or several images' records
side by side (:meth:`History.joined`, a pass of :mod:`depixel.optimize.pack`): each image's
nodes count their own rounds, the rounds it moved in, as they do alone.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ..arrays import set_rows, unique


class Moves(NamedTuple):
    """What one round of the relaxation moved: the nodes and their places before it (the
    record :func:`depixel.optimize.fidelity.keep_centres_inside` walks back)."""

    nodes: np.ndarray  # (K,) nodes of the slots that moved
    before: np.ndarray  # (K, 2) their positions before the round


class History:
    """The relaxation's record of moves (:class:`Moves`, a round each) as tables over the nodes
    that moved: where each sat before each round it moved in, and the latest round up to
    each round in which it moved, so that :func:`walk_back` finds a node's place in a few
    calls whatever the number of rounds. ``rounds``: the rounds of the record (of each
    node's image, (N,), when joined)."""

    def __init__(self, moves: Sequence[Moves]) -> None:
        self._tables([m.nodes for m in moves], [m.before for m in moves], np.arange(len(moves)), len(moves))
        self.rounds: int | np.ndarray = len(moves)

    @classmethod
    def joined(cls, moves: Sequence[Moves], node_bounds: np.ndarray) -> History:
        """The record ``moves`` of the curves of several images relaxed together, their nodes
        numbered one image after the other (image i's from ``node_bounds[i]``, (S+1,)): each
        image counts its own rounds, those it moved in, as it does alone."""
        self = cls.__new__(cls)
        images = node_bounds.size - 1
        sizes = [m.nodes.size for m in moves]
        nodes = np.concatenate([m.nodes for m in moves]) if moves else np.zeros(0, np.int64)
        image = node_bounds.searchsorted(nodes, side="right") - 1
        # each entry's round among its image's rounds (those it moved in)
        global_round = np.arange(len(moves)).repeat(sizes)
        present = np.zeros((len(moves), images), bool)
        present[global_round, image] = True
        counts = present.sum(axis=0)
        local = (present.cumsum(axis=0) - 1).ravel().take(global_round * images + image)
        self._tables([nodes], [m.before for m in moves], local, int(counts.max(initial=0)), entries=True)
        self.rounds = counts.repeat(np.diff(node_bounds))
        return self

    def _tables(self, nodes_of: list[np.ndarray], before_of: list[np.ndarray], round_of: np.ndarray,
                rounds: int, entries: bool = False) -> None:
        """The tables of ``rounds`` rounds from the records ``nodes_of`` and ``before_of``, a
        round each, ``round_of`` their rounds (with ``entries``: one record, ``round_of`` the
        round of each of its entries)."""
        nodes = np.concatenate(nodes_of) if nodes_of else np.zeros(0, np.int64)
        self.movers = unique(nodes)  # sorted
        self.before = np.concatenate(before_of) if before_of else np.zeros((0, 2))
        # (R, U) the row of each mover in the concatenated record of each round, -1 where it
        # did not move (a node twice in a round, which the relaxation never records: the
        # last, as a plain assignment keeps it)
        self.row = np.full((rounds, self.movers.size), -1, np.int64)
        which = round_of if entries else round_of.repeat([n.size for n in nodes_of])
        self.row[which, self.movers.searchsorted(nodes)] = np.arange(nodes.size)
        # (R, U) the latest round up to each round in which the mover moved (-1: none)
        latest = np.where(self.row >= 0, np.arange(rounds)[:, None], -1)
        self.latest = np.maximum.accumulate(latest, axis=0) if rounds else latest

    def rounds_of(self, nodes: np.ndarray) -> int | np.ndarray:
        """The rounds of the record of ``nodes``' images (one, or (K,))."""
        return self.rounds if isinstance(self.rounds, int) else self.rounds.take(nodes)


def walk_back(positions: np.ndarray, start: np.ndarray, nodes: np.ndarray, back: np.ndarray,
              history: History) -> None:
    """Put each of the curve ``nodes`` where it was before the latest round of the
    relaxation (``history``) it moved in and has not gone back past yet (``back`` counts each
    node's rounds gone back; in place); one that moved in none of them, at ``start``. A node
    k rounds back sits where it was after round R − k; the rounds it did not move in are
    passed over, so a node found next to a bad cell always goes somewhere else (or is at its
    start already)."""
    rounds, movers = history.rounds_of(nodes), history.movers
    level = back.take(nodes)
    at = np.minimum(movers.searchsorted(nodes), max(movers.size - 1, 0))  # the node among the movers
    limit = rounds - 1 - level  # the latest round it may go back to the place before
    round_ = np.full(nodes.size, -1, np.int64)
    ok = (limit >= 0) & (movers.take(at, mode="clip") == nodes) if movers.size else np.zeros(nodes.size, bool)
    if ok.any():
        round_[ok] = history.latest.ravel().take(limit.compress(ok) * movers.size + at.compress(ok))
    found = round_ >= 0
    gone = nodes.compress(~found)  # to its start (rounds gone back: all of them)
    set_rows(positions, gone, start.take(gone, axis=0))
    back[gone] = np.maximum(level.compress(~found), _of(rounds, ~found))
    if found.any():
        round_, at = round_.compress(found), at.compress(found)
        row = history.row.ravel().take(round_ * movers.size + at)
        set_rows(positions, nodes.compress(found), history.before.take(row, axis=0))
        back[nodes.compress(found)] = _of(rounds, found) - round_


def _of(rounds: int | np.ndarray, which: np.ndarray) -> int | np.ndarray:
    """The rounds of the nodes ``which`` picks: all the same (one), or their own."""
    return rounds if isinstance(rounds, int) else rounds.compress(which)
