"""Stage 0 — input: any image Pillow reads, or an Aseprite file (:mod:`.aseprite`) → RGBA
uint8 array (the YUV space is in :mod:`depixel.colour`). The frames of a GIF or an APNG are
those a browser shows (composited by :mod:`.gif` and :mod:`.apng`, not by Pillow), so
``--frames N`` and ``--animate`` read the same pictures."""
from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, BinaryIO, TypeAlias

import numpy as np

from ..errors import InputError, ParameterError, display_name
from ..limits import (  # noqa: F401 (DEFAULT_MAX_PIXELS, check_pixels: re-exported)
    DEFAULT_MAX_FRAMES,
    DEFAULT_MAX_PIXELS,
    MAX_FILE_BYTES,
    MAX_INDEXED_PIXELS,
    check_frame_index,
    check_frames,
    check_frames_pixels,
    check_pixels,
)
from . import apng, gif
from .pillow import bomb_error, is_bomb, mute_stderr_fd, open_image, quiet_pillow, to_rgba

ImageSource = str | os.PathLike | bytes | bytearray | memoryview | BinaryIO

if TYPE_CHECKING:
    from numpy.typing import ArrayLike
    from PIL.Image import Image as PILImage
#: pixels as the API takes them: an array (``(H, W)``, ``(H, W, 2|3|4)``; :func:`as_rgba`) or a PIL image
Pixels: TypeAlias = "ArrayLike | PILImage"

def _describe(source: ImageSource, name: str | None = None) -> str:
    if name is not None:
        return name
    if isinstance(source, (str, os.PathLike)):
        return display_name(source)
    return "<bytes>" if isinstance(source, (bytes, bytearray, memoryview)) else "<stdin>"


def load_image(source: ImageSource, max_pixels: int | None = DEFAULT_MAX_PIXELS, frame: int = 0, *,
               max_frames: int | None = DEFAULT_MAX_FRAMES, name: str | None = None) -> np.ndarray:
    """Read one frame of an image into an ``(H, W, 4) uint8`` RGBA array, alpha kept.

    ``source`` is a path, raw file bytes or a binary file object: an image Pillow reads, or
    an Aseprite file (its frame composited, :mod:`depixel.prepare.aseprite`). Every Pillow mode is
    accepted (docs/colour.md, "Input modes"): palette and grey images with a tRNS
    transparency key keep it as alpha, 16-bit and 32-bit data are scaled to 8 bits.
    The size of the frame (or page) decoded is checked against ``max_pixels`` (``None``:
    only Pillow's decompression-bomb guard) from its header, before any pixel is decoded.
    Frame N of an animation decodes the N before it: N must be under ``max_frames``.
    Anything unreadable raises :class:`InputError` with a one-line message naming the file
    (``name``: how to name it, e.g. a file whose bytes are given).
    """
    from ..validate import number  # noqa: PLC0415

    number("frame", frame, low=0, integer=True)
    for _, rgba, _info in _frames(source, max_pixels, int(frame), max_frames, name):
        return rgba
    raise AssertionError("unreachable: _frames yields the frame or raises")


def load_frames(source: ImageSource, max_pixels: int | None = DEFAULT_MAX_PIXELS, *,
                max_frames: int | None = DEFAULT_MAX_FRAMES, name: str | None = None):
    """Every frame of an (animated) image in order, each decoded once: yields ``(index,
    (H, W, 4) uint8 RGBA)``. The file is read once and the frames are decoded sequentially,
    so the cost is linear in the number of frames. Before the first is decoded, the frames
    the header declares are checked against ``max_frames`` and their pixels in all against
    ``max_pixels`` (each frame's own size is added as it comes: TIFF pages differ)."""
    for index, rgba, _info in _frames(source, max_pixels, None, max_frames, name):
        yield index, rgba


