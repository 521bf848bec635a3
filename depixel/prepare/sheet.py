"""Stage 0 — input: a sprite sheet's RGBA → where its sprites are (:class:`Sheet`).

A sheet's sprites stand apart on a background: fully transparent pixels, or (a sheet with no
transparency) one opaque colour, the commonest on the sheet's border. :func:`find_sprites`
looks for a regular grid in the gutters — columns (rows) of background between the sprites
— and falls back to the bounding boxes of 8-connected sprites when they form none;
:func:`grid_sprites` cuts a grid of a given cell size. A grid's sprite is its whole cell (so
the frames of an animation keep their alignment), named ``r{row}c{col}`` from 0; cells with
nothing but background are skipped. :mod:`.sheet_json` reads the sprites from an Aseprite or
TexturePacker JSON file instead (docs/inputs.md, "Sprite sheets").

The grid along each axis is found alone (the other axis' sprites merged into its profile):
every cell boundary must fall where a whole column is background, so no 8-connected sprite is
ever cut. Of the pitches and phases that allow that, the one with the most cells holding
something wins, then the fewest empty cells, then the tightest cells (the content at one
place in every cell), then the least margin around the grid, then the grid most evenly
centred on the sheet; its cells are first the tightest
that hold every column's content; unless every cell is filled edge to edge, they are then
widened to tile the sheet when the margins fit in the gutters (sprites centred in cells that
touch), else by half the gutter on either side as far as the margins allow.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import component_roots
from ..errors import InputError, ParameterError
from .aseprite_format import Slice, Tag


@dataclass(frozen=True)
class Sprite:
    """One sprite of a sheet: its name and its rectangle on the sheet (pixels); ``duration``
    (ms) and ``trim`` (``(x, y, width, height)``: where the trimmed rectangle sat in its
    untrimmed frame, and that frame's size) when a JSON file says so."""

    name: str
    x: int
    y: int
    width: int
    height: int
    duration: int | None = None
    trim: tuple[int, int, int, int] | None = None

    @property
    def box(self) -> tuple[slice, slice]:
        """The sprite's rows and columns: ``rgba[sprite.box]`` is its crop."""
        return slice(self.y, self.y + self.height), slice(self.x, self.x + self.width)


@dataclass(frozen=True)
class Grid:
    """A regular grid: cells of ``cell`` (width, height) pixels, ``gap`` pixels between
    them, the first at ``offset`` (x, y); ``columns`` × ``rows`` cells."""

    cell: tuple[int, int]
    gap: tuple[int, int]
    offset: tuple[int, int]
    columns: int
    rows: int


@dataclass(frozen=True)
class Sheet:
    """The sprites found on a sheet, the grid they sit in (None: found apart), the
    background (None: transparent), tags and slices from a JSON file, and one line that
    says what was found."""

    sprites: tuple[Sprite, ...]
    grid: Grid | None
    background: tuple[int, int, int, int] | None
    description: str
    tags: tuple[Tag, ...] = ()
    slices: tuple[Slice, ...] = ()


def background_of(rgba: np.ndarray) -> tuple[int, int, int, int] | None:
    """The sheet's background: None (transparent) when any pixel is fully transparent, else
    the commonest colour of the rows and columns of one colour (gutters, margins), or with
    none, of the sheet's border."""
    if not rgba[..., 3].all():
        return None
    rows = rgba[(rgba == rgba[:, :1]).all(axis=(1, 2)), 0]
    columns = rgba[0, (rgba == rgba[:1]).all(axis=(0, 2))]
    lines = np.concatenate([rows, columns])
    pixels = lines if lines.size else np.concatenate([rgba[0], rgba[-1], rgba[:, 0], rgba[:, -1]])
    keys = pixels.astype(np.uint32) << np.array([24, 16, 8, 0], np.uint32)
    values, counts = np.unique(np.bitwise_or.reduce(keys, axis=1), return_counts=True)
    key = int(values[counts.argmax()])
    return key >> 24, key >> 16 & 255, key >> 8 & 255, key & 255


def content_mask(rgba: np.ndarray, background: tuple[int, int, int, int] | None) -> np.ndarray:
    """``(H, W) bool``: the pixels that are not background."""
    if background is None:
        return rgba[..., 3] != 0
    return (rgba != np.array(background, np.uint8)).any(axis=2)


#: a grid whose cells hold several sprites apart is still taken from this many sprites on
#: (frames with detached parts: sparks, debris); below it the sprites are found apart
GRID_TRUSTED = 4


def find_sprites(rgba: np.ndarray) -> Sheet:
    """The sprites of a sheet (module docstring): a regular grid when the gutters form one
    with at least two sprites, each cell holding one sprite (or at least GRID_TRUSTED
    sprites); else the bounding boxes of 8-connected sprites (boxes that overlap merged, so
    no sprite's rectangle holds part of another)."""
    background = background_of(rgba)
    filled = content_mask(rgba, background)
    blobs = _blobs(filled)
    columns, rows = _axis_grid(filled.any(axis=0)), _axis_grid(filled.any(axis=1))
    if columns is not None and rows is not None:
        grid = Grid((columns[1], rows[1]), (columns[2], rows[2]), (columns[0], rows[0]), columns[3], rows[3])
        sprites = _cells(filled, grid)
        if len(sprites) >= 2 and (len(sprites) >= GRID_TRUSTED or len(sprites) == len(blobs)):
            return Sheet(sprites, grid, background, describe(sprites, grid, background))
    return Sheet(blobs, None, background, describe(blobs, None, background))


def parse_grid(spec: str) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
    """``WxH``, ``WxH+GAP`` or ``WxH+GAPX,GAPY``, each optionally followed by ``@X,Y`` (the
    first cell's corner) → ``(cell, gap, offset)``; a :class:`ParameterError` otherwise."""
    text = spec.strip().lower()
    head, _, offset = text.partition("@")
    size, _, gap = head.partition("+")
    try:
        cell = tuple(int(v) for v in size.split("x"))
        gaps = tuple(int(v) for v in gap.split(",")) if "+" in head else (0,)
        corner = tuple(int(v) for v in offset.split(",")) if offset else (0, 0)
    except ValueError:
        cell = gaps = corner = ()
    if len(cell) != 2 or len(gaps) not in (1, 2) or len(corner) != 2 or min(cell) < 1 or min(gaps + corner) < 0:
        raise ParameterError(f"sheet grid {spec!r}: expected WxH, WxH+GAP or WxH+GAPX,GAPY, optionally @X,Y "
                             "(e.g. 32x32+2@1,1)", parameter="sheet")
    return (cell[0], cell[1]), (gaps[0], gaps[-1]), (corner[0], corner[1])


#: ``sheet="auto"``: find the sprites (:func:`find_sprites`)
AUTO = "auto"


def sheet_spec(value: str) -> str:
    """The ``sheet`` option normalized: ``"auto"``, or the grid :func:`parse_grid` reads
    written the shortest way (``"32x32+2@1,1"``; ``"32x32+0"`` is ``"32x32"``), so that two
    spellings of one grid are one option."""
    if not isinstance(value, str):
        raise ParameterError(f"sheet must be auto or a grid like 32x32+2, not {value!r}", parameter="sheet")
    if value.strip().lower() == AUTO:
        return AUTO
    (w, h), (gx, gy), (ox, oy) = parse_grid(value)
    gap = "" if gx == gy == 0 else f"+{gx}" if gx == gy else f"+{gx},{gy}"
    return f"{w}x{h}{gap}" + (f"@{ox},{oy}" if ox or oy else "")


def grid_sprites(rgba: np.ndarray, spec: str) -> Sheet:
    """The sprites of a grid of the cell size ``spec`` gives (:func:`parse_grid`): every
    whole cell on the sheet that holds something but background."""
    cell, gap, offset = parse_grid(spec)
    height, width = rgba.shape[:2]
    columns = (width - offset[0] + gap[0]) // (cell[0] + gap[0])
    rows = (height - offset[1] + gap[1]) // (cell[1] + gap[1])
    if columns < 1 or rows < 1:
        raise ParameterError(f"sheet grid {spec!r}: no whole {cell[0]}x{cell[1]} cell fits the {width}x{height} "
                             "sheet", parameter="sheet")
    background = background_of(rgba)
    grid = Grid(cell, gap, offset, columns, rows)
    sprites = _cells(content_mask(rgba, background), grid)
    return Sheet(sprites, grid, background, describe(sprites, grid, background))


def sheet_of(rgba: np.ndarray, spec: str | None, sheet_json=None, name: str = "<image>") -> Sheet:
    """The sprites a sheet ``spec`` ("auto" or a grid, :func:`sheet_spec`) or a ``sheet_json``
    (a :class:`~depixel.prepare.sheet_json.SheetJson`) finds on the sheet ``rgba``; a sheet with
    none is an :class:`InputError`."""
    height, width = rgba.shape[:2]
    if sheet_json is not None:
        sheet = sheet_json.sheet((width, height))
    elif spec == "auto":
        sheet = find_sprites(rgba)
    else:
        sheet = grid_sprites(rgba, str(spec))
    if not sheet.sprites:
        raise InputError(f"{name}: no sprites on the sheet (nothing but its background)")
    return sheet


def describe(sprites: tuple[Sprite, ...], grid: Grid | None, background: tuple[int, int, int, int] | None) -> str:
    """One line: what was found ("6 sprites in 3 columns × 2 rows, 32×32 cells, 2-px gutters")."""
    count = f"{len(sprites)} sprite{'' if len(sprites) == 1 else 's'}"
    if grid is None:
        text = f"{count} apart (no regular grid): the bounding boxes of connected pixels"
    else:
        gx, gy = grid.gap
        gutters = "no gutters" if gx == gy == 0 else f"{gx}-px gutters" if gx == gy else f"{gx}×{gy}-px gutters"
        text = (f"{count} in {grid.columns} column{'' if grid.columns == 1 else 's'} × {grid.rows} "
                f"row{'' if grid.rows == 1 else 's'}, {grid.cell[0]}×{grid.cell[1]} cells, {gutters}")
        if grid.offset != (0, 0):
            text += f", offset {grid.offset[0]},{grid.offset[1]}"
        empty = grid.columns * grid.rows - len(sprites)
        if empty:
            text += f", {empty} empty cell{'' if empty == 1 else 's'} skipped"
    if background is not None:
        text += ", background #" + bytes(background[:3]).hex()
    return text


def _cells(filled: np.ndarray, grid: Grid) -> tuple[Sprite, ...]:
    """The grid's cells that hold something, row by row."""
    (cw, ch), (gx, gy), (ox, oy) = grid.cell, grid.gap, grid.offset
    sprites = []
    for row in range(grid.rows):
        for col in range(grid.columns):
            x, y = ox + col * (cw + gx), oy + row * (ch + gy)
            if filled[y:y + ch, x:x + cw].any():
                sprites.append(Sprite(f"r{row}c{col}", x, y, cw, ch))
    return tuple(sprites)


def _axis_grid(filled: np.ndarray | np.bool_) -> tuple[int, int, int, int] | None:
    """The best regular grid along one axis whose ``filled`` (a column or row has content)
    profile it explains: ``(offset, cell, gap, count)``, or None when there is no content."""
    filled = np.asarray(filled)
    size = filled.size
    content = filled.nonzero()[0]
    if content.size == 0:
        return None
    # a boundary at b (between b - 1 and b) cuts no sprite when either side is background
    allowed = np.ones(size + 1, bool)
    allowed[1:size] = ~(filled[:-1] & filled[1:])
    starts = np.flatnonzero(np.diff(np.concatenate(([0], filled.view(np.int8), [0]))) == 1)
    ends = np.flatnonzero(np.diff(np.concatenate(([0], filled.view(np.int8), [0]))) == -1)
    widest = int((ends - starts).max())
    best: tuple[tuple[int, ...], tuple[int, int, int, int]] | None = None
    for pitch in range(widest, size + 1):
        rounds = -(-(size + 1) // pitch)
        padded = np.ones(rounds * pitch, bool)
        padded[:size + 1] = allowed
        phases = np.flatnonzero(padded.reshape(rounds, pitch).all(axis=0))
        # phases in one run put every content column in the same cell: one of each run
        for phase in phases.compress(np.diff(phases, prepend=-2) > 1).tolist():
            model = _tight(content, size, pitch, phase)
            if model is not None and (best is None or model[0] < best[0]):
                best = model
    return None if best is None else best[1]


def _tight(content: np.ndarray, size: int, pitch: int, phase: int):
    """The grid of ``pitch`` whose boundaries lie at ``phase`` + k·pitch, its cells made the
    tightest that hold every content column (then widened into the margins when they fit in
    the gutters), scored for :func:`_axis_grid`: ``(score, (offset, cell, gap, count))``, or
    None when its cells would not fit on the sheet."""
    cell = (content - phase) // pitch  # each content column's cell
    local = content - phase - cell * pitch
    low, high = int(local.min()), int(local.max()) + 1
    first, last = int(cell[0]), int(cell[-1])
    width, gap, count = high - low, pitch - (high - low), last - first + 1
    start = phase + first * pitch + low
    end = start + (count - 1) * pitch + width
    if start < 0 or end > size:
        return None
    left, right = start, size - end
    skew = abs(left - right)
    groups = np.flatnonzero(np.diff(cell, prepend=first - 1))  # each cell's first content column
    ends = np.append(groups[1:], cell.size) - 1
    if (local.take(groups) == low).all() and (local.take(ends) == high - 1).all():
        grow = (0, 0)  # every cell filled edge to edge: the gutters and margins are the sheet's
    elif left + right <= gap:  # sprites centred in cells that tile the sheet: widen the cells to them
        grow = (left, right)
    else:  # else half the gutter on either side, as far as the margins go
        grow = (min(gap // 2, left, right),) * 2
    width, gap, start = width + sum(grow), gap - sum(grow), start - grow[0]
    left, right = left - grow[0], right - grow[1]
    held = 1 + int(np.count_nonzero(np.diff(cell)))
    # the content at one place in every cell (the tightest cells before any widening), the
    # least margin, the grid centred
    return (-held, count - held, high - low, left + right, skew, pitch), (start, width, gap, count)


def _blobs(filled: np.ndarray) -> tuple[Sprite, ...]:
    """The bounding boxes of the 8-connected sprites, boxes that overlap merged, in reading
    order (by top edge, then left), named ``sprite{n}`` from 1."""
    height, width = filled.shape
    index = np.arange(filled.size).reshape(height, width)
    pairs = [(filled[:, :-1] & filled[:, 1:], index[:, :-1], index[:, 1:]),
             (filled[:-1] & filled[1:], index[:-1], index[1:]),
             (filled[:-1, :-1] & filled[1:, 1:], index[:-1, :-1], index[1:, 1:]),
             (filled[:-1, 1:] & filled[1:, :-1], index[:-1, 1:], index[1:, :-1])]
    a = np.concatenate([first[both] for both, first, _ in pairs])
    b = np.concatenate([second[both] for both, _, second in pairs])
    root = component_roots(filled.size, a, b)
    pixels = filled.ravel().nonzero()[0]
    _, label = np.unique(root[pixels], return_inverse=True)
    n = int(label.max()) + 1 if label.size else 0
    ys, xs = pixels // width, pixels % width
    low = np.full((2, n), max(height, width), np.int64)
    high = np.zeros((2, n), np.int64)
    for axis, values in enumerate((xs, ys)):
        np.minimum.at(low[axis], label, values)
        np.maximum.at(high[axis], label, values + 1)
    boxes = np.stack([low[0], low[1], high[0], high[1]], axis=1).tolist()
    merged = _merge_overlapping(boxes)
    merged.sort(key=lambda box: (box[1], box[0]))
    return tuple(Sprite(f"sprite{n}", x0, y0, x1 - x0, y1 - y0) for n, (x0, y0, x1, y1) in enumerate(merged, 1))


def _merge_overlapping(boxes: list[list[int]]) -> list[list[int]]:
    """Boxes ``[x0, y0, x1, y1]`` with every overlapping pair merged into their union, until
    none overlaps."""
    merged = True
    while merged:
        merged = False
        out: list[list[int]] = []
        for box in boxes:
            for other in out:
                if box[0] < other[2] and other[0] < box[2] and box[1] < other[3] and other[1] < box[3]:
                    other[:] = [min(box[0], other[0]), min(box[1], other[1]), max(box[2], other[2]),
                                max(box[3], other[3])]
                    merged = True
                    break
            else:
                out.append(box)
        boxes = out
    return boxes
