"""The whole pipeline on one screen: image → similarity graph → resolved crossings →
reshaped cells → splines → corners → optimized splines → VectorImage (export with
:mod:`depixel.svg.writer`).

Each stage is a function of the previous stage's immutable result; :func:`depixelize`
calls them in order, stops at the requested stage and times each one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from . import validate
from .frozen import compact_repr
from .graph.cells import CellGraph, build_cell_graph
from .graph.crossings import CrossingResolution, resolve_crossings
from .graph.similarity import SimilarityGraph, build_similarity_graph
from .params import Params
from .prepare.image import Pixels, as_rgba
from .vector import VectorImage, straight_image

if TYPE_CHECKING:  # the spline stages are imported only when a run reaches them
    from .curves.splines import SplineSet
    from .optimize.stage import OptimizedSplines

#: Output stages, in pipeline order. "optimized" is the paper's final result.
STAGES = ("cells", "splines", "optimized")


@dataclass(frozen=True, eq=False)
class Result:
    """Every intermediate product of one run, plus the vector image of the last stage.

    ``splines`` holds the curves of §3.3 as extracted (what the "splines" stage draws);
    ``optimized.splines`` are the same curves cut at ``optimized.corners``, the ones the
    "optimized" stage draws with ``optimized.positions``."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    similarity: SimilarityGraph
    resolution: CrossingResolution
    cells: CellGraph
    vector: VectorImage
    splines: SplineSet | None = None  # when the "splines" stage was reached
    optimized: OptimizedSplines | None = None  # when the "optimized" stage was reached
    timings: dict[str, float] = field(default_factory=dict)  # seconds per stage


def depixelize(image: Pixels, params: Params = Params(), stage: str = "optimized") -> Result:
    """Run the pipeline on an RGBA image (array or PIL image) up to ``stage``."""
    validate.choice("stage", stage, STAGES)
    timings: dict[str, float] = {}
    clock = time.perf_counter

    t = clock()
    similarity = build_similarity_graph(as_rgba(image), params)
    timings["similarity"] = clock() - t
    t = clock()
    resolution = resolve_crossings(similarity, params)
    timings["crossings"] = clock() - t
    t = clock()
    cells = build_cell_graph(resolution)
    timings["cells"] = clock() - t
    if stage == "cells":
        return Result(similarity, resolution, cells, straight_image(cells), timings=timings)

    from .curves.splines import extract_splines, split_at  # noqa: PLC0415 (keeps the cells stage light)

    t = clock()
    splines = extract_splines(cells, params)  # §3.3
    timings["splines"] = clock() - t
    if stage == "splines":
        return Result(similarity, resolution, cells, splines.vector_image(), splines=splines, timings=timings)

    from .optimize.corners import detect_corners  # noqa: PLC0415
    from .optimize.stage import optimize_splines  # noqa: PLC0415

    t = clock()
    corners = detect_corners(splines, params)  # §3.4, Figure 7
    curves = split_at(splines, corners.nodes)  # every corner ends its curves
    timings["corners"] = clock() - t
    t = clock()
    optimized = optimize_splines(curves, corners, params)  # §3.4
    timings["optimize"] = clock() - t
    return Result(similarity, resolution, cells, optimized.vector_image(), splines=splines,
                  optimized=optimized, timings=timings)
