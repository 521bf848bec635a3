"""Input — Pillow's decoding, made quiet and safe: an image opened from bytes with its warnings
turned off (its decompression-bomb warning an error), C libraries' complaints kept off stderr,
and any Pillow mode turned into RGBA uint8 (docs/colour.md, "Input modes").

Its own module so that every reader that decodes with Pillow (:mod:`.image`, and :mod:`.gif` and
:mod:`.apng`, which :mod:`.image` reads animations with) shares it without an import cycle.
"""
from __future__ import annotations

import contextlib
import io
import os
import warnings

import numpy as np

from ..errors import InputError

#: Modes with more than 8 bits per grey sample, scaled by hand (Pillow's convert clips them).
WIDE_GREY = ("I;16", "I;16B", "I;16L", "I;16N", "I", "F")


@contextlib.contextmanager
def quiet_pillow():
    """Pillow's warnings (corrupt EXIF, odd chunks) are not shown: the file either loads or
    fails with one line. Its decompression-bomb warning, given from MAX_IMAGE_PIXELS on (it
    only raises at twice that), becomes an error."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        yield


@contextlib.contextmanager
def mute_stderr_fd(active: bool):
    """Point file descriptor 2 at the null device for the duration (C libraries that print
    directly there); a no-op when not ``active`` or when fd 2 cannot be duplicated."""
    try:
        saved = os.dup(2) if active else None
    except OSError:
        saved = None
    if saved is None:
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def is_bomb(exc: BaseException) -> bool:
    from PIL import Image

    return isinstance(exc, (Image.DecompressionBombError, Image.DecompressionBombWarning))


def bomb_error(name: str) -> InputError:
    from PIL import Image

    return InputError(f"{name}: header claims an absurd size, over {Image.MAX_IMAGE_PIXELS} pixels "
                      "(decompression bomb guard)")


def open_image(data: bytes, name: str):
    """Pillow image over ``data`` (header read, pixels not yet decoded); use as a context,
    inside :func:`quiet_pillow`."""
    from PIL import Image  # Pillow is imported lazily: `depixel --help` should stay fast

    try:
        img = open_png(data) if data.startswith(PNG_SIGNATURE) else Image.open(io.BytesIO(data))
    except Exception as exc:  # UnidentifiedImageError, or a header Pillow chokes on
        if is_bomb(exc):
            raise bomb_error(name) from None
        raise InputError(f"{name}: not an image (no format Pillow reads recognises it)") from None
    width, height = img.size
    if width <= 0 or height <= 0:
        img.close()
        raise InputError(f"{name}: image has zero size")
    return img


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def open_png(data: bytes):
    """A PNG opened by Pillow's PNG reader itself: ``Image.open`` first imports the BMP, GIF,
    JPEG and PPM readers too (~9 ms of every conversion process, most of it the ``subprocess``
    module the JPEG reader imports). The same decompression-bomb guard as ``Image.open`` under
    :func:`quiet_pillow`: over ``MAX_IMAGE_PIXELS`` is refused."""
    from PIL import Image, PngImagePlugin

    img = PngImagePlugin.PngImageFile(io.BytesIO(data))
    width, height = img.size
    if Image.MAX_IMAGE_PIXELS is not None and width * height > Image.MAX_IMAGE_PIXELS:
        img.close()
        raise Image.DecompressionBombError(f"{width * height} pixels")
    return img


def to_rgba(img, name: str = "<image>") -> np.ndarray:
    """Convert any Pillow mode to RGBA uint8 (see docs/colour.md for the rules)."""
    mode = img.mode
    if mode in WIDE_GREY:
        raw = np.asarray(img)
        arr = np.nan_to_num(raw.astype(np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        if mode == "F":
            top = 1.0 if arr.max(initial=0) <= 1.0 else 255.0
        else:
            top = 65535.0 if mode.startswith("I;16") or arr.max(initial=0) > 255 else 255.0
        grey = np.clip(np.round(arr / top * 255.0), 0, 255).astype(np.uint8)
        alpha = np.full(grey.shape, 255, np.uint8)
        key = img.info.get("transparency")
        if isinstance(key, (int, float)) and not isinstance(key, bool):
            alpha[raw == key] = 0  # a 16-bit grey PNG's tRNS key
        return np.stack([grey, grey, grey, alpha], axis=-1)
    if mode == "P" and "transparency" in img.info:
        img = img.convert("PA")
    elif mode == "La":  # premultiplied; Pillow only converts it to LA
        img = img.convert("LA")
    try:
        return np.ascontiguousarray(np.asarray(img.convert("RGBA"), dtype=np.uint8))
    except ValueError:
        raise InputError(f"{name}: image mode {mode} cannot be converted to RGBA") from None