def _frames(source: ImageSource, max_pixels: int | None, only: int | None, max_frames: int | None,
            name: str | None):
    """Frames ``only`` (one index) or all of them, as :func:`load_frames` describes, each with
    Pillow's ``info`` of that frame (its duration, the loop count: :mod:`.animation` reads them)."""
    from ..validate import limit  # noqa: PLC0415

    max_pixels = limit("max_pixels", max_pixels)
    max_frames = limit("max_frames", max_frames)
    name = _describe(source, name)
    data = read_source(source)
    if _is_aseprite(data):
        from .aseprite_compose import aseprite_frames  # noqa: PLC0415 (~15 ms to import: only for Aseprite files)
        from .aseprite_format import parse_aseprite  # noqa: PLC0415

        ase = parse_aseprite(data, name, max_pixels)
        for index, rgba in aseprite_frames(ase, only, max_pixels, max_frames):
            yield index, rgba, {"duration": ase.durations[index], "tags": ase.tags}  # as Pillow's info, and tags
        return
    if only is not None:
        check_frame_index(name, only, max_frames)
    # frame N decodes the N before it, but only all frames are counted in all
    parsed = parse_animated(data, name, max_pixels, max_frames if only is None else None, whole=only is None)
    if parsed is not None:
        delays = [frame.delay for frame in parsed.frames]
        if only is not None and only >= len(delays):
            raise InputError(f"{name}: has {len(delays)} frame(s), no frame {only}")
        for index, rgba in enumerate(composite(parsed, name)):
            if only is None or index == only:
                yield index, rgba, {"duration": delays[index]}
            if index == only:
                return
        return
    with quiet_pillow(), open_image(data, name) as img:
        width, height = img.size
        check_pixels(name, width, height, max_pixels)
        try:
            n_frames = int(getattr(img, "n_frames", 1))
        except Exception:
            raise InputError(f"{name}: truncated or corrupt image data") from None
        if only is None:
            check_frames(name, n_frames, max_frames)
            check_frames_pixels(name, n_frames, n_frames * width * height, max_pixels)
        elif only >= n_frames:
                raise InputError(f"{name}: has {n_frames} frame(s), no frame {only}")
        total = 0
        for index in range(n_frames) if only is None else (only,):
            try:
                with mute_stderr_fd(img.format == "TIFF"):  # libtiff prints its complaints there
                    if index:
                        img.seek(index)  # the next frame after the previous one: no re-reading
                    # a page of a TIFF (or a frame of an APNG) has its own size: check it too
                    width, height = img.size
                    check_pixels(name, width, height, max_pixels)
                    total += width * height
                    if only is None:
                        check_frames_pixels(name, index + 1, total, max_pixels)
                    img.load()
            except InputError:
                raise
            except MemoryError:
                raise InputError(f"{name}: not enough memory to decode a {img.size[0]}x{img.size[1]} image") from None
            except Exception as exc:  # Pillow raises OSError, SyntaxError, ValueError, zlib.error, ...
                if is_bomb(exc):
                    raise bomb_error(name) from None
                raise InputError(f"{name}: truncated or corrupt image data") from None
            yield index, to_rgba(img, name), dict(img.info)


def frame_count(source: ImageSource, max_frames: int | None = None, *, name: str | None = None) -> int:
    """Number of frames in an (animated) image; 1 for still images. Over ``max_frames``
    (to convert every one) is refused, before anything is made per frame."""
    name = _describe(source, name)
    data = read_source(source)
    if _is_aseprite(data):
        from .aseprite_format import parse_aseprite  # noqa: PLC0415

        n_frames = parse_aseprite(data, name, None).n_frames
    elif (parsed := parse_animated(data, name, None, max_frames, whole=False)) is not None:
        n_frames = len(parsed.frames)
    else:
        with quiet_pillow(), open_image(data, name) as img:
            try:
                n_frames = int(getattr(img, "n_frames", 1))
            except Exception:
                raise InputError(f"{name}: truncated or corrupt image data") from None
    check_frames(name, n_frames, max_frames)
    return n_frames


