"""Stage 0b — preparing the input — RGBA as given → :class:`PreparedImage` (the 1× pixel art).

Pixel art as people have it is often not a clean 1× image: saved upscaled with
nearest-neighbour (every art pixel a k×k block), saved as JPEG (hundreds of near-identical
colours from ringing and chroma subsampling), drawn on a solid backdrop. This stage undoes
that before the similarity graph (docs/inputs.md has the how and the limits, with figures):

1. pixel grid: find the nearest-neighbour factor and grid offset of each axis (from the
   exact colour changes, or from luma edges for lossy input), and reduce every block to
   one pixel (its colour, or for lossy input the median of its inner pixels);
2. denoise (lossy input): snap near-identical colours to a small palette; for 1× pixels
   whose chroma was subsampled (4:2:0 JPEG, lossy WebP), label every pixel jointly
   through the decoder's model instead (depixel/prepare/chroma.py, depixel/prepare/chroma_unmix.py);
3. backdrop: make one colour fully transparent where it reaches the border (or everywhere).

A lossless input that looks anti-aliased or noisy gets a hint in ``notes`` instead
(:mod:`.noisy`): denoising is on by default only for files that say they are lossy.

Before them, an image with a ``background`` colour is composited over it. Each step is its
own module (:mod:`.pixelgrid`, :mod:`.palette` with :mod:`.chroma` and :mod:`.chroma_unmix`,
:mod:`.backdrop`); this one holds the driver :func:`prepare`, its options
(:class:`PrepareOptions`) and its product :class:`PreparedImage` (the overlay of the result on
the input is :mod:`depixel.render.overlay`).

On real 1× art the grid is never found and nothing else is on by default for a lossless
file, so the prepared image *is* the input and the output is byte-identical to
``pixel_size=1`` (``benchmarks/check_prepare.py`` checks it on every corpus image).

Coordinates: sizes and offsets are ``(x, y)`` pairs (horizontal first, as in "4×3"),
arrays are ``(row, column)``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, replace
from typing import cast

import numpy as np

from .. import validate
from ..colour import Colour, as_colour, parse_colour
from ..errors import ParameterError
from ..frozen import added, compact_repr
from .backdrop import Backdrop, hex_code, make_transparent, over_colour
from .image import DEFAULT_MAX_PIXELS, ImageSource, Pixels, as_rgba, check_pixels_given, load_image
from .noisy import noise_hint
from .palette import LEFTOVER_BLOCK, distinct_colours, snap_colours
from .pixelgrid import AUTO, MAX_FACTOR, block_medians, find_grid, reduce_blocks

PixelSize = str | int | tuple[int, int]


@dataclass(frozen=True)
class PrepareOptions:
    """How :func:`prepare` turns an image as given into the 1× art (docs/inputs.md), checked
    and normalized when made: a colour name becomes its ``(r, g, b)``, ``"4x3"`` becomes
    ``(4, 3)``. A bad value raises :class:`~depixel.errors.ParameterError` naming the field.
    Part of :class:`depixel.options.ConvertOptions`; every field is in a file's stamp
    (docs/design.md, Options, says how to add one)."""

    background: Colour | str | None = None  # composite over this opaque colour first (None: keep the alpha)
    pixel_size: PixelSize = AUTO  # "auto" (detect), or (x, y) input pixels per art pixel
    denoise: bool | None = None  # snap near-identical colours to a palette (None: when the input is lossy)
    transparent: str | Colour | None = None  # the backdrop colour made transparent, or "auto" (the corners')
    #: every pixel of the ``transparent`` colour, not only those joined to the border (added
    #: after the stamp's format: left out of it without a ``transparent`` colour)
    transparent_everywhere: bool = added(False, left_out=lambda options, value: options.transparent is None)

    def __post_init__(self) -> None:
        if self.denoise is not None and not isinstance(self.denoise, (bool, np.bool_)):
            raise ParameterError(f"denoise must be True, False or None, not {self.denoise!r}", parameter="denoise")
        normal = {"background": as_colour(self.background), "pixel_size": parse_pixel_size(self.pixel_size),
                  "denoise": None if self.denoise is None else bool(self.denoise),
                  "transparent": parse_transparent(self.transparent),
                  "transparent_everywhere": validate.flag("transparent_everywhere", self.transparent_everywhere)}
        for name, value in normal.items():
            object.__setattr__(self, name, value)


@dataclass(frozen=True, eq=False)
class PreparedImage:
    """The 1× pixel art the pipeline converts, and what was done to get it.

    ``rgba`` is ``(h, w, 4) uint8`` and read-only. ``pixel_size`` is ``(x, y)`` input
    pixels per art pixel, ``(1, 1)`` when the input was taken as it is; ``offset`` is
    where the first whole block starts (``0 <= offset < pixel_size``): a crop of an
    upscaled image has partial blocks at its edges, which still count as art pixels.
    """

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    rgba: np.ndarray
    input_size: tuple[int, int]  # (width, height) of the image as given
    pixel_size: tuple[int, int] = (1, 1)
    offset: tuple[int, int] = (0, 0)
    detected: bool = False  # the pixel size was found, not given
    lossy: str | None = None  # the lossy format the pixels came from ("JPEG"), if known
    colours_before: int = 0  # distinct colours before denoising (0: not denoised)
    palette: int = 0  # colours after denoising (0: not denoised)
    subsampling: str | None = None  # the chroma subsampling undone while denoising ("4:2:0"), if any
    transparent: Colour | None = None  # the colour made transparent
    transparent_pixels: int = 0  # art pixels made transparent
    transparent_kept: int = 0  # art pixels of that colour kept: inside the art, not joined to the border
    notes: tuple[str, ...] = ()  # what was looked for and not done, one phrase each

    @property
    def upscaled(self) -> bool:
        return self.pixel_size != (1, 1)

    @property
    def denoised(self) -> bool:
        return self.palette > 0

    @property
    def changed(self) -> bool:
        """Whether ``rgba`` differs from the input (anything was detected or applied)."""
        return self.upscaled or self.denoised or self.transparent_pixels > 0

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the 1× art."""
        return self.rgba.shape[1], self.rgba.shape[0]

    def viewbox(self) -> tuple[float, float, float, float]:
        """(x, y, width, height) of the input's area in art pixels: the viewBox that lays
        the converted art exactly over the input."""
        (kx, ky), (w, h) = self.pixel_size, self.input_size
        sx, sy = ((k - o) % k for k, o in zip(self.pixel_size, self.offset))
        return sx / kx, sy / ky, w / kx, h / ky

    def describe(self, name: str, kept_hint: str = "") -> str | None:
        """One line saying what was detected and done, or None when nothing was; ``kept_hint``
        follows the count of the backdrop's colour kept inside (how a front end removes it)."""
        parts = []
        if self.upscaled:
            factor = _factor_text(self.pixel_size)
            shift = f", grid offset {self.offset[0]},{self.offset[1]}" if any(self.offset) else ""
            how = "upscaled pixel art" if self.detected else "pixel art (pixel size given)"
            parts.append(f"{name} is {factor} {how}{shift}; converted its {self.size[0]}×{self.size[1]} pixels")
        if self.denoised:
            source = f"lossy {self.lossy}" if self.lossy else "denoised"
            unmixed = f" ({self.subsampling} chroma unmixed)" if self.subsampling else ""
            parts.append(f"{source}{unmixed}: snapped {self.colours_before} colours to {self.palette}")
        if self.transparent is not None:
            kept = f"; {self.transparent_kept} of that colour inside kept{kept_hint}" if self.transparent_kept else ""
            parts.append(f"made {hex_code(self.transparent)} transparent ({self.transparent_pixels} pixels{kept})")
        parts.extend(self.notes)
        if not parts:
            return None
        return ("" if self.upscaled else f"{name}: ") + "; ".join(parts)  # the first part names it

    def summary(self) -> dict:
        """What was detected and done, for JSON reports."""
        return {
            "input_size": list(self.input_size),
            "size": list(self.size),
            "pixel_size": list(self.pixel_size),
            "offset": list(self.offset),
            "detected": self.detected,
            "lossy": self.lossy,
            "colours_before": self.colours_before or None,
            "palette": self.palette or None,
            "subsampling": self.subsampling,
            "transparent": hex_code(self.transparent) if self.transparent is not None else None,
            "transparent_pixels": self.transparent_pixels,
            "transparent_kept": self.transparent_kept,
            "notes": list(self.notes),
        }


