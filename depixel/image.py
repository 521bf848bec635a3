"""Stage 0 — input: any image Pillow reads → RGBA uint8 array, and the hqx YUV colour space.

The paper compares colours in YUV (§3.2, after hqx). Colours are converted once here, to
float64 on a 0-255 scale, with the hqx formula (documented in docs/colour.md)::

    Y =  0.299 R + 0.587 G + 0.114 B
    U = -0.169 R - 0.331 G + 0.500 B
    V =  0.500 R - 0.419 G - 0.081 B
"""
from __future__ import annotations

import io
import os
import warnings
from pathlib import Path
from typing import BinaryIO, Union

import numpy as np

from .errors import InputError

#: Default limit on width × height. Pixel art is small; a larger input is almost always a photo.
DEFAULT_MAX_PIXELS = 1_048_576

ImageSource = Union[str, os.PathLike, bytes, BinaryIO]

_YUV_MATRIX = np.array(
    [[0.299, 0.587, 0.114], [-0.169, -0.331, 0.5], [0.5, -0.419, -0.081]], dtype=np.float64
)


def rgb_to_yuv(rgb: np.ndarray) -> np.ndarray:
    """hqx YUV of an ``(..., 3)`` RGB array on a 0-255 scale → ``(..., 3) float64``."""
    return rgb[..., :3].astype(np.float64) @ _YUV_MATRIX.T


def _describe(source: ImageSource) -> str:
    if isinstance(source, (str, os.PathLike)):
        return str(source)
    return "<stdin>" if not isinstance(source, bytes) else "<bytes>"


def load_image(source: ImageSource, max_pixels: int | None = DEFAULT_MAX_PIXELS, frame: int = 0) -> np.ndarray:
    """Read an image into an ``(H, W, 4) uint8`` RGBA array, alpha kept.

    ``source`` is a path, raw file bytes or a binary file object. Palette, grayscale,
    16-bit, CMYK and palette-with-transparency images are converted to RGBA. Raises
    :class:`InputError` with a one-line message naming the file for anything unreadable.
    """
    from PIL import Image  # Pillow is imported lazily: `depixel --help` should stay fast

    name = _describe(source)
    try:
        if isinstance(source, (str, os.PathLike)):
            path = Path(source)
            if not path.exists():
                raise InputError(f"{name}: no such file")
            if path.is_dir():
                raise InputError(f"{name}: is a directory, not an image")
            try:
                data = path.read_bytes()
            except PermissionError:
                raise InputError(f"{name}: permission denied") from None
            except OSError as exc:
                raise InputError(f"{name}: cannot read ({exc.strerror or exc})") from None
        elif isinstance(source, bytes):
            data = source
        else:
            data = source.read()
        if not data:
            raise InputError(f"{name}: empty file")
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            try:
                img = Image.open(io.BytesIO(data))
            except (Image.DecompressionBombError, Image.DecompressionBombWarning):
                raise InputError(f"{name}: image is absurdly large (decompression bomb guard)") from None
            except Exception:
                raise InputError(f"{name}: not an image Pillow can read") from None
            width, height = img.size
            if width <= 0 or height <= 0:
                raise InputError(f"{name}: image has zero size")
            if max_pixels is not None and width * height > max_pixels:
                raise InputError(
                    f"{name}: {width}x{height} is {width * height} pixels, over the limit of "
                    f"{max_pixels} (depixel is for pixel art; raise it with --max-pixels)"
                )
            try:
                n_frames = getattr(img, "n_frames", 1)
                if frame >= n_frames:
                    raise InputError(f"{name}: has {n_frames} frame(s), no frame {frame}")
                if frame:
                    img.seek(frame)
                img.load()
                rgba = _to_rgba(img)
            except InputError:
                raise
            except Exception:
                raise InputError(f"{name}: truncated or corrupt image data") from None
    except InputError:
        raise
    return rgba


def frame_count(source: ImageSource) -> int:
    """Number of frames in an (animated) image; 1 for still images."""
    from PIL import Image

    try:
        data = Path(source).read_bytes() if isinstance(source, (str, os.PathLike)) else source
        with Image.open(io.BytesIO(data)) as img:  # type: ignore[arg-type]
            return int(getattr(img, "n_frames", 1))
    except Exception:
        raise InputError(f"{_describe(source)}: not an image Pillow can read") from None


def _to_rgba(img) -> np.ndarray:
    """Convert any Pillow mode to RGBA uint8, scaling 16-bit and 32-bit data to 8 bits."""
    mode = img.mode
    if mode in ("I;16", "I;16B", "I;16L", "I;16N", "I"):
        arr = np.asarray(img, dtype=np.float64)
        top = 65535.0 if mode.startswith("I;16") or arr.max(initial=0) > 255 else 255.0
        grey = np.clip(np.round(arr / top * 255.0), 0, 255).astype(np.uint8)
        alpha = np.full(grey.shape, 255, np.uint8)
        return np.stack([grey, grey, grey, alpha], axis=-1)
    if mode == "F":
        arr = np.asarray(img, dtype=np.float64)
        top = 1.0 if arr.max(initial=0) <= 1.0 else 255.0
        grey = np.clip(np.round(arr / top * 255.0), 0, 255).astype(np.uint8)
        alpha = np.full(grey.shape, 255, np.uint8)
        return np.stack([grey, grey, grey, alpha], axis=-1)
    if mode == "P" and "transparency" in img.info:
        img = img.convert("PA")
    return np.ascontiguousarray(np.asarray(img.convert("RGBA"), dtype=np.uint8))


def as_rgba(image) -> np.ndarray:
    """Accept an RGBA/RGB/grey numpy array or a PIL image; return ``(H, W, 4) uint8``."""
    if hasattr(image, "mode") and hasattr(image, "size"):  # a PIL image
        return _to_rgba(image)
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4):
        raise InputError(f"array of shape {arr.shape}: expected (H, W), (H, W, 3) or (H, W, 4)")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise InputError(f"array of shape {arr.shape}: image has zero size")
    if arr.dtype != np.uint8:
        if np.issubdtype(arr.dtype, np.floating) and arr.size and float(np.nanmax(arr)) <= 1.0:
            arr = np.round(np.nan_to_num(arr) * 255.0)
        arr = np.clip(arr, 0, 255).astype(np.uint8)
    channels = arr.shape[2]
    if channels == 1:
        arr = np.concatenate([arr, arr, arr, np.full_like(arr, 255)], axis=2)
    elif channels == 2:
        arr = np.concatenate([arr[..., :1]] * 3 + [arr[..., 1:]], axis=2)
    elif channels == 3:
        arr = np.concatenate([arr, np.full(arr.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return np.ascontiguousarray(arr)
