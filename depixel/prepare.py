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
   through the decoder's model instead (depixel/chroma.py);
3. backdrop: make one colour fully transparent.

On real 1× art the grid is never found and nothing else is on by default for a lossless
file, so the prepared image *is* the input and the output is byte-identical to
``pixel_size=1`` (``benchmarks/check_prepare.py`` checks it on every corpus image).

Coordinates: sizes and offsets are ``(x, y)`` pairs (horizontal first, as in "4×3"),
arrays are ``(row, column)``.
"""
from __future__ import annotations

import heapq
import re
from dataclasses import dataclass

import numpy as np

from . import chroma
from .errors import ParameterError
from .image import as_rgba, rgb_to_yuv

# --- constants (none is in the paper: this stage is not part of it) ----------------------------
#: largest nearest-neighbour factor looked for or accepted, per axis
MAX_FACTOR = 32
#: a detected axis needs at least this many block boundaries where the art changes colour,
#: so a few coincidentally aligned edges (a lone rectangle) are never taken for a grid
MIN_EVIDENCE = 3
#: lossy input: a luma step (0-255) over this between neighbours is an edge, if the steps
#: on either side are no larger (ringing beside an edge is weaker than the edge)
LOSSY_EDGE = 24.0
#: lossy input: at most this share of the edges may lie off the grid; measured on the paper
#: sprites at 2×–8× with random offsets, JPEG q70–95: ≤ 0.15; the best grid of any 1× JPEG
#: leaves ≥ 0.32 off it (docs/inputs.md)
LOSSY_OFF_GRID = 0.25
#: lossy input: at least this share of pixels must lie within LOSSY_EDGE luma of their block's median
LOSSY_BLOCK_AGREEMENT = 0.9
#: colours within this distance (hqx YUV, largest component, 0-255) are one palette colour
SNAP_RADIUS = 10.0
#: a palette candidate within this luma distance of a candidate SHADOW_RATIO times as
#: frequent is chroma bleeding from 4:2:0 subsampling (a tinted copy), not a colour of its own
SHADOW_LUMA = 10.0
SHADOW_RATIO = 2.0
#: a palette colour covers at least this share of the visible pixels (and at least 3 pixels)
MIN_SHARE = 0.005
#: pixels snap to the nearest palette colour with chroma counted this much: JPEG keeps luma
#: per pixel but chroma only per 2×2 block (4:2:0), so chroma is the less reliable half
CHROMA_WEIGHT = 0.3
#: clean colours (block medians) farther than this many SNAP_RADIUS from their palette colour
#: are gathered again into colours of their own (a box reaches up to 1.5 radii: sbm4_01's white
#: lies 17 from its off-white); only for blocks of at least LEFTOVER_BLOCK pixels a side, whose
#: median is taken over at least 2×2 inner pixels (a 3× block's single inner pixel still
#: carries JPEG's chroma bleeding: the ghost fixture saved 3× at q85 would gain two stray colours)
LEFTOVER = 1.5
LEFTOVER_BLOCK = 4
#: rounds of moving each palette colour to the mean of the pixels it gathers
REFINE_STEPS = 2

AUTO = "auto"
PixelSize = str | int | tuple[int, int]
Colour = tuple[int, int, int]


@dataclass(frozen=True, eq=False)
class PreparedImage:
    """The 1× pixel art the pipeline converts, and what was done to get it.

    ``rgba`` is ``(h, w, 4) uint8`` and read-only. ``pixel_size`` is ``(x, y)`` input
    pixels per art pixel, ``(1, 1)`` when the input was taken as it is; ``offset`` is
    where the first whole block starts (``0 <= offset < pixel_size``): a crop of an
    upscaled image has partial blocks at its edges, which still count as art pixels.
    """

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

    def describe(self, name: str) -> str | None:
        """One line saying what was detected and done, or None when nothing was."""
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
            parts.append(f"made {_hex(self.transparent)} transparent ({self.transparent_pixels} pixels)")
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
            "transparent": _hex(self.transparent) if self.transparent is not None else None,
            "transparent_pixels": self.transparent_pixels,
            "notes": list(self.notes),
        }


def prepare(image, *, pixel_size: PixelSize = AUTO, denoise: bool | None = None,
            transparent: str | Colour | None = None, lossy: str | None = None) -> PreparedImage:
    """Turn an image as given into the 1× pixel art to convert.

    Parameters
    ----------
    image : array or PIL image (anything :func:`depixel.image.as_rgba` takes), or a
        :class:`PreparedImage` (returned as it is).
    pixel_size : ``"auto"`` (default) detects nearest-neighbour upscaling, ``1`` takes the
        pixels as they are, ``N`` or ``(x, y)`` or ``"NxM"`` forces that many input pixels
        per art pixel (the grid offset is still fitted).
    denoise : snap near-identical colours to a small palette; ``None`` (default) does it
        when ``lossy`` names the format the pixels came from (JPEG, lossy WebP).
    transparent : a colour (``(r, g, b)``, ``"#rrggbb"``, a CSS name) to make fully
        transparent, or ``"auto"``: the colour of the four corners when they agree.
    lossy : the lossy format the pixels were decoded from, if any (see :func:`lossy_format`);
        a PIL image opened from a JPEG file says so itself.
    """
    if isinstance(image, PreparedImage):
        return image
    size = parse_pixel_size(pixel_size)
    key_colour = parse_transparent(transparent)
    lossy = lossy or pil_lossy(image)
    rgba = as_rgba(image)
    height, width = rgba.shape[:2]
    notes: list[str] = []

    lossy_pixels = denoise if denoise is not None else lossy is not None
    grid = find_grid(rgba, size, lossy=lossy_pixels)
    factor, offset = grid if grid is not None else ((1, 1), (0, 0))
    colours_before = palette = 0
    subsampling = None
    if lossy_pixels:
        colours_before = _distinct_colours(rgba)
        if grid is None:
            rgba, _, palette, subsampling = snap_colours(rgba, unmix=True)
        else:  # block medians are clean colours: each art pixel counts, however rare its colour
            rgba, _, palette, _ = snap_colours(block_medians(rgba, grid), min_count=1.0, shadows=False,
                                               leftovers=min(factor) >= LEFTOVER_BLOCK)
    elif grid is not None:
        rgba = reduce_blocks(rgba, grid)

    keyed, n_keyed = None, 0
    if key_colour is not None:
        rgba, keyed, n_keyed, note = make_transparent(rgba, key_colour, snapped=palette > 0)
        if note:
            notes.append(note)

    rgba = np.array(rgba, dtype=np.uint8, order="C")  # a copy: the caller's array stays writable
    rgba.flags.writeable = False
    return PreparedImage(rgba, (width, height), factor, offset, detected=size == AUTO and factor != (1, 1),
                         lossy=lossy, colours_before=colours_before, palette=palette, subsampling=subsampling,
                         transparent=keyed,
                         transparent_pixels=n_keyed, notes=tuple(notes))


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
        from .api import parse_colour  # noqa: PLC0415 (api imports this module)

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


# --- the pixel grid ---------------------------------------------------------------------------

def colour_keys(rgba: np.ndarray) -> np.ndarray:
    """``(H, W) int64``: equal exactly when two pixels look the same (RGBA equal, or both
    fully transparent whatever RGB they hide)."""
    q = rgba.astype(np.int64)
    keys = (q[..., 0] << 24) | (q[..., 1] << 16) | (q[..., 2] << 8) | q[..., 3]
    return np.where(q[..., 3] == 0, 0, keys)


Grid = tuple[tuple[int, int], tuple[int, int]]  # ((kx, ky), (ox, oy))


def find_grid(rgba: np.ndarray, pixel_size: str | tuple[int, int] = AUTO, lossy: bool = False) -> Grid | None:
    """The nearest-neighbour grid of an ``(H, W, 4)`` image, ``((kx, ky), (ox, oy))``, or None.

    Across a block boundary the art may change colour; inside a block it may not. So a
    factor k with offset o fits an axis when every colour change between neighbouring
    pixels along it lies at a position p ≡ o (mod k) (p: the pixel after the change), and
    the largest fitting k ≤ 32 with ``MIN_EVIDENCE`` changing boundaries is taken; both
    axes must fit. For ``lossy`` input a change is a luma edge (``LOSSY_EDGE``), up to
    ``LOSSY_OFF_GRID`` of them may lie off the grid, and ``LOSSY_BLOCK_AGREEMENT`` of the
    pixels must be close to their block's median. A forced ``(kx, ky)`` gets the offset
    whose boundaries carry the most changes.
    """
    if lossy:
        luma = rgb_to_yuv(rgba)[..., 0]
        change = (_edge_share(luma), _edge_share(luma.T))
    else:
        keys = colour_keys(rgba)
        change = (_change_share(keys), _change_share(keys.T))
    if not isinstance(pixel_size, str):  # forced
        if pixel_size == (1, 1):
            return None
        return pixel_size, (_best_offset(change[0], pixel_size[0]), _best_offset(change[1], pixel_size[1]))
    fits = [_fit_axis(c, LOSSY_OFF_GRID if lossy else 0.0) for c in change]
    if fits[0] is None or fits[1] is None:
        return None
    grid = (fits[0][0], fits[1][0]), (fits[0][1], fits[1][1])
    if lossy and _median_agreement(rgba, luma, grid) < LOSSY_BLOCK_AGREEMENT:
        return None
    return grid


def _change_share(keys: np.ndarray) -> np.ndarray:
    """For each boundary between columns i and i+1, the share of rows where the colour changes."""
    return (keys[:, 1:] != keys[:, :-1]).mean(axis=0)


def _edge_share(luma: np.ndarray) -> np.ndarray:
    """Like :func:`_change_share` for lossy pixels: the share of rows with a luma edge,
    a step over LOSSY_EDGE that is no smaller than the steps on either side of it (the
    ringing beside an edge is weaker than the edge)."""
    step = np.abs(np.diff(luma, axis=1))
    edge = step > LOSSY_EDGE
    edge[:, 1:] &= step[:, 1:] >= step[:, :-1]  # no smaller than the step before it
    edge[:, :-1] &= step[:, :-1] >= step[:, 1:]  # ... and the step after it
    return edge.mean(axis=0)


def _offset_mass(change: np.ndarray, k: int) -> np.ndarray:
    """``(k,)``: the colour changes at boundary positions p ≡ o (mod k), for each o.
    Boundary i lies before pixel p = i + 1."""
    return np.bincount(np.arange(1, change.size + 1) % k, weights=change, minlength=k)


def _fit_axis(change: np.ndarray, off_grid: float) -> tuple[int, int] | None:
    """(k, o) of the largest factor that fits one axis, or None (see :func:`find_grid`)."""
    where = np.flatnonzero(change) + 1  # positions with a colour change before them
    if off_grid == 0.0:  # exact: every change on the grid, so k divides all their spacings
        if where.size < MIN_EVIDENCE:
            return None
        spacing = int(np.gcd.reduce(np.diff(where)))
        k = max((d for d in range(2, min(MAX_FACTOR, spacing) + 1) if spacing % d == 0), default=1)
        return (k, int(where[0] % k)) if k > 1 else None
    # every factor at once: the changes at each (k, offset), k = 2 … top, in one bincount
    top = min(MAX_FACTOR, change.size)
    factors = np.arange(2, top + 1)
    first = np.concatenate([[0], np.cumsum(factors)])[:-1]  # where each factor's offsets start
    position = np.arange(1, change.size + 1)
    slot = (first[:, None] + position[None, :] % factors[:, None]).ravel()
    mass = np.bincount(slot, weights=np.tile(change, len(factors)), minlength=int(factors.sum()))
    evidence = np.bincount(slot, weights=np.tile(change > 0, len(factors)).astype(np.float64),
                           minlength=int(factors.sum()))
    total = float(change.sum())
    best = np.maximum.reduceat(mass, first)  # each factor's best offset's changes
    for i in np.flatnonzero(total - best <= off_grid * total)[::-1]:  # the largest fitting factor wins
        o = int(np.argmax(mass[first[i]:first[i] + factors[i]]))
        if evidence[first[i] + o] >= MIN_EVIDENCE:
            return int(factors[i]), o
    return None


def _best_offset(change: np.ndarray, k: int) -> int:
    """The offset whose boundaries carry the most colour changes (0 on ties)."""
    return int(np.argmax(_offset_mass(change, k))) if k > 1 else 0


def _blocks(shape: tuple[int, int], grid: Grid) -> tuple[np.ndarray, tuple[int, int]]:
    """The block of every pixel, ``(H*W,)`` in scanline order, and the blocks' grid shape.
    A partial block at an edge is a block."""
    (kx, ky), (ox, oy) = grid
    bx = (np.arange(shape[1]) + (kx - ox) % kx) // kx
    by = (np.arange(shape[0]) + (ky - oy) % ky) // ky
    grid_shape = (int(by[-1]) + 1, int(bx[-1]) + 1)
    return (by[:, None] * grid_shape[1] + bx[None, :]).ravel(), grid_shape


def reduce_blocks(rgba: np.ndarray, grid: Grid) -> np.ndarray:
    """``(h, w, 4)``: one pixel per block, of the block's most common colour (ties: the
    lower colour key)."""
    block, (gh, gw) = _blocks(rgba.shape[:2], grid)
    colours, first_pixel, colour_id = np.unique(colour_keys(rgba).ravel(), return_index=True,
                                                return_inverse=True)
    pairs, counts = np.unique(block * colours.size + colour_id.ravel(), return_counts=True)
    pair_block = pairs // colours.size
    order = np.lexsort((-counts, pair_block))  # per block, the most common colour first
    first = order[np.r_[True, pair_block[order][1:] != pair_block[order][:-1]]]
    return rgba.reshape(-1, 4)[first_pixel[pairs[first] % colours.size]].reshape(gh, gw, 4)


def block_medians(rgba: np.ndarray, grid: Grid) -> np.ndarray:
    """``(h, w, 4)``: one pixel per block, each channel the (lower) median of the block's
    inner pixels (all of them when the block is too thin to have any): the block's colour
    without the ringing and the chroma blur along its edges."""
    (kx, ky), (ox, oy) = grid
    block, (gh, gw) = _blocks(rgba.shape[:2], grid)
    inner_x = _inner(rgba.shape[1], kx, ox)
    inner_y = _inner(rgba.shape[0], ky, oy)
    inner = (inner_y[:, None] & inner_x[None, :]).ravel()
    has_inner = np.bincount(block[inner], minlength=gh * gw) > 0
    use = inner | ~has_inner[block]
    return _medians(rgba.reshape(-1, 4)[use], block[use], gh * gw).reshape(gh, gw, 4)


def _inner(n: int, k: int, o: int) -> np.ndarray:
    """``(n,)`` bool: pixels not on the first or last line of their block (blocks of k ≥ 3)."""
    if k < 3:
        return np.ones(n, dtype=bool)
    place = (np.arange(n) + (k - o) % k) % k
    return (place > 0) & (place < k - 1)


def _medians(pixels: np.ndarray, group: np.ndarray, n_groups: int) -> np.ndarray:
    """``(n_groups, 4) uint8``: per group the (lower) median of each channel of ``pixels``."""
    size = np.bincount(group, minlength=n_groups)
    middle = np.cumsum(size) - size + (size - 1) // 2
    out = np.empty((n_groups, 4), dtype=np.uint8)
    for c in range(4):
        ordered = np.sort(group * 256 + pixels[:, c])  # by group, then by value
        out[:, c] = ordered[middle] & 255
    return out


def _median_agreement(rgba: np.ndarray, luma: np.ndarray, grid: Grid) -> float:
    """Share of pixels whose luma lies within LOSSY_EDGE of their block median's."""
    block, _ = _blocks(rgba.shape[:2], grid)
    block_luma = rgb_to_yuv(block_medians(rgba, grid).reshape(-1, 4))[:, 0]
    return float(np.mean(np.abs(luma.ravel() - block_luma[block]) <= LOSSY_EDGE))


