"""The SVG writer's simplification of many images in one pass (issue 44).

A sprite's simplification is some 950 numpy calls (its passes of fits, the levels of its
cuts) whatever its size. When the pipelines of several images run in one pass
(:func:`depixel.pipeline.ahead`), :func:`shapes_ahead` also begins their outlines there: each
image's face topology and boundary pieces (:class:`~depixel.svg.outlines.OutlineShapes`
takes them, :func:`begun`), the pieces of all of them simplified as one set
(:func:`simplify_many`). A piece is simplified on its own and a range is fitted alone, so
the pieces of several images joined (their segments numbered one image after the other, each
in its own coordinates) give each image the curves it gets alone; what reads an image's
cells (its protected points) is found per image, then joined.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import numpy as np

from ..vector import VectorImage
from .boundaries import BoundaryPieces, build_pieces
from .breaks import joined_breaks
from .reference import joined
from .simplify import SPECULATIVE_SEGMENTS, References, assemble, references, simplified_ranges, simplify_pieces
from .stacking import FaceTopology

#: outlines begun ahead, by (id(image), layout, grid, simplify): the image, its face topology
#: and its (simplified) boundary pieces
_AHEAD: dict[tuple, tuple[VectorImage, FaceTopology, BoundaryPieces]] = {}


def begun(image: VectorImage, layout: str, grid: float | None, simplify: float
          ) -> tuple[FaceTopology, BoundaryPieces] | None:
    """The face topology and the pieces of ``image``'s outlines begun ahead with these options
    (:func:`shapes_ahead`), once; None when there are none."""
    found = _AHEAD.pop((id(image), layout, grid, simplify), None)
    return None if found is None or found[0] is not image else (found[1], found[2])


@contextmanager
def shapes_ahead(layout: str, grid: float | None, simplify: float) -> Iterator[Callable[[Sequence[VectorImage]], None]]:
    """Within the block, ``add(images)`` begins the outlines of ``images`` with these options,
    their simplifications in one pass; :func:`begun` hands each to its writer. What was not
    taken is dropped at the end of the block. A failure leaves the images to their writers."""
    keys: list[tuple] = []

    def add(images: Sequence[VectorImage]) -> None:
        try:
            begun = [(image, FaceTopology(image, layout == "stacked")) for image in images]
            pieces = [build_pieces(image, topo.junction, grid) for image, topo in begun]
            pieces = simplify_many([(p, image) for p, (image, _) in zip(pieces, begun)], simplify, grid=grid)
        except Exception:  # each writer finds nothing, and makes (and reports) its own
            return
        for (image, topo), simplified in zip(begun, pieces):
            key = (id(image), layout, grid, simplify)
            keys.append(key)
            _AHEAD[key] = (image, topo, simplified)

    try:
        yield add
    finally:
        for key in keys:
            _AHEAD.pop(key, None)


def simplify_many(items: Sequence[tuple[BoundaryPieces, VectorImage]], tolerance: float, clearance: float = 0.075,
                  grid: float | None = None) -> list[BoundaryPieces]:
    """:func:`~depixel.svg.simplify.simplify_pieces` of each ``(pieces, image)``, their fits in
    one set of passes: the same pieces as one image at a time."""
    if tolerance <= 0:
        return [pieces for pieces, _ in items]
    todo = [i for i, (pieces, _) in enumerate(items) if pieces.kind.size]
    if len(todo) < 2:
        return [simplify_pieces(pieces, image, tolerance, clearance, grid) for pieces, image in items]
    made = [references(*items[i], tolerance, clearance) for i in todo]
    offsets = np.cumsum([0] + [pieces.kind.size for pieces, _ in made])
    refs = [r for _, r in made]
    exact, protected = joined([r.exact for r in refs], [r.protected for r in refs])
    ptr = np.concatenate([r.ptr[:-1] + offsets[k] for k, r in enumerate(refs)] + [offsets[-1:]])
    union = References(ptr, np.concatenate([r.kind for r in refs]), joined_breaks([r.breaks for r in refs]), exact,
                       protected)
    lo, hi, kinds, c1, c2 = simplified_ranges(union, tolerance, clearance, grid, SPECULATIVE_SEGMENTS * len(made))
    bounds = lo.searchsorted(offsets)  # the ranges are sorted, each within one image
    out = [pieces for pieces, _ in items]
    for k, i in enumerate(todo):
        part = slice(int(bounds[k]), int(bounds[k + 1]))
        out[i] = assemble(made[k][0], lo[part] - offsets[k], hi[part] - offsets[k], kinds[part], c1[part], c2[part])
    return out
