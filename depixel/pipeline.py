"""The whole pipeline on one screen: image → similarity graph → resolved crossings →
reshaped cells → splines → corners → optimized splines → VectorImage (export with
:mod:`depixel.svg.writer`).

Each stage is a function of the previous stage's immutable result; :func:`depixelize`
calls them in order, stops at the requested stage and times each one.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple, cast

import numpy as np

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
    from .optimize.corners import Corners
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
    rgba = as_rgba(image)
    if _AHEAD and (done := _taken((rgba.shape, rgba.tobytes(), params, stage))) is not None:
        return done
    return _optimized([_to_corners(rgba, params, stage)], params)[0]


def depixelize_many(images: Sequence, params: Params = Params(), stage: str = "optimized") -> list[Result | Exception]:
    """:func:`depixelize` of each image, the optimization's relaxation of them all in one pass
    (:mod:`depixel.optimize.pack`: a round's numpy calls paid once for all; the results are
    those of one image at a time, to the last bit). An image that fails gives its exception
    in its place (the others are converted): the stages before the relaxation run per image,
    and if the pass fails, each image is optimized alone."""
    validate.choice("stage", stage, STAGES)
    out: list[Result | _Begun | Exception] = []
    for image in images:
        try:
            out.append(_to_corners(as_rgba(image), params, stage))
        except Exception as exc:  # this image's own failure: reported in its place
            out.append(exc)
    began = [i for i, item in enumerate(out) if isinstance(item, _Begun)]
    try:
        done: list[Result | Exception] = list(_optimized([cast(_Begun, out[i]) for i in began], params))
    except Exception:  # one of them (or the pass itself) failed: each alone, to find which
        done = []
        for i in began:
            try:
                done.append(_optimized([cast(_Begun, out[i])], params)[0])
            except Exception as exc:
                done.append(exc)
    for i, result in zip(began, done):
        out[i] = result
    return cast("list[Result | Exception]", out)


#: images in one pass (:func:`ahead`): past some 16 sprites a larger pass saves no more calls
#: than its larger arrays cost (docs/performance.md, "Batches in one pass")
PASS_IMAGES = 16
#: pixels in one pass: it holds every product of its pipelines at once, about as much memory as
#: one conversion of an image this size (~65 MB at limits.PEAK_BYTES_PER_PIXEL; the CLI's
#: LOCAL_MAX_PIXELS); a larger image is converted alone
PASS_PIXELS = 1 << 16


@contextmanager
def ahead(images: Sequence, params: Params = Params(), stage: str = "optimized", size: int = PASS_IMAGES,
          pixels: int = PASS_PIXELS, then: Callable[[list[VectorImage]], None] | None = None) -> Iterator[None]:
    """Within the block, :func:`depixelize` of one of ``images`` (the same pixels, params and
    stage) returns its result computed by :func:`depixelize_many` with the images next to it,
    at most ``size`` images and ``pixels`` pixels at a time (a pass holds all its products at
    once: as much memory as one conversion of that many pixels; a larger image is left out).
    A pass runs when the first of its images is asked for; each result is returned once. So
    a batch's files, a sheet's sprites, an animation's frames are each converted by their own
    code, and only their pipelines run together. An image that failed in its pass is
    converted when asked, as without this block. What was not taken is dropped at its end.
    ``then``: told the vector images of each pass as it ends (the SVG writer's pass)."""
    keys: list[tuple] = []
    groups: list[list[tuple]] = []
    total = 0
    for image in images:
        rgba = as_rgba(image)
        key = (rgba.shape, rgba.tobytes(), params, stage)
        area = rgba.shape[0] * rgba.shape[1]
        if key in _AHEAD or key in _GROUP or area > pixels:  # (the same pixels twice: one result)
            continue
        if not groups or len(groups[-1]) >= size or total + area > pixels:
            groups.append([])
            total = 0
        groups[-1].append(key)
        total += area
        keys.append(key)
        _AHEAD[key] = rgba
        _GROUP[key] = groups[-1]
        if then is not None:
            _THEN[key] = then
    try:
        yield
    finally:
        for key in keys:
            _AHEAD.pop(key, None)
            _GROUP.pop(key, None)
            _THEN.pop(key, None)


def _taken(key: tuple) -> Result | None:
    """The result waiting under ``key`` (:func:`ahead`), its pass run first if need be."""
    found = _AHEAD.pop(key, None)
    if isinstance(found, np.ndarray):  # its pass has not run: run it
        group = [k for k in _GROUP.get(key, [key]) if k == key or isinstance(_AHEAD.get(k), np.ndarray)]
        images = [found if k == key else _AHEAD[k] for k in group]
        results = depixelize_many(images, key[2], key[3])
        for k, result in zip(group, results):
            _GROUP.pop(k, None)
            if k == key:
                found = result if isinstance(result, Result) else None
            elif isinstance(result, Result):
                _AHEAD[k] = result
            else:
                del _AHEAD[k]  # converted (and failing) when asked
        if (then := _THEN.get(key)) is not None:
            then([result.vector for result in results if isinstance(result, Result)])
    return found if isinstance(found, Result) else None


#: what :func:`ahead` holds, by (shape, pixels, params, stage): an image whose pass has not run
#: (its pixels) or its result; and each image's pass (the keys of its group)
_AHEAD: dict[tuple, Result | np.ndarray] = {}
_GROUP: dict[tuple, list[tuple]] = {}
_THEN: dict[tuple, Callable[[list[VectorImage]], None]] = {}


class _Begun(NamedTuple):
    """An image's run up to its relaxation: its :class:`Result` when ``stage`` stops before the
    optimization, else the products so far."""

    result: Result | None
    products: tuple[SimilarityGraph, CrossingResolution, CellGraph, SplineSet] | None = None
    timings: dict[str, float] | None = None
    curves: SplineSet | None = None  # cut at the corners
    corners: Corners | None = None


def _to_corners(rgba, params: Params, stage: str) -> _Begun:
    """The stages up to the corners (the curves cut there), or the whole run of an earlier stage."""
    timings: dict[str, float] = {}
    clock = time.perf_counter

    t = clock()
    similarity = build_similarity_graph(rgba, params)
    timings["similarity"] = clock() - t
    t = clock()
    resolution = resolve_crossings(similarity, params)
    timings["crossings"] = clock() - t
    t = clock()
    cells = build_cell_graph(resolution)
    timings["cells"] = clock() - t
    if stage == "cells":
        return _Begun(Result(similarity, resolution, cells, straight_image(cells), timings=timings))

    from .curves.splines import extract_splines, split_at  # noqa: PLC0415 (keeps the cells stage light)

    t = clock()
    splines = extract_splines(cells, params)  # §3.3
    timings["splines"] = clock() - t
    if stage == "splines":
        return _Begun(Result(similarity, resolution, cells, splines.vector_image(), splines=splines, timings=timings))

    from .optimize.corners import detect_corners  # noqa: PLC0415

    t = clock()
    corners = detect_corners(splines, params)  # §3.4, Figure 7
    curves = split_at(splines, corners.nodes)  # every corner ends its curves
    timings["corners"] = clock() - t
    return _Begun(None, (similarity, resolution, cells, splines), timings, curves, corners)


def _optimized(begun: Sequence[_Begun], params: Params) -> list[Result]:
    """The results of runs begun by :func:`_to_corners`: those that reached the corners are
    optimized (§3.4), together (the time is shared out evenly)."""
    todo = cast("list[tuple[SplineSet, Corners]]", [(item.curves, item.corners) for item in begun
                                                      if item.result is None])
    optimized: Iterator[OptimizedSplines] = iter(())
    seconds = 0.0
    t = time.perf_counter()
    if len(todo) == 1:  # alone: nothing to join
        from .optimize.stage import optimize_splines  # noqa: PLC0415

        optimized = iter([optimize_splines(*todo[0], params)])
    elif todo:
        from .optimize.pack import optimize_many  # noqa: PLC0415

        optimized = iter(optimize_many(todo, params))
    seconds = (time.perf_counter() - t) / max(len(todo), 1)
    out = []
    for item in begun:
        if item.result is not None:
            out.append(item.result)
            continue
        result = next(optimized)
        similarity, resolution, cells, splines = cast("tuple[SimilarityGraph, CrossingResolution, CellGraph, "
                                                      "SplineSet]", item.products)
        out.append(Result(similarity, resolution, cells, result.vector_image(), splines=splines, optimized=result,
                          timings={**(item.timings or {}), "optimize": seconds}))
    return out