# --- denoising ----------------------------------------------------------------------------------

def _distinct_colours(rgba: np.ndarray) -> int:
    return int(np.unique(colour_keys(rgba)).size)


def snap_colours(rgba: np.ndarray, min_count: float | None = None, shadows: bool = True,
                 unmix: bool = False, leftovers: bool = False) -> tuple[np.ndarray, int, int, str | None]:
    """Snap the visible pixels' colours to a small palette (alpha is kept).

    Returns the snapped ``(H, W, 4) uint8`` image, the number of distinct colours before,
    the palette size and the chroma subsampling that was undone (``"4:2:0"``, or None). The
    palette is found by mode seeking in hqx YUV: the colour with the most pixels within
    about ``SNAP_RADIUS`` becomes a palette colour and takes those pixels, and so on while a
    colour gathers ``min_count`` pixels (default: ``MIN_SHARE`` of them, at least 3); with
    ``shadows``, a candidate is skipped when it is a tinted copy of a more frequent colour
    of the same luma (``SHADOW_*``: chroma bleeding of 4:2:0 subsampling, which block
    medians no longer have). Each palette colour then moves to the mean of the pixels it
    gathers, and every pixel takes the nearest palette colour, chroma weighted by
    ``CHROMA_WEIGHT``. With ``leftovers`` (clean colours, like the medians of large blocks),
    colours left farther than ``LEFTOVER`` radii from their palette colour are gathered again
    into colours of their own. With ``unmix`` (decoded 1× pixels), when the chroma was subsampled
    (:func:`depixel.chroma.chroma_grid`), the pixels' colours and the palette are then
    found jointly through the decoder's model instead (:func:`depixel.chroma.unmix`).
    """
    visible = rgba[..., 3] > 0
    rgb = rgba[..., :3][visible]
    out = rgba.copy()
    if rgb.shape[0] == 0:
        return out, 0, 0, None
    packed = (rgb[:, 0].astype(np.int64) << 16) | (rgb[:, 1].astype(np.int64) << 8) | rgb[:, 2]
    colours, inverse, counts = np.unique(packed, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    colour_rgb = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], axis=1).astype(np.float64)
    colour_yuv = rgb_to_yuv(colour_rgb)
    if min_count is None:
        min_count = max(3.0, MIN_SHARE * rgb.shape[0])

    palette = _palette(colour_yuv, colour_rgb, counts.astype(np.float64), min_count, shadows)
    grid = chroma.chroma_grid(rgb_to_yuv(rgba)) if unmix else None
    if grid is not None and chroma.fits(rgba.shape[:2], len(palette)):
        labels, palette = chroma.unmix(rgba, palette, grid, min_count=min_count, radius=SNAP_RADIUS)
        snapped = np.clip(np.round(palette), 0, 255).astype(np.uint8)
        out[..., :3][visible] = snapped[labels[visible]]
        return out, int(colours.size), _distinct_rgb(snapped[np.unique(labels[visible])]), grid.name

    weight = np.array([1.0, CHROMA_WEIGHT, CHROMA_WEIGHT])
    nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    for _ in range(REFINE_STEPS):
        # each palette colour moves to the mean of the colours it gathers within the radius
        close = np.abs(colour_yuv - rgb_to_yuv(palette)[nearest]).max(axis=1) <= SNAP_RADIUS
        mass = np.bincount(nearest[close], weights=counts[close], minlength=len(palette))
        sums = np.stack([np.bincount(nearest[close], weights=counts[close] * colour_rgb[close, c],
                                     minlength=len(palette)) for c in range(3)], axis=1)
        moved = mass > 0
        palette[moved] = sums[moved] / mass[moved, None]
        palette = _merge_near(palette, np.bincount(nearest, weights=counts, minlength=len(palette)))
        nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    if leftovers:
        # a colour that a box took in (boxes reach a little beyond the radius) but that lies
        # far from the colour the box became is a colour of its own
        far = np.abs(colour_yuv - rgb_to_yuv(palette)[nearest]).max(axis=1) > LEFTOVER * SNAP_RADIUS
        if counts[far].sum() >= min_count:
            extra = _palette(colour_yuv[far], colour_rgb[far], counts[far].astype(np.float64), min_count, False)
            gap = np.abs(rgb_to_yuv(extra)[:, None, :] - rgb_to_yuv(palette)[None, :, :]).max(axis=2).min(axis=1)
            palette = np.vstack([palette, extra[gap > SNAP_RADIUS]])  # not a smear beside a colour it has
            nearest = _nearest(colour_yuv * weight, rgb_to_yuv(palette) * weight)
    snapped = np.clip(np.round(palette), 0, 255).astype(np.uint8)[nearest]
    out[..., :3][visible] = snapped[inverse]
    return out, int(colours.size), _distinct_rgb(snapped), None


