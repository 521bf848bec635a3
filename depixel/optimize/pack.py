"""Stage 5 — paper §3.4 — the optimization of many images' curves in one pass (issue 44).

A relaxation round is some hundred numpy calls whatever the number of slots, ten rounds an
image: on a sprite that fixed cost is most of the stage. :func:`optimize_many` relaxes the
curves of several images side by side, their flat arrays joined into one
:class:`~depixel.curves.splines.SplineSet` (:func:`join`: slots, curves and nodes renumbered),
so each round's calls are paid once for all of them; the harmonic map and the walk-back then
run on them joined too, their cells joined (:mod:`depixel.optimize.joined`), each image's
linear system solved as its own part and each image walking back its own rounds
(:func:`depixel.optimize.stage.settle`).

Every image gets the very numbers it would get alone: each keeps its own coordinates (float
arithmetic is not translation-exact, so no image is moved to an offset), a slot's work reads
only slots of its own curves and its own protected points (given per slot, found in each
image's own cell graph), every reduction that decides something is per slot or per image
(:func:`depixel.optimize.relax.relax_rounds`' ``parts``: an image whose rounds would have
stopped sits the later rounds out; :meth:`depixel.optimize.energy.Energy.totals`), and each
image walks back its own rounds of the record of the moves.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from ..curves.drawing import Drawing
from ..curves.pairing import HalfEnds
from ..curves.splines import SplineSet
from ..graph.cells import INDEX, CellGraph
from ..params import Params
from .corners import Corners
from .fidelity import protected_points
from .joined import JoinedCells, join_cells
from .relax import relax_rounds
from .stage import OptimizedSplines, relaxation_inputs, settle
from .walkback import History


def optimize_many(items: Sequence[tuple[SplineSet, Corners]], params: Params = Params()) -> list[OptimizedSplines]:
    """:func:`depixel.optimize.stage.optimize_splines` of each ``(splines, corners)``, the
    relaxations in one pass; the same results as one at a time."""
    if len(items) == 1:
        from .stage import optimize_splines  # noqa: PLC0415 (alone: nothing to join)

        return [optimize_splines(*items[0], params)]
    curves = [splines for splines, _ in items]
    # per image: a T-junction on a straight side is found by its nodes' places
    # (optimize/straight.py), which the images' joined curves share
    starts, fixed, excluded = zip(*(relaxation_inputs(splines, corners, params) for splines, corners in items))
    cells = join_cells([splines.cells for splines in curves])
    joined, slots, nodes = join(curves, cells)
    start = np.concatenate(starts)
    model, anchor, done = relax_rounds(joined, start, np.concatenate(fixed), np.concatenate(excluded),
                                       params, slots, np.concatenate([protected_points(splines) for splines in curves]))
    before, after = model.totals(anchor, anchor, slots), model.totals(done.ctrl, anchor, slots)
    del model, anchor
    history = History.joined(done.rounds, nodes)
    positions, drawing = settle(joined, start, done.ctrl, done.movable,
                                np.concatenate([corners.nodes for _, corners in items]), history, params)
    # each image's drawing: its nodes', its slots' and its curved edges' rows (the curved
    # edges in slot order, so each image's one after another)
    of_edge = cells.edge_bounds.searchsorted(drawing.edges, side="right") - 1
    curved = of_edge.searchsorted(np.arange(len(items) + 1))
    out = []
    for i, (splines, corners) in enumerate(items):
        rows, part, edges = slice(int(nodes[i]), int(nodes[i + 1])), slice(int(slots[i]), int(slots[i + 1])), \
            slice(int(curved[i]), int(curved[i + 1]))
        ctrl = None if drawing.ctrl is None else drawing.ctrl[part].copy()
        mine = Drawing(drawing.points[rows].copy(), drawing.edges[edges] - int(cells.edge_bounds[i]),
                       drawing.controls[edges].copy(), ctrl)
        out.append(OptimizedSplines(splines, corners, starts[i], positions[rows].copy(), before[i], after[i], mine))
    return out


def join(curves: Sequence[SplineSet], cells: JoinedCells) -> tuple[SplineSet, np.ndarray, np.ndarray]:
    """The curves of several SplineSets as one, each in its own coordinates, and the (S+1,)
    bounds of each one's slots and nodes in it. Its cells are their ``cells`` joined (what the
    harmonic map and the walk-back read; anything else reading them fails loudly) and it has
    no pairing: only the curves, their nodes and their edges' numbers, which is what the
    relaxation reads."""
    slots = np.cumsum([0] + [s.n_slots for s in curves])
    nodes = np.cumsum([0] + [len(s.positions) for s in curves])
    edges = np.cumsum([0] + [s.visible.size for s in curves])
    ptr = np.concatenate([s.curve_ptr[:-1] + slots[i] for i, s in enumerate(curves)] + [slots[-1:]]).astype(INDEX)
    none = np.zeros(0, INDEX)
    joined = SplineSet(
        cells=cast(CellGraph, cells),
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