def prepare(image: Pixels, options: PrepareOptions | None = None, *, lossy: str | None = None,
            **changes) -> PreparedImage:
    """Turn an image as given into the 1× pixel art to convert.

    Parameters
    ----------
    image : array or PIL image (anything :func:`depixel.prepare.image.as_rgba` takes), or a
        :class:`PreparedImage` (returned as it is).
    options : the :class:`PrepareOptions` (None: the defaults); ``changes`` (their field names
        as keywords, as ``prepare(image, denoise=True)``) replace some of them:

        * ``background``: composite over this opaque colour first;
        * ``pixel_size``: ``"auto"`` (default) detects nearest-neighbour upscaling, ``1`` takes
          the pixels as they are, ``N`` or ``(x, y)`` or ``"NxM"`` forces that many input
          pixels per art pixel (the grid offset is still fitted);
        * ``denoise``: snap near-identical colours to a small palette; ``None`` (default) does
          it when ``lossy`` names the format the pixels came from (JPEG, lossy WebP);
        * ``transparent``: the backdrop colour (``(r, g, b)``, ``"#rrggbb"``, a CSS name), or
          ``"auto"``: the colour of the four corners when they agree. Its pixels joined to the
          border (4-connected) become fully transparent; the same colour inside the art stays;
        * ``transparent_everywhere``: make every pixel of that colour transparent (a colour key).
    lossy : the lossy format the pixels were decoded from, if any (see :func:`lossy_format`);
        a PIL image opened from a JPEG file says so itself.
    """
    options = replace(options or PrepareOptions(), **changes)  # (checked again: a change is checked too)
    if isinstance(image, PreparedImage):
        return image
    size = cast("str | tuple[int, int]", options.pixel_size)  # normalized: "auto" or (x, y)
    key_colour, denoise = options.transparent, options.denoise
    lossy = lossy or pil_lossy(image)
    rgba = as_rgba(image)
    if options.background is not None:
        rgba = over_colour(rgba, cast(Colour, options.background))  # (normalized: an (r, g, b))
    height, width = rgba.shape[:2]
    notes: list[str] = []

    lossy_pixels = denoise if denoise is not None else lossy is not None
    grid = find_grid(rgba, size, lossy=lossy_pixels)
    factor, offset = grid if grid is not None else ((1, 1), (0, 0))
    colours_before = palette = 0
    subsampling = None
    if lossy_pixels:
        colours_before = distinct_colours(rgba)
        if grid is None:
            rgba, _, palette, subsampling = snap_colours(rgba, unmix=True)
        else:  # block medians are clean colours: each art pixel counts, however rare its colour
            rgba, _, palette, _ = snap_colours(block_medians(rgba, grid), min_count=1.0, shadows=False,
                                               leftovers=min(factor) >= LEFTOVER_BLOCK)
    elif grid is not None:
        rgba = reduce_blocks(rgba, grid)
    if denoise is None and not lossy_pixels and (hint := noise_hint(rgba)) is not None:
        notes.append(hint)  # a lossless file that looks like a lossy one: say what denoise would do

    keyed = Backdrop(rgba, None, 0, 0, None) if key_colour is None else \
        make_transparent(rgba, key_colour, snapped=palette > 0, everywhere=options.transparent_everywhere)
    rgba = keyed.rgba
    if keyed.note:
        notes.append(keyed.note)

    rgba = np.array(rgba, dtype=np.uint8, order="C")  # a copy: the caller's array stays writable
    rgba.flags.writeable = False
    return PreparedImage(rgba, (width, height), factor, offset, detected=size == AUTO and factor != (1, 1),
                         lossy=lossy, colours_before=colours_before, palette=palette, subsampling=subsampling,
                         transparent=keyed.colour, transparent_pixels=keyed.pixels, transparent_kept=keyed.kept,
                         notes=tuple(notes))


