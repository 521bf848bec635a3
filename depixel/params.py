"""The tuning parameters of the pipeline, named as in the paper.

Every constant carries its source: "paper" (Kopf & Lischinski 2011, with the section),
"hqx" (the YUV test the paper borrows), or "not in paper" with the reason it was chosen.
"""
from __future__ import annotations

from dataclasses import InitVar, dataclass, fields, replace
from typing import Any, NamedTuple


class Range(NamedTuple):
    """The values a numeric field accepts: finite, within [low, high], whole when ``integer``."""

    low: float | None = 0.0
    high: float | None = None
    integer: bool = False


#: The range of every numeric field (a field not listed is not checked; booleans must be bool),
#: one a line. Every field has an upper bound (docs/limits.md lists them): the fields that
#: size work or memory are bounded where the largest value still costs little more than the
#: default (tests/test_limits.py converts a small image with each at its bound under a memory
#: limit), the others where a larger value changes nothing (a threshold above any difference of
#: two colours) or only gives numbers that overflow.
LIMITS: dict[str, Range] = {
    "threshold_y": Range(0, 1_000),  # YUV differences on the 0-255 scale are at most ~315
    "threshold_u": Range(0, 1_000),
    "threshold_v": Range(0, 1_000),
    "threshold_alpha": Range(0, 1_000),
    "curve_weight": Range(0, 1_000),  # votes: 1000 times another heuristic's outvotes it anyway
    "sparse_weight": Range(0, 1_000),
    "sparse_window": Range(2, 64, integer=True),  # a window of side N costs N² per crossing
    "island_weight": Range(0, 1_000),
    "shading_distance": Range(0, 1_000),  # a YUV distance on the 0-255 scale is at most ~450
    "snap_passes": Range(1, 100, integer=True),
    "run_tolerance": Range(0, 4),  # pixels
    "run_long": Range(0, 64),  # pixels: no run is followed further (run_reach)
    "run_short": Range(0, 64),
    "run_turn": Range(0, 180),  # degrees
    "run_bend": Range(0, 180),
    "run_reach": Range(0, 64),  # a run is followed ~3 steps a pixel, each step weighing all before it
    "iterations": Range(0, 10_000, integer=True),
    "radius": Range(0, 4),  # pixels: as far as max_offset lets a node go
    "max_offset": Range(0, 4),  # pixels: past every neighbour of a node's cell
    "centre_clearance": Range(0, 1),  # pixels: a whole pixel from every centre leaves no room to move
    "harmonic_reach": Range(0, 1_000, integer=True),
    "revert_rounds": Range(0, 1_000, integer=True),
    "shading_sigma": Range(1e-6, 16),  # pixels
    "shading_radius": Range(1e-6, 16),  # pixels: the render pads the image by it and weighs ~3 r² cells a sample
    "shading_supersample": Range(1, 16, integer=True),  # samples² per contour pixel
}


#: the fields gone, and why: asked for, they raise a ParameterError saying so
REMOVED = {
    "seed": "no longer does anything: the relaxation tries the same places for every slot, with no random draws "
            "(issue 31)",
    "candidates": "no longer does anything: every slot tries the same pattern of places (issue 31)",
}


