"""The tuning parameters of the pipeline, named as in the paper.

Every constant carries its source: "paper" (Kopf & Lischinski 2011, with the section),
"hqx" (the YUV test the paper borrows), or "not in paper" with the reason it was chosen.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import NamedTuple


class Range(NamedTuple):
    """The values a numeric field accepts: finite, within [low, high], whole when ``integer``."""

    low: float | None = 0.0
    high: float | None = None
    integer: bool = False


#: The constraint of every numeric field (a field not listed is not checked; booleans must be bool).
#: Upper bounds keep the pipeline's memory in reason (a window of side N costs N² per crossing).
LIMITS: dict[str, Range] = {
    "threshold_y": Range(), "threshold_u": Range(), "threshold_v": Range(), "threshold_alpha": Range(),
    "curve_weight": Range(), "sparse_weight": Range(), "island_weight": Range(),
    "sparse_window": Range(2, 64, integer=True),
    "shading_distance": Range(),
    "iterations": Range(0, 10_000, integer=True),
    "candidates": Range(1, 1_000, integer=True),
    "radius": Range(), "max_offset": Range(), "centre_clearance": Range(),
    "seed": Range(0, 2**63 - 1, integer=True),
}


@dataclass(frozen=True)
class Params:
    """Constants of the depixelization pipeline (all colour values on a 0-255 scale).

    Only what changes the geometry lives here; output settings (SVG precision, scale) are
    arguments of the writers, and the last stage to run is an argument of
    :func:`depixel.depixelize`."""

    # --- §3.2 similarity graph -------------------------------------------------------------
    threshold_y: float = 48.0  # paper §3.2 / hqx: dissimilar when |ΔY| > 48/255
    threshold_u: float = 7.0  # paper §3.2 / hqx: dissimilar when |ΔU| > 7/255
    threshold_v: float = 6.0  # paper §3.2 / hqx: dissimilar when |ΔV| > 6/255
    threshold_alpha: float = 48.0  # not in paper: two visible pixels whose alpha differs by more are dissimilar

    # --- §3.2 crossing resolution heuristics ----------------------------------------------
    curve_weight: float = 1.0  # paper §3.2 "curves": vote = difference of curve lengths (× this factor)
    sparse_weight: float = 1.0  # paper §3.2 "sparse pixels": vote = difference of component sizes (× this)
    sparse_window: int = 8  # paper §3.2: component sizes are measured in an 8×8 window around the block
    island_weight: float = 5.0  # paper §3.2 "islands": fixed vote, empirically 5
    tie_break: bool = True  # not in paper: a tie goes to the diagonal of the rarer colour in the window

    # --- §3.3 spline extraction -----------------------------------------------------------
    shading_distance: float = 100.0  # paper §3.3: a visible edge is a shading edge if YUV distance ≤ 100/255

    # --- §3.4 optimization ----------------------------------------------------------------
    iterations: int = 10  # not in paper ("at each iteration"): 10 sweeps at radius 0.2 give 90% of the energy drop of 40 sweeps at 0.125
    candidates: int = 8  # not in paper ("several random offsets"): trial positions per node and sweep
    radius: float = 0.2  # not in paper ("a small radius"): trial offsets within 1/5 pixel
    max_offset: float = 0.5  # not in paper: hard bound on a node's move from its initial place (pixels)
    centre_clearance: float = 0.15  # not in paper: curves keep this far (pixels) from the centres of their pixels
    seed: int = 0  # not in paper: all randomness comes from numpy's PCG64 seeded with this
    corner_patterns: bool = True  # paper §3.4 / Figure 7: keep detected corners out of the smoothness term

    def __post_init__(self) -> None:
        """Refuse values the pipeline cannot use (runs on construction and on :meth:`replace`)."""
        from .errors import ParameterError  # noqa: PLC0415
        from .validate import number  # noqa: PLC0415

        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(f.default, bool) and not isinstance(value, bool):
                raise ParameterError(f"{f.name} must be True or False, not {value!r}", parameter=f.name)
            rule = LIMITS.get(f.name)
            if rule is not None:
                number(f.name, value, low=rule.low, high=rule.high, integer=rule.integer)
                # whole floats and numpy integers become int (range() and the RNG need it)
                object.__setattr__(self, f.name, int(value) if rule.integer else float(value))

    def replace(self, **changes: object) -> "Params":
        """A copy with some fields changed (unknown names raise TypeError)."""
        return replace(self, **changes)

    @classmethod
    def names(cls) -> list[str]:
        return [f.name for f in fields(cls)]
