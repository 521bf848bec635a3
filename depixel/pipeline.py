"""The whole pipeline on one screen: image → similarity graph → resolved crossings →
reshaped cells → splines → optimized splines → VectorImage (export with :mod:`depixel.svg`).

Each stage is a function of the previous stage's immutable result; :func:`depixelize`
calls them in order, stops at the requested stage and times each one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from .cells import CellGraph, build_cell_graph
from .crossings import CrossingResolution, resolve_crossings
from .image import as_rgba
from .params import Params
from .similarity import SimilarityGraph, build_similarity_graph
from .vector import VectorImage, straight_image

#: Output stages, in pipeline order. "optimized" is the paper's final result.
STAGES = ("cells", "splines", "optimized")


@dataclass(frozen=True, eq=False)
class Result:
    """Every intermediate product of one run, plus the vector image of the last stage."""

    similarity: SimilarityGraph
    resolution: CrossingResolution
    cells: CellGraph
    vector: VectorImage
    splines: object | None = None  # depixel.splines.SplineSet, when the stage was reached
    optimized: object | None = None  # depixel.optimize.OptimizedSplines, likewise
    timings: dict[str, float] = field(default_factory=dict)  # seconds per stage


def depixelize(image, params: Params = Params(), stage: str = "optimized") -> Result:
    """Run the pipeline on an RGBA image (array or PIL image) up to ``stage``."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage {stage!r}; choose one of {', '.join(STAGES)}")
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

    from .splines import extract_splines  # noqa: PLC0415 (keeps the cells stage light)

    t = clock()
    splines = extract_splines(cells, params)
    timings["splines"] = clock() - t
    if stage == "splines":
        return Result(similarity, resolution, cells, splines.vector_image(), splines=splines, timings=timings)

    from .optimize import optimize_splines  # noqa: PLC0415

    t = clock()
    optimized = optimize_splines(splines, params)
    timings["optimize"] = clock() - t
    return Result(similarity, resolution, cells, optimized.vector_image(), splines=splines,
                  optimized=optimized, timings=timings)