# --- options ------------------------------------------------------------------------------------

def parse_pixel_size(value: PixelSize) -> str | tuple[int, int]:
    """``"auto"``, ``N``, ``"N"``, ``"NxM"`` or ``(x, y)`` → ``"auto"`` or ``(x, y)``."""
    if isinstance(value, str):
        text = value.strip().lower()
        if text == AUTO:
            return AUTO
        match = re.fullmatch(r"(\d+)(?:\s*[x×]\s*(\d+))?", text)
        if match is None:
            raise ParameterError(f"pixel_size must be auto, N or NxM (like 4 or 4x3), not {value!r}",
                                 parameter="pixel_size")
        x = int(match.group(1))
        pair = (x, int(match.group(2)) if match.group(2) else x)
    elif isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        pair = (int(value), int(value))
    elif isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, (int, np.integer)) for v in value):
        pair = (int(value[0]), int(value[1]))
    else:
        raise ParameterError(f"pixel_size must be auto, N or NxM (like 4 or 4x3), not {value!r}",
                             parameter="pixel_size")
    if not all(1 <= v <= MAX_FACTOR for v in pair):
        raise ParameterError(f"pixel_size must be between 1 and {MAX_FACTOR} on each axis, not "
                             f"{_factor_text(pair)}", parameter="pixel_size")
    return pair


