"""Pictures — the renders of an animation's frames → one animated PNG (APNG).

Each frame is stored whole where it differs from the frame before (Pillow crops it to the
rectangle that changed; ``OP_SOURCE``, ``OP_NONE``: the rectangle replaces what was there),
with the frame's duration and APNG's ``num_plays`` (0: for ever, N: N plays), the same
timing as the animated SVG. Consecutive frames that render alike become one frame of their
summed duration (Pillow does so); a single frame is a plain PNG.
"""
from __future__ import annotations

import io
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..limits import check_frames_pixels, check_rendered_frames

if TYPE_CHECKING:
    from ..options import ConvertOptions
    from ..prepare.animation import Animation


def encode_apng(frames: Sequence[np.ndarray], durations: Sequence[float], plays: int) -> bytes:
    """The bytes of an animated PNG of ``(H, W, 4) uint8`` RGBA ``frames``, each shown for
    ``durations[i]`` milliseconds, the whole played ``plays`` times (0: for ever)."""
    from PIL import Image, PngImagePlugin  # noqa: PLC0415

    if not frames or len(frames) != len(durations):
        raise ValueError(f"{len(frames)} frames for {len(durations)} durations")
    images = [Image.fromarray(np.ascontiguousarray(frame), "RGBA") for frame in frames]
    buffer = io.BytesIO()
    images[0].save(buffer, format="PNG", save_all=True, append_images=images[1:],
                   duration=[float(d) for d in durations], loop=int(plays),
                   disposal=PngImagePlugin.Disposal.OP_NONE, blend=PngImagePlugin.Blend.OP_SOURCE)
    return buffer.getvalue()


def animated(animation: Animation, formats: Mapping[str, str | None], options: ConvertOptions,
             convert_frame: Callable[[np.ndarray, dict[str, None]], dict[str, bytes]], *,
             name: str = "<image>") -> dict[str, bytes]:
    """Every frame of ``animation`` converted by ``convert_frame(frame, formats)`` (the
    still's :func:`depixel.api.conversions`) → ``{format: bytes}``: one SVG of
    all the frames (:func:`depixel.svg.animation.compose`: a layer a frame, SMIL in the file's
    timing, shared shapes once) or one APNG of their renders
    (:func:`encode_apng`). Each frame is converted alone, as a still
    of it is; frames of the same pixels once. The frames' pixels in all are checked against
    ``max_pixels``, and for a PNG the renders' in all against ``max_output_pixels``, first."""
    from PIL import Image  # noqa: PLC0415

    from ..svg.animation import compose  # noqa: PLC0415

    n, limits = len(animation.frames), options.limits
    height, width = animation.frames[0].shape[:2]
    check_frames_pixels(name, n, n * width * height, limits.max_pixels)
    if "png" in formats:
        scale = options.output.scale_for(width, height)
        check_rendered_frames(name, n, n * max(1, round(width * scale)) * max(1, round(height * scale)),
                              limits.max_output_pixels)
    made: dict[bytes, dict[str, bytes]] = {}
    for frame in animation.frames:
        if (key := frame.tobytes()) not in made:
            made[key] = convert_frame(frame, dict.fromkeys(formats))
    drawn = [made[frame.tobytes()] for frame in animation.frames]
    blobs = {}
    grids = {d["svg"].partition(b"<svg")[2].partition(b">")[0] for d in drawn} if "svg" in formats else ()
    if len(grids) > 1:  # each frame is prepared alone: an upscaled grid found in some frames only
        raise InputError(f"{name}: its frames were found to be pixel art of different sizes (upscaled in some, "
                         "not in others); give the grid of all with pixel_size", parameter="pixel_size")
    for fmt in formats:
        if fmt == "svg":
            svg = compose([d["svg"].decode("utf-8") for d in drawn], animation.durations, animation.plays)
            blobs[fmt] = svg.encode("utf-8")
        else:
            renders: dict[int, np.ndarray] = {}  # by the identity of a frame's bytes: each decoded once
            for d in drawn:
                if id(d) not in renders:
                    with Image.open(io.BytesIO(d["png"])) as png:
                        renders[id(d)] = np.asarray(png.convert("RGBA"))
            blobs[fmt] = encode_apng([renders[id(d)] for d in drawn], animation.durations, animation.plays)
    return blobs
