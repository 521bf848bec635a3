"""Stage 5 — paper §3.4 — the optimization of many images' curves in one pass (issue 44).

A relaxation round is some hundred numpy calls whatever the number of slots, ten rounds an
image: on a sprite that fixed cost is most of the stage. :func:`optimize_many` relaxes the
curves of several images side by side, their flat arrays joined into one
:class:`~depixel.curves.splines.SplineSet` (:func:`join`: slots, curves and nodes renumbered),
so each round's calls are paid once for all of them; the harmonic map and the walk-back then
run per image (:func:`depixel.optimize.stage.finish`).

Every image gets the very numbers it would get alone: each keeps its own coordinates (float
arithmetic is not translation-exact, so no image is moved to an offset), a slot's work reads
only slots of its own curves and its own protected points (given per slot, found in each
image's own cell graph), every reduction that decides something is per slot or per image
(:func:`depixel.optimize.relax.relax_rounds`' ``parts``: an image whose rounds would have
stopped sits the later rounds out; :meth:`depixel.optimize.energy.Energy.totals`), and the
record of the moves is cut back into each image's rounds.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from ..curves.pairing import HalfEnds
from ..curves.splines import SplineSet
from ..graph.cells import INDEX, CellGraph
from ..params import Params
from .corners import Corners
from .fidelity import Moves, protected_points
from .relax import Relaxed, relax_rounds
from .stage import OptimizedSplines, finish, relaxation_inputs


def optimize_many(items: Sequence[tuple[SplineSet, Corners]], params: Params = Params()) -> list[OptimizedSplines]:
    """:func:`depixel.optimize.stage.optimize_splines` of each ``(splines, corners)``, the
    relaxations in one pass; the same results as one at a time."""
    if len(items) == 1:
        from .stage import optimize_splines  # noqa: PLC0415 (alone: nothing to join)

        return [optimize_splines(*items[0], params)]
    curves = [splines for splines, _ in items]
    starts, fixed, excluded = zip(*(relaxation_inputs(splines, corners, params) for splines, corners in items))
    joined, slots, nodes = join(curves)
    model, anchor, done = relax_rounds(joined, np.concatenate(starts), np.concatenate(fixed), np.concatenate(excluded),
                                       params, slots, np.concatenate([protected_points(splines) for splines in curves]))
    before, after = model.totals(anchor, anchor, slots), model.totals(done.ctrl, anchor, slots)
    del model, anchor
    out = []
    for i, (splines, corners) in enumerate(items):
        lo, hi = int(nodes[i]), int(nodes[i + 1])
        rounds = []
        for moves in done.rounds:  # the image's own moves of each round it moved in
            mine = ((moves.nodes >= lo) & (moves.nodes < hi)).nonzero()[0]
            if mine.size:
                rounds.append(Moves(moves.nodes.take(mine) - lo, moves.before.take(mine, axis=0)))
        part = slice(int(slots[i]), int(slots[i + 1]))
        relaxed = Relaxed(done.ctrl[part].copy(), done.movable[part].copy(), before[i], after[i], rounds)
        out.append(finish(splines, corners, starts[i], relaxed, params))
    return out


def join(curves: Sequence[SplineSet]) -> tuple[SplineSet, np.ndarray, np.ndarray]:
    """The curves of several SplineSets as one, each in its own coordinates, and the (S+1,)
    bounds of each one's slots and nodes in it. The result has no cell graph (its ``cells``
    is None: a stand-in, so that anything reading it fails loudly) and no pairing: only the
    curves, their nodes and their edges' numbers, which is what the relaxation reads."""
    slots = np.cumsum([0] + [s.n_slots for s in curves])
    nodes = np.cumsum([0] + [len(s.positions) for s in curves])
    edges = np.cumsum([0] + [s.visible.size for s in curves])
    ptr = np.concatenate([s.curve_ptr[:-1] + slots[i] for i, s in enumerate(curves)] + [slots[-1:]]).astype(INDEX)
    none = np.zeros(0, INDEX)
    joined = SplineSet(
        cells=cast(CellGraph, None),
        visible=np.concatenate([s.visible for s in curves]),
        shading=np.concatenate([s.shading for s in curves]),
        curve_ptr=ptr,
        curve_nodes=np.concatenate([s.curve_nodes + nodes[i] for i, s in enumerate(curves)]).astype(INDEX),
        curve_closed=np.concatenate([s.curve_closed for s in curves]),
        slot_edges=np.concatenate([np.where(s.slot_edges >= 0, s.slot_edges + edges[i], -1)
                                   for i, s in enumerate(curves)]).astype(INDEX),
        slot_forward=np.concatenate([s.slot_forward for s in curves]),
        positions=np.concatenate([s.positions for s in curves]),
        half_ends=HalfEnds(none, none, none),
        snap_passes=curves[0].snap_passes)
    return joined, slots, nodes