def parse_animated(data: bytes, name: str, max_pixels: int | None, max_frames: int | None,
                   whole: bool = True) -> gif.GifFile | apng.ApngFile | None:
    """A GIF or an APNG walked (nothing decoded) and checked against the limits: its frames
    within ``max_frames``, the canvas and each frame within ``max_pixels`` and, when the
    ``whole`` animation is to be decoded, the frames' pixels in all too; None for any other
    format. :func:`composite` gives its frames."""
    if data.startswith(gif.SIGNATURES):
        found = gif.parse_gif(data, name, max_frames)
        gif.check_gif(found, name, max_pixels, whole)
        return found
    if apng.is_apng(data):
        png = apng.parse_apng(data, name, max_frames)
        apng.check_apng(png, name, max_pixels, whole)
        return png
    return None


def composite(parsed: gif.GifFile | apng.ApngFile, name: str) -> Iterator[np.ndarray]:
    """The frames of a GIF or an APNG of :func:`parse_animated` as a browser shows them, in
    order, each decoded when asked for."""
    if isinstance(parsed, gif.GifFile):
        return gif.composite(parsed, name)
    return apng.composite(parsed, name)


def _is_aseprite(data: bytes) -> bool:
    """Whether ``data`` starts like an Aseprite file: its magic number 0xA5E0 at byte 4
    (:func:`depixel.prepare.aseprite_format.is_aseprite`, not imported for every image)."""
    return data[4:6] == b"\xe0\xa5"


def read_source(source: ImageSource) -> bytes:
    """All bytes of a path, bytes or binary file object; :class:`InputError` for a missing,
    empty or unreadable file, a folder, a device, or more than MAX_FILE_BYTES (so an endless
    stream such as ``cat /dev/zero |`` fails fast instead of filling the memory). A named
    pipe is read when something writes to it (``<(cat sprite.png)``); one nothing writes to
    fails at once instead of waiting (:func:`open_input`)."""
    name = _describe(source)
    try:
        if isinstance(source, (bytes, bytearray, memoryview)):
            data = bytes(source)
        elif isinstance(source, (str, os.PathLike)):
            with open_input(source, name) as fh:
                data = fh.read(MAX_FILE_BYTES + 1)
                if not data and stat.S_ISFIFO(os.fstat(fh.fileno()).st_mode):
                    raise InputError(f"{name}: a pipe nothing was written to")
        elif hasattr(source, "read"):
            data = source.read(MAX_FILE_BYTES + 1)
        else:
            raise TypeError(f"expected a path, bytes or a binary file object, not {type(source).__name__}")
    except InputError:
        raise
    except PermissionError:
        raise InputError(f"{name}: permission denied") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path, a closed file
        reason = getattr(exc, "strerror", None) or str(exc)
        raise InputError(f"{name}: cannot read ({reason})") from None
    if not isinstance(data, bytes):
        raise InputError(f"{name}: not a binary file object")
    if not data:
        raise InputError(f"{name}: empty file")
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"{name}: over {MAX_FILE_BYTES // 2**20} MiB, too large for pixel art")
    return data


def open_input(path: str | os.PathLike, name: str, regular: bool = False) -> BinaryIO:
    """``path`` open for reading, checked on the descriptor opened (what it is when read, not
    when looked at): a folder or a device is an :class:`InputError`, and so is anything but a
    regular file with ``regular``. Opening never waits for a writer of a named pipe (a
    batch's input swapped for one must fail, not hang): one nobody writes to reads as empty.
    A device is refused before it is opened too (opening a tape rewinds it)."""
    try:
        _check_kind(name, os.stat(path).st_mode, regular)
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    try:
        _check_kind(name, os.fstat(fd).st_mode, regular)
        os.set_blocking(fd, True)  # a pipe with a writer is then read to its end
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _check_kind(name: str, mode: int, regular: bool) -> None:
    if stat.S_ISDIR(mode):
        raise InputError(f"{name}: is a directory, not a file")
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        raise InputError(f"{name}: is a device, not a file")
    if regular and not stat.S_ISREG(mode):
        raise InputError(f"{name}: is not a regular file")


def check_indexable(name: str, width: int, height: int) -> None:
    """Refuse an image too large for the pipeline's 32-bit indices (``limits.MAX_INDEXED_PIXELS``),
    whatever ``max_pixels`` allows."""
    if width * height > MAX_INDEXED_PIXELS:
        raise InputError(f"{name}: {width}x{height} is {width * height} pixels, over the "
                         f"{MAX_INDEXED_PIXELS} that depixel's 32-bit indices can address")