def parse_transparent(value: str | Colour | None) -> str | Colour | None:
    """``None``, ``"auto"``, a colour string or an ``(r, g, b)`` triple → None, "auto" or (r, g, b)."""
    if value is None:
        return None
    if isinstance(value, str):
        if value.strip().lower() == AUTO:
            return AUTO
        try:
            return parse_colour(value)
        except ValueError:
            raise ParameterError(f"transparent: unknown colour {value!r} (use auto, #rgb, #rrggbb or a "
                                 "name like white)", parameter="transparent") from None
    if (isinstance(value, tuple) and len(value) in (3, 4)
            and all(isinstance(v, (int, np.integer)) and 0 <= v <= 255 for v in value)):
        return int(value[0]), int(value[1]), int(value[2])
    raise ParameterError(f"transparent must be auto, a colour name or (r, g, b), not {value!r}",
                         parameter="transparent")


#: formats whose pixels are lossy, as Pillow names them
_LOSSY_PIL_FORMATS = {"JPEG": "JPEG", "MPO": "JPEG", "JPEG2000": "JPEG 2000"}


def pil_lossy(image) -> str | None:
    """The lossy format a PIL image was opened from ("JPEG"), or None (arrays, lossless
    files, and WebP, whose PIL image does not say whether it was lossy)."""
    return _LOSSY_PIL_FORMATS.get(getattr(image, "format", None) or "")


def lossy_format(data: bytes) -> str | None:
    """The lossy format of an image file's bytes ("JPEG", "JPEG 2000", "WebP"), or None
    for lossless formats. WebP is lossy when its image chunk is ``VP8 `` (``VP8L`` is the
    lossless coding)."""
    head = bytes(data[:16])
    if head.startswith(b"\xff\xd8\xff"):
        return "JPEG"
    if head.startswith(b"\x00\x00\x00\x0cjP  \r\n\x87\n") or head.startswith(b"\xff\x4f\xff\x51"):
        return "JPEG 2000"
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        pos = 12
        while pos + 8 <= len(data):  # walk the chunks: VP8X and ICCP may come first
            tag, size = bytes(data[pos:pos + 4]), int.from_bytes(data[pos + 4:pos + 8], "little")
            if tag == b"VP8 ":
                return "WebP"
            if tag == b"VP8L":
                return None
            pos += 8 + size + (size & 1)
    return None




def _factor_text(pair: tuple[int, int]) -> str:
    return f"{pair[0]}×" if pair[0] == pair[1] else f"{pair[0]}×{pair[1]}"


def flatten(image: Pixels, colour: Colour | str) -> np.ndarray:
    """Composite an image over an opaque colour → ``(H, W, 4) uint8`` with alpha 255.

    Useful before converting art whose semi-transparent edges should blend into a known
    background instead of becoming separate translucent shapes.
    """
    rgb = as_colour(colour)
    if rgb is None:
        raise ParameterError("background must be a colour name or an (r, g, b) triple, not None",
                             parameter="background")
    check_pixels_given(image, max_pixels=None)
    return over_colour(as_rgba(image), rgb)


def load(source: ImageSource, *, frame: int = 0, background: Colour | str | None = None,
         max_pixels: int | None = DEFAULT_MAX_PIXELS) -> np.ndarray:
    """Read an image file (path, bytes or binary file) → ``(H, W, 4) uint8`` RGBA,
    flattened over ``background`` when given."""
    colour = as_colour(background)
    rgba = load_image(source, max_pixels=max_pixels, frame=frame)
    return rgba if colour is None else flatten(rgba, colour)
