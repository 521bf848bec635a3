"""Animations — an :class:`~depixel.prepare.animation.Animation` → one animated SVG or APNG.

Every frame is converted alone, as :func:`depixel.api.convert` converts a still (what
``--frames all`` writes one file a frame for), then :mod:`depixel.svg.animation` composes the
frames' SVGs into one, with the shapes the frames share written once, or
:mod:`depixel.render.animation` writes the frames' smooth renders as an APNG. Frames that are
the same pixels are converted once; the frames' pipelines run together, some at a time
(:mod:`depixel.files.ahead`: the bytes of each frame alone). Read a file's frames and timing with
:func:`depixel.prepare.animation.read_animation`.
"""
from __future__ import annotations

import io

import numpy as np

from ..api import convert, convert_bytes
from ..errors import ParameterError
from ..limits import DEFAULT_MAX_OUTPUT_PIXELS, check_rendered_frames
from ..params import Params
from ..prepare.animation import Animation
from ..render.animation import encode_apng
from ..svg.animation import compose
from .ahead import converted_ahead


def animate(animation: Animation, params: Params = Params(), **options) -> str:
    """One animated SVG of every frame of ``animation`` (docs/animation.md): a layer a frame,
    switched by SMIL in the file's own timing; a renderer without animation shows the first
    frame. ``options`` are those of :func:`depixel.api.convert` (``scale``, ``shading``,
    ``layout``, ``simplify``, ``precision``, ``pixel_size``, …), the same for every frame."""
    _check(animation)
    svgs: dict[bytes, str] = {}
    with converted_ahead(animation.frames, params, **options):  # the frames' pipelines in passes
        for frame in animation.frames:
            key = frame.tobytes()
            if key not in svgs:
                svgs[key] = convert(frame, params, **options)
    return compose([svgs[frame.tobytes()] for frame in animation.frames], animation.durations, animation.plays)


def animate_png(animation: Animation, params: Params = Params(), *, name: str = "<image>",
                max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS, **options) -> bytes:
    """An animated PNG of the frames' smooth renders (paper §3.5, as
    :func:`depixel.api.convert_bytes` renders a PNG) with the animation's timing. ``options``
    are those of :func:`depixel.api.convert_bytes`; the frames' pixels in all must stay within
    ``max_output_pixels`` (each alone too), checked once the first frame's size is known."""
    from PIL import Image  # noqa: PLC0415

    _check(animation)
    renders: dict[bytes, np.ndarray] = {}
    with converted_ahead(animation.frames, params, **options):  # the frames' pipelines in passes
        for frame in animation.frames:
            key = frame.tobytes()
            if key in renders:
                continue
            png = convert_bytes(frame, "png", params, name=name, max_output_pixels=max_output_pixels, **options)
            with Image.open(io.BytesIO(png)) as image:
                renders[key] = np.asarray(image.convert("RGBA"))
            if len(renders) == 1:
                h, w = renders[key].shape[:2]
                n = len(animation.frames)
                check_rendered_frames(name, n, n * w * h, max_output_pixels)
    return encode_apng([renders[frame.tobytes()] for frame in animation.frames], animation.durations,
                       animation.plays)


def _check(animation: Animation) -> None:
    if not isinstance(animation, Animation):
        raise ParameterError(f"animate takes a depixel.prepare.animation.Animation, not {type(animation).__name__}",
                             parameter="animation")