def _distinct_rgb(rgb: np.ndarray) -> int:
    """How many distinct rows an ``(n, 3) uint8`` array has."""
    return int(np.unique((rgb[:, 0].astype(np.int64) << 16) | (rgb[:, 1].astype(np.int64) << 8) | rgb[:, 2]).size)


def _merge_near(palette: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Merge palette colours closer than SNAP_RADIUS (the closest pair first, into their
    mass-weighted mean), so that no two colours of the result are near-identical."""
    palette, mass = palette.copy(), mass.astype(np.float64).copy()
    while len(palette) > 1:
        yuv = rgb_to_yuv(palette)
        gap = np.abs(yuv[:, None, :] - yuv[None, :, :]).max(axis=2)
        np.fill_diagonal(gap, np.inf)
        i, j = np.unravel_index(int(np.argmin(gap)), gap.shape)
        if gap[i, j] > SNAP_RADIUS:
            break
        total = max(mass[i] + mass[j], 1e-9)
        palette[i] = (palette[i] * mass[i] + palette[j] * mass[j]) / total
        mass[i] = mass[i] + mass[j]
        palette, mass = np.delete(palette, j, axis=0), np.delete(mass, j)
    return palette


#: mode seeking counts pixels in cells of half the radius: a colour's neighbourhood is the
#: 5×5×5 cells around its own, about SNAP_RADIUS either way
_CELL = SNAP_RADIUS / 2
_REACH = 2
#: hqx luma of an RGB colour: colour @ _LUMA
_LUMA = rgb_to_yuv(np.eye(3))[:, 0]


def _palette(yuv: np.ndarray, rgb: np.ndarray, counts: np.ndarray, min_count: float,
             shadows: bool) -> np.ndarray:
    """``(K, 3) float64`` RGB palette by mode seeking over a histogram of the colours."""
    r = _REACH
    cell_of = np.floor(yuv / _CELL).astype(np.int64)
    cell_of -= cell_of.min(axis=0)
    span = tuple(cell_of.max(axis=0) + 1)
    keys, colour_cell = np.unique(np.ravel_multi_index(tuple(cell_of.T), span), return_inverse=True)
    colour_cell = colour_cell.ravel()
    cells = np.stack(np.unravel_index(keys, span), axis=1) + 2 * r  # grid positions, room for a 2r box around each
    shape = tuple(np.array(span) + 4 * r)
    mass = np.bincount(colour_cell, weights=counts, minlength=len(cells))
    rgb_sum = np.stack([np.bincount(colour_cell, weights=counts * rgb[:, c], minlength=len(cells))
                        for c in range(3)], axis=1)
    grid = np.zeros(shape, dtype=np.float32)  # pixels per cell not taken yet (counts: exact)
    grid[tuple(cells.T)] = mass
    # pixels within reach of each cell; only cells that could gather min_count are candidates
    density = _box_sums(grid, cells)
    candidates = np.flatnonzero(density >= min_count)
    cell_at = np.full(shape, -1, dtype=np.int32)  # which cell sits at each grid position
    cell_at[tuple(cells.T)] = np.arange(len(cells), dtype=np.int32)
    # lazy greedy: the box sums only shrink as boxes are taken, so a stale sum is an upper
    # bound; the candidate on top of the heap is the densest (first on ties) once its own sum,
    # brought up to date, still beats the next stale one
    heap = list(zip((-density[candidates]).tolist(), candidates.tolist()))
    heapq.heapify(heap)
    live = np.zeros(len(cells), dtype=bool)
    live[candidates] = True
    chosen: list[np.ndarray] = []
    chosen_mass: list[tuple[float, float]] = []  # (luma, pixels)
    while heap:
        _, c = heapq.heappop(heap)
        if not live[c]:
            continue  # its cell was taken
        x, y, z = cells[c]
        box = (slice(x - r, x + r + 1), slice(y - r, y + r + 1), slice(z - r, z + r + 1))
        now = float(grid[box].sum())
        if heap and (-now, c) > heap[0]:
            heapq.heappush(heap, (-now, c))  # not the densest any more: back, with its true sum
            continue
        if now < min_count:
            break
        gone = cell_at[box][cell_at[box] >= 0]
        cell_at[box] = -1  # taken: these cells are gone for every later box
        grid[box] = 0.0
        live[gone] = False
        colour = rgb_sum[gone].sum(axis=0) / now
        luma = float(colour @ _LUMA)
        if not shadows or not any(abs(luma - y) <= SHADOW_LUMA and m >= SHADOW_RATIO * now
                                  for y, m in chosen_mass):
            chosen.append(colour)
            chosen_mass.append((luma, now))
    if not chosen:  # too few pixels for any colour to count: the most common one
        chosen = [rgb[int(np.argmax(counts))]]
    return np.array(chosen, dtype=np.float64)


def _box_sums(grid: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``(n,) float64``: the sum of ``grid`` over the (2·_REACH+1)³ box around each of the
    ``(n, 3)`` positions ``at`` (at least _REACH cells from the edges): one gather of every
    box's cells (cumulative sums along a grid's first axes are slow strided passes)."""
    r = _REACH
    strides = np.array([grid.shape[1] * grid.shape[2], grid.shape[2], 1])
    offset = (np.stack(np.meshgrid(*[np.arange(-r, r + 1)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) @ strides)
    return grid.ravel()[(at @ strides)[:, None] + offset].sum(axis=1, dtype=np.float64)


def _nearest(points: np.ndarray, palette: np.ndarray) -> np.ndarray:
    """Index of the nearest palette row (Euclidean) for every point."""
    d = ((points[:, None, :] - palette[None, :, :]) ** 2).sum(axis=2)
    return np.argmin(d, axis=1)


# --- backdrop ------------------------------------------------------------------------------------

def make_transparent(rgba: np.ndarray, colour: str | Colour, snapped: bool = False):
    """Make every visible pixel of one colour fully transparent.

    ``colour`` is an ``(r, g, b)`` triple or ``"auto"``: the colour of the four corners
    when all four are that same opaque colour. On a ``snapped`` (denoised) image the
    palette colour nearest to a given colour is taken when it lies within SNAP_RADIUS.
    Returns ``(rgba, colour made transparent or None, pixels changed, note or None)``.
    """
    keys = colour_keys(rgba)
    if colour == AUTO:
        corners = keys[[0, 0, -1, -1], [0, -1, 0, -1]]
        if corners[0] == 0 and (corners == 0).all():
            return rgba, None, 0, None  # already on a transparent backdrop
        if not (corners == corners[0]).all() or rgba[0, 0, 3] != 255:
            return rgba, None, 0, "the corners differ, so no backdrop colour was made transparent"
        target: Colour = (int(rgba[0, 0, 0]), int(rgba[0, 0, 1]), int(rgba[0, 0, 2]))
    else:
        target = (int(colour[0]), int(colour[1]), int(colour[2]))
        if snapped:
            visible = rgba[..., 3] > 0
            present = np.unique(rgba[..., :3][visible], axis=0)
            if present.size:
                gap = np.abs(rgb_to_yuv(present) - rgb_to_yuv(np.array(target, dtype=np.float64))).max(axis=1)
                if gap.min() <= SNAP_RADIUS:
                    nearest = present[int(np.argmin(gap))]
                    target = (int(nearest[0]), int(nearest[1]), int(nearest[2]))
    hit = (rgba[..., 3] > 0) & (rgba[..., :3] == np.array(target, dtype=np.uint8)).all(axis=2)
    n = int(hit.sum())
    if n == 0:
        return rgba, None, 0, f"no pixel is {_hex(target)}, so nothing was made transparent"
    out = rgba.copy()
    out[hit, 3] = 0
    return out, target, n, None


# --- output that overlays the input ---------------------------------------------------------------

def overlay_svg(svg: str, prepared: PreparedImage, scale: float = 1.0) -> str:
    """Give an SVG of the 1× art the input's size × ``scale`` and the viewBox that lays it
    exactly over the input (partial blocks at the edges cut, non-square pixels stretched).
    Unchanged when the input was not upscaled."""
    if not prepared.upscaled:
        return svg
    from .svgtext import numbers  # noqa: PLC0415

    width, height = numbers(np.array([prepared.input_size[0] * scale, prepared.input_size[1] * scale]), 3).tolist()
    box = numbers(np.array([prepared.viewbox()]), 6).tolist()[0]
    head = re.search(r"<svg\b[^>]*>", svg)
    if head is None:
        raise ValueError("not an SVG document: no <svg> element")
    # the writer's own size and viewBox are replaced; everything else in the tag is kept
    tag = re.sub(r"""\s(?:width|height|viewBox|preserveAspectRatio)\s*=\s*("[^"]*"|'[^']*')""", "",
                 head.group(0))
    size = f' width="{width}" height="{height}" viewBox="{box}"'
    if prepared.pixel_size[0] != prepared.pixel_size[1]:
        size += ' preserveAspectRatio="none"'  # non-square art pixels: stretch, do not letterbox
    closing = 2 if tag.endswith("/>") else 1
    return svg[: head.start()] + tag[:-closing] + size + tag[-closing:] + svg[head.end():]


def overlay_raster(pixels: np.ndarray, prepared: PreparedImage, scale: float) -> np.ndarray:
    """Crop and resample an ``(H, W, 4) uint8`` render of the whole 1× grid (any uniform
    scale) to the input's size × ``scale``, laid over the input like :func:`overlay_svg`."""
    if not prepared.upscaled:
        return pixels
    from PIL import Image  # noqa: PLC0415

    gh, gw = prepared.rgba.shape[:2]
    per_x, per_y = pixels.shape[1] / gw, pixels.shape[0] / gh  # render pixels per art pixel
    x, y, w, h = prepared.viewbox()
    box = (x * per_x, y * per_y, (x + w) * per_x, (y + h) * per_y)
    size = (max(1, round(prepared.input_size[0] * scale)), max(1, round(prepared.input_size[1] * scale)))
    if all(float(b).is_integer() for b in box) and (box[2] - box[0], box[3] - box[1]) == size:
        return np.ascontiguousarray(pixels[int(box[1]):int(box[3]), int(box[0]):int(box[2])])
    image = Image.fromarray(pixels, "RGBA").resize(size, Image.Resampling.LANCZOS, box=box)
    return np.asarray(image, dtype=np.uint8)


def _factor_text(pair: tuple[int, int]) -> str:
    return f"{pair[0]}×" if pair[0] == pair[1] else f"{pair[0]}×{pair[1]}"


def _hex(colour: Colour) -> str:
    return "#{:02x}{:02x}{:02x}".format(*colour)
