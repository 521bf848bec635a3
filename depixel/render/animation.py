"""Pictures — the renders of an animation's frames → one animated PNG (APNG).

Each frame is stored whole where it differs from the frame before (Pillow crops it to the
rectangle that changed; ``OP_SOURCE``, ``OP_NONE``: the rectangle replaces what was there),
with the frame's duration and APNG's ``num_plays`` (0: for ever, N: N plays), the same
timing as the animated SVG. Consecutive frames that render alike become one frame of their
summed duration (Pillow does so); a single frame is a plain PNG.
"""
from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np


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
