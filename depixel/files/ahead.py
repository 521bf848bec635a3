"""Many conversions in one pass — a sheet's sprites, an animation's frames, a folder's files.

Each image is still converted by its own :func:`depixel.api.convert` (or
:func:`~depixel.api.convert_bytes`) call; within :func:`converted_ahead` those calls find their
pipelines run already, all of them in one pass (:func:`depixel.pipeline.ahead`: the
relaxation's numpy calls paid once for all, :mod:`depixel.optimize.pack`), with the very
bytes each would have alone. The pass prepares each image as the conversion will; an image
it cannot prepare, or prepares otherwise, is simply converted when asked, as without it.
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np

from ..api import prepared_input
from ..options import ConvertOptions
from ..params import Params
from ..pipeline import PASS_IMAGES, PASS_PIXELS, ahead


@contextmanager
def converted_ahead(images: Sequence, params: Params = Params(), **keywords) -> Iterator[None]:
    """Within the block, the conversions of ``images`` with these options (the keywords of
    :func:`depixel.api.convert`; ``title`` and ``name`` do not matter here, nor do the SVG's)
    find their pipelines run, in passes of at most :data:`PASS_IMAGES` images and
    :data:`PASS_PIXELS` pixels, each run when the first of its images is converted. Options
    that are refused leave every image to its conversion (which reports them)."""
    prepared: list[np.ndarray] = []
    try:
        options = ConvertOptions.build(params, **{k: v for k, v in keywords.items() if k not in ("title", "name")})
    except Exception:  # the conversions report it
        options, images = ConvertOptions(), ()
    for image in images:
        try:
            prepared.append(prepared_input(image, options.prepare, max_pixels=None).rgba)
        except Exception:  # its conversion reports it
            continue
    with ahead(prepared, options.params, options.output.stage, PASS_IMAGES, PASS_PIXELS):
        yield