def as_rgba(image: Any) -> np.ndarray:
    """Accept a numpy array or a PIL image; return ``(H, W, 4) uint8`` RGBA.

    Arrays are ``(H, W)`` grey, ``(H, W, 2)`` grey + alpha, ``(H, W, 3)`` RGB or
    ``(H, W, 4)`` RGBA. ``uint8`` is taken as is, ``uint16`` is scaled from 0-65535,
    ``bool`` maps to 0/255, floats are on a 0-1 scale when none exceeds 1 (else 0-255, like
    other integer types), and everything is clipped to 0-255. Ragged nested lists and NaN or
    infinite values are refused (:class:`InputError`): they are no picture.
    """
    if hasattr(image, "mode") and hasattr(image, "size"):  # a PIL image
        check_indexable("<image>", *image.size)
        try:
            image.load()
        except Exception:
            raise InputError("<image>: truncated or corrupt image data") from None
        return to_rgba(image)
    arr = image_array(image)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4):
        raise InputError(f"array of shape {arr.shape}: expected (H, W), (H, W, 2), (H, W, 3) or (H, W, 4)")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise InputError(f"array of shape {arr.shape}: image has zero size")
    check_indexable(f"array of shape {arr.shape}", arr.shape[1], arr.shape[0])
    if arr.dtype.kind not in "biuf":
        raise InputError(f"array of dtype {arr.dtype}: expected integer, float or bool pixels")
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8) * 255
    elif arr.dtype == np.uint16:
        arr = np.round(arr / 257.0)
    elif arr.dtype.kind == "f":
        if not np.isfinite(arr).all():
            raise InputError(f"array of shape {arr.shape}: has NaN or infinite values; pixels must be finite")
        arr = arr.astype(np.float64)
        arr = np.round(arr * 255.0) if arr.max() <= 1.0 else np.round(arr)
    if arr.dtype != np.uint8:
        arr = np.clip(arr, 0, 255).astype(np.uint8)
    channels = arr.shape[2]
    if channels == 1:
        arr = np.concatenate([arr, arr, arr, np.full_like(arr, 255)], axis=2)
    elif channels == 2:
        arr = np.concatenate([arr[..., :1]] * 3 + [arr[..., 1:]], axis=2)
    elif channels == 3:
        arr = np.concatenate([arr, np.full(arr.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return np.ascontiguousarray(arr)


def image_array(image: object) -> np.ndarray:
    """``np.asarray(image)``, with an :class:`InputError` for what is no array of numbers (a
    ragged nested list, where numpy raises a bare ValueError)."""
    try:
        return np.asarray(image)
    except (ValueError, TypeError) as exc:
        reason = "rows of different lengths" if "inhomogeneous" in str(exc) else str(exc).splitlines()[0]
        raise InputError(f"not an image array ({reason}); expected (H, W) or (H, W, C) numbers") from None


def check_pixels_given(image: object, name: str = "<image>", max_pixels: int | None = DEFAULT_MAX_PIXELS) -> None:
    """Refuse what is not an image in memory (a file name gets a pointer to the file
    functions) and images over ``max_pixels``, before any conversion copies them."""
    if isinstance(image, (str, os.PathLike)):
        raise ParameterError(f"{display_name(image)}: convert takes pixels (a numpy array or a PIL image), "
                             "not a file name; use depixel.convert_file(path, output) or "
                             "depixel.api.load(path)", parameter="image")
    if isinstance(image, (bytes, bytearray, memoryview)):
        raise ParameterError("convert takes pixels (a numpy array or a PIL image), not file bytes; "
                             "decode them with depixel.api.load(data)", parameter="image")
    size = image.size if hasattr(image, "mode") and hasattr(image, "size") else image_array(image).shape[1::-1]
    if len(size) == 2:
        from ..validate import limit  # noqa: PLC0415

        check_pixels(name, int(size[0]), int(size[1]), limit("max_pixels", max_pixels))
        check_indexable(name, int(size[0]), int(size[1]))