@dataclass(frozen=True)
class Params:
    """Constants of the depixelization pipeline (all colour values on a 0-255 scale).

    Only what changes the result lives here (the geometry, and the smooth shading of PNG
    output); output settings (SVG precision, scale) are arguments of the writers, and the
    last stage to run is an argument of :func:`depixel.depixelize`."""

    # --- §3.2 similarity graph -------------------------------------------------------------
    threshold_y: float = 48.0  # paper §3.2 / hqx: dissimilar when |ΔY| > 48/255 [0, 1000]
    threshold_u: float = 7.0  # paper §3.2 / hqx: dissimilar when |ΔU| > 7/255 [0, 1000]
    threshold_v: float = 6.0  # paper §3.2 / hqx: dissimilar when |ΔV| > 6/255 [0, 1000]
    # not in paper: two visible pixels whose alpha differs by more are dissimilar [0, 1000]
    threshold_alpha: float = 48.0

    # --- §3.2 crossing resolution heuristics ----------------------------------------------
    curve_weight: float = 1.0  # paper §3.2 "curves": vote = difference of curve lengths (× this factor) [0, 1000]
    sparse_weight: float = 1.0  # paper §3.2 "sparse pixels": vote = difference of component sizes (× this) [0, 1000]
    sparse_window: int = 8  # paper §3.2: component sizes are measured in an 8×8 window around the block [2, 64]
    island_weight: float = 5.0  # paper §3.2 "islands": fixed vote, empirically 5 [0, 1000]
    tie_break: bool = True  # not in paper: a tie goes to the diagonal of the rarer colour in the window

    # --- §3.3 spline extraction -----------------------------------------------------------
    shading_distance: float = 100.0  # paper §3.3: a visible edge is a shading edge if YUV distance ≤ 100/255 [0, 1000]
    snap_passes: int = 6  # not in paper: T-junction snapping is iterated; each pass shrinks the gap ≥ 4× [1, 100]

    # --- §3.4 corners (docs/corners.md) ---------------------------------------------------
    corner_patterns: bool = True  # paper §3.4 / Figure 7: keep detected corners out of the smoothness term
    # not in paper (issue 46): the nodes of a constant-slope staircase start on its line (optimize/slopes.py)
    straight_runs: bool = True
    # not in paper: a straight run's nodes stay this near (px) its chord (a 2:1 staircase stays within ¼) [0, 4]
    run_tolerance: float = 0.3
    run_long: float = 2.5  # not in paper: a long run (px); smooth curves bend away before their chords do [0, 64]
    run_short: float = 1.4  # not in paper: shortest bevel (px) between two long runs; the "386" chip's is 1.5 [0, 64]
    # not in paper: degrees two runs must turn by, across a sharp corner or a whole bevel [0, 180]
    run_turn: float = 80.0
    # not in paper: degrees each end of a bevel must turn by (a pixel circle turns 45° but over longer runs) [0, 180]
    run_bend: float = 25.0
    # not in paper: runs are followed at most this far (px); longer ones are no straighter [0, 64]
    run_reach: float = 4.0

    # --- §3.4 relaxation -------------------------------------------------------------------
    # not in paper ("at each iteration"): rounds in which every slot moves at once (depixel/optimize/relax.py);
    # a slot's place depends on slots at most 2 per round away along its curve (docs/design.md) [0, 10000]
    iterations: int = 10
    # not in paper ("a small radius"): the pattern of trial offsets first reaches 1/5 pixel [0, 4]
    radius: float = 0.2
    max_offset: float = 0.5  # not in paper: hard bound on a node's move from its initial place (pixels) [0, 4]
    # not in paper: curves keep this far (pixels) from the centres of their pixels [0, 1]
    centre_clearance: float = 0.15
    # gone with the random trials (issue 31): the relaxation has no random draws, so nothing to seed or count
    seed: InitVar[Any] = None
    candidates: InitVar[Any] = None

    # --- §3.4 harmonic map and the fidelity guard --------------------------------------------
    # not in paper: the harmonic map is solved within this many edges of a moved curve node (decayed beyond) [0, 1000]
    harmonic_reach: int = 6
    # not in paper: rounds of walking back the nodes around cells whose centre came within centre_clearance / 2
    # of their boundary, one relaxation round each, all the way in the last (iterations + 2) [0, 1000]
    revert_rounds: int = 12

    # --- §3.5 smooth shading (PNG output) ---------------------------------------------------
    shading_sigma: float = 1.0  # paper §3.5: Gaussian influence of a cell with σ = 1 pixel [1e-6, 16]
    shading_radius: float = 2.0  # paper §3.5: truncated at 2 pixels [1e-6, 16]
    # not in paper: samples per output pixel along each axis at contours (odd: one at the pixel centre) [1, 16]
    shading_supersample: int = 3

    def __post_init__(self, seed: Any = None, candidates: Any = None) -> None:
        """Refuse values the pipeline cannot use (runs on construction and on :meth:`replace`)."""
        from .errors import ParameterError  # noqa: PLC0415
        from .validate import number  # noqa: PLC0415

        for name, value in zip(REMOVED, (seed, candidates)):
            if value is not None:
                raise ParameterError(f"{name} {REMOVED[name]}; leave it out", parameter=name)

        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(f.default, bool) and not isinstance(value, bool):
                raise ParameterError(f"{f.name} must be True or False, not {value!r}", parameter=f.name)
            rule = LIMITS.get(f.name)
            if rule is not None:
                number(f.name, value, low=rule.low, high=rule.high, integer=rule.integer)
                # whole floats and numpy integers become int (range() needs it)
                object.__setattr__(self, f.name, int(value) if rule.integer else float(value))

    def replace(self, **changes: Any) -> Params:
        """A copy with some fields changed; an unknown name raises ParameterError with the
        closest field (``replace(iteration=1)``: did you mean iterations?), as misspelt options
        do; ``seed`` and ``candidates`` say they are gone (:data:`REMOVED`)."""
        unknown = [name for name in changes if name not in self.names() and name not in REMOVED]
        if unknown:
            import difflib  # noqa: PLC0415

            from .errors import ParameterError  # noqa: PLC0415

            close = difflib.get_close_matches(unknown[0], self.names(), n=1)
            hint = f"; did you mean {close[0]}?" if close else f"; the fields are {', '.join(self.names())}"
            raise ParameterError(f"Params has no field {unknown[0]!r}{hint}", parameter=unknown[0])
        return replace(self, **changes)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]
