"""Stage 5 — paper §3.4 — splines cut at their corners → optimized splines (the default output).

:func:`optimize_splines` is the driver; each step is its own module:

1. corners (:mod:`depixel.optimize.corners`, found before the curves are cut at them in
   :func:`depixel.depixelize`): right-angle corners go back onto their lattice points; the
   nodes of constant-slope staircases start on their line and those of long straight runs
   stay where they are (:mod:`depixel.optimize.straight`);
2. relaxation (:mod:`depixel.optimize.relax`): the curve control points move to lower E_s + E_p,
   each move guarded so that curves keep clear of pixel centres (:mod:`depixel.optimize.fidelity`);
3. harmonic map (:mod:`depixel.optimize.harmonic`): the nodes off the curves follow them;
4. fidelity (:mod:`depixel.optimize.fidelity`): nodes around any cell whose centre came too near its
   boundary are walked back, a relaxation round at a time.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..arrays import flat_rows, set_rows
from ..curves.drawing import Drawing
from ..curves.splines import SplineSet
from ..frozen import compact_repr, freeze
from ..params import Params
from ..vector import VectorImage
from .corners import Corners, excluded_halves
from .fidelity import keep_centres_inside
from .harmonic import follow, harmonic_map
from .relax import Relaxed, relax
from .straight import place_staircases, straight_runs
from .walkback import History, Moves


@dataclass(frozen=True, eq=False)
class OptimizedSplines:
    """The curves (cut at the corners) and their optimized node positions (pixel units);
    arrays are read-only."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    splines: SplineSet  # the curves optimized: Result.splines cut at the corners
    corners: Corners  # the corner nodes, kept sharp and fixed
    initial: np.ndarray  # (N, 2) positions before relaxation (right-angle corners already placed)
    positions: np.ndarray  # (N, 2) final positions: relaxed curve nodes, harmonic others
    energy_before: float  # total E_s + E_p before relaxation
    energy_after: float  # and after
    drawing: Drawing  # the curves drawn with the final positions (the output's geometry)

    def __post_init__(self) -> None:
        freeze(self)

    def vector_image(self) -> VectorImage:
        """The output: :attr:`drawing` with every edge's controls (zero where straight), as
        ``splines.vector_image(positions)`` would draw it again."""
        cells = self.splines.cells
        n_edges = len(cells.edges)
        curved = np.zeros(n_edges, dtype=bool)
        curved[self.drawing.edges] = True
        controls = np.zeros(n_edges * 6, dtype=np.float64)  # (E, 3, 2) written flat, six numbers an edge
        controls[flat_rows(self.drawing.edges, 6)] = self.drawing.controls.reshape(-1)
        # the drawing's control points are those of the positions (the harmonic map moves no curve node)
        ctrl = self.splines.controls_for(self.positions) if self.drawing.ctrl is None else self.drawing.ctrl
        return VectorImage(cells, self.drawing.points, curved, controls.reshape(n_edges, 3, 2), "optimized",
                           self.splines.curve_table(ctrl, curved))


def optimize_splines(splines: SplineSet, corners: Corners, params: Params = Params()) -> OptimizedSplines:
    """§3.4 on curves already cut at ``corners``: place the corners and the staircases of
    constant slope, relax the curve nodes (all but the corners and the straight runs),
    then move the other nodes by a harmonic map, then walk back moves that pushed a pixel
    centre out."""
    start, fixed, excluded = relaxation_inputs(splines, corners, params)
    return finish(splines, corners, start, relax(splines, start, fixed, excluded, params), params)


def relaxation_inputs(splines: SplineSet, corners: Corners, params: Params = Params()
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the relaxation starts from: the node positions with the corners and the
    staircases placed (N, 2), the nodes it keeps fixed (N,) (the corners and the straight
    runs) and the span halves left out of E_s (P, 2)."""
    start = place_staircases(splines, corners.place(splines), params)
    return start, corners.nodes | straight_runs(splines, params), excluded_halves(splines, corners.nodes)


def finish(splines: SplineSet, corners: Corners, start: np.ndarray, relaxed: Relaxed,
           params: Params = Params()) -> OptimizedSplines:
    """:func:`optimize_splines` after the relaxation (``relaxed``, from the node positions
    ``start``): the harmonic map and the walk-back (:func:`settle`)."""
    positions, drawing = settle(splines, start, relaxed.ctrl, relaxed.movable, corners.nodes, relaxed.rounds, params)
    return OptimizedSplines(splines, corners, start, positions, relaxed.energy_before, relaxed.energy_after, drawing)


def settle(splines: SplineSet, start: np.ndarray, ctrl: np.ndarray, movable: np.ndarray, corners: np.ndarray,
           moves: Sequence[Moves] | History, params: Params = Params()) -> tuple[np.ndarray, Drawing]:
    """The final positions and their drawing from the relaxed control points ``ctrl`` of the
    ``movable`` slots and the node positions ``start``: the harmonic map moves the other
    nodes, the walk-back takes back the moves (``moves``, the relaxation's record) that
    pushed a pixel centre out. Also of several images' curves joined
    (:mod:`depixel.optimize.pack`: ``splines`` over :class:`~depixel.optimize.joined.JoinedCells`,
    ``moves`` their joined :class:`~depixel.optimize.walkback.History`)."""
    positions = start.copy()
    set_rows(positions, splines.curve_nodes.compress(movable), ctrl.compress(movable, axis=0))
    # the relaxed curves are drawn once: the harmonic map needs their display points, the
    # revert's first round the whole drawing (the harmonic map moves no curve node); the
    # revert's initial drawing is drawn with them (one pass for both on a sprite)
    drawing, initial = splines.drawings(positions, start)
    mapped = harmonic_map(splines, start, positions, corners, params.harmonic_reach, drawing.points)
    drawing = drawing._replace(points=follow(drawing.points, positions, mapped))
    return keep_centres_inside(splines, start, mapped, params.centre_clearance / 2, params.revert_rounds, drawing,
                               initial, moves)
