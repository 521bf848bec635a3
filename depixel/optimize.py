"""Stage 5 — paper §3.4 — splines cut at their corners → optimized splines (the default output).

:func:`optimize_splines` is the driver; each step is its own module:

1. corners (:mod:`depixel.corners`, found before the curves are cut at them in
   :func:`depixel.depixelize`): right-angle corners go back onto their lattice points;
2. relaxation (:mod:`depixel.relax`): the curve control points move to lower E_s + E_p,
   each move guarded so that curves keep clear of pixel centres (:mod:`depixel.fidelity`);
3. harmonic map (:mod:`depixel.harmonic`): the nodes off the curves follow them;
4. fidelity (:mod:`depixel.fidelity`): nodes around any cell whose centre came too near its
   boundary are put back.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .corners import Corners, excluded_halves
from .fidelity import keep_centres_inside
from .frozen import freeze
from .harmonic import harmonic_map
from .params import Params
from .relax import relax
from .splines import SplineSet
from .vector import VectorImage


@dataclass(frozen=True, eq=False)
class OptimizedSplines:
    """The curves (cut at the corners) and their optimized node positions (pixel units);
    arrays are read-only."""

    splines: SplineSet  # the curves optimized: Result.splines cut at the corners
    corners: Corners  # the corner nodes, kept sharp and fixed
    initial: np.ndarray  # (N, 2) positions before relaxation (right-angle corners already placed)
    positions: np.ndarray  # (N, 2) final positions: relaxed curve nodes, harmonic others
    energy_before: float  # total E_s + E_p before relaxation
    energy_after: float  # and after

    def __post_init__(self) -> None:
        freeze(self)

    def vector_image(self) -> VectorImage:
        return self.splines.vector_image(self.positions, stage="optimized")


def optimize_splines(splines: SplineSet, corners: Corners, params: Params = Params()) -> OptimizedSplines:
    """§3.4 on curves already cut at ``corners``: relax the curve nodes, then move the
    other nodes by a harmonic map, then undo moves that pushed a pixel centre out."""
    start = corners.place(splines)
    relaxed = relax(splines, start, corners.nodes, excluded_halves(splines, corners.nodes), params)
    positions = start.copy()
    positions[splines.curve_nodes[relaxed.movable]] = relaxed.ctrl[relaxed.movable]
    energy_before, energy_after = relaxed.energy_before, relaxed.energy_after
    del relaxed  # the control points live on in the positions; free them for the steps below
    positions = harmonic_map(splines, start, positions, corners.nodes, params.harmonic_reach)
    positions = keep_centres_inside(splines, start, positions, params.centre_clearance / 2, params.revert_rounds)
    return OptimizedSplines(splines, corners, start, positions, energy_before, energy_after)
