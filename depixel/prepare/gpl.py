"""Palettes: GIMP palette files (``.gpl``) read and written, and the palette swap of an output.

A :class:`Palette` is a list of named colours. It names the swatches of an SVG
(``--swatches``, :mod:`depixel.svg.swatches`), is what ``--export-palette`` writes, and two of
them make a :class:`PaletteMap`, which recolours an output colour by colour (``--palette-map``).

The GIMP palette format, as GIMP and Aseprite write it::

    GIMP Palette
    Name: sprite            (optional)
    Columns: 8              (optional)
    Channels: RGBA          (optional: Aseprite's extension, an alpha column)
    # a comment
    255   0   0	red
      0   0   0	            (no name)

GIMP writes ``Untitled`` for an entry without a name, which is read as none. A palette is
also read from an Aseprite file (its palette, with its names). Anything else is one
:class:`~depixel.errors.ParameterError` line naming the file and the line.
"""
from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError, display_name
from .aseprite_format import PaletteEntry

__all__ = ["Palette", "PaletteEntry", "PaletteMap", "PaletteMapSource", "PaletteSource", "as_palette",
           "as_palette_map", "format_gpl", "parse_gpl", "read_palette"]

HEADER = "GIMP Palette"
#: what GIMP writes for an entry without a name
UNNAMED = "Untitled"
#: a palette file is small: a 256-colour palette is ~6 KiB
MAX_PALETTE_BYTES = 1 << 20
RGBA = tuple[int, int, int, int]


@dataclass(frozen=True)
class Palette:
    """Colours in order, each with its name (or None); ``alpha``: the colours have their own
    opacity (``Channels: RGBA``), else they are opaque and match a colour of any opacity."""

    entries: tuple[PaletteEntry, ...]
    name: str | None = None
    columns: int | None = None
    alpha: bool = False

    def __len__(self) -> int:
        return len(self.entries)

    @property
    def rgba(self) -> np.ndarray:
        """``(N, 4) uint8`` the colours."""
        return np.array([entry.rgba for entry in self.entries], np.uint8).reshape(-1, 4)

    def index(self, rgba: np.ndarray) -> np.ndarray:
        """``(...,)`` int64 the first entry of the colour of each ``(..., 4)`` pixel (by RGB,
        or RGBA for a palette with ``alpha``), -1 where none is (and where alpha is 0)."""
        keys = _keys(rgba, self.alpha)
        if not self.entries:
            return np.full(keys.shape, -1, np.int64)
        own = _keys(self.rgba, self.alpha)
        order = np.argsort(own, kind="stable")  # the first of equal colours first
        ranked = own.take(order)
        at = np.minimum(ranked.searchsorted(keys), ranked.size - 1)
        found = (ranked.take(at) == keys) & (np.asarray(rgba)[..., 3] > 0)
        return np.where(found, order.take(at), -1)

    def names(self) -> dict[tuple[int, ...], str]:
        """Each named colour's name by its key (RGB, or RGBA with ``alpha``), the first entry's."""
        named: dict[tuple[int, ...], str] = {}
        for entry in self.entries:
            if entry.name:
                named.setdefault(entry.rgba if self.alpha else entry.rgba[:3], entry.name)
        return named

    def name_of(self, rgba: tuple[int, ...]) -> str | None:
        """The name of colour ``rgba`` in this palette, or None."""
        return self.names().get(tuple(rgba) if self.alpha else tuple(rgba[:3]))


def _keys(rgba: np.ndarray, alpha: bool) -> np.ndarray:
    q = np.asarray(rgba).astype(np.int64)
    key = (q[..., 0] << 16) | (q[..., 1] << 8) | q[..., 2]
    return (key << 8) | q[..., 3] if alpha else key


@dataclass(frozen=True)
class PaletteMap:
    """A palette swap: every colour of ``source`` becomes the colour at its place in
    ``target`` (the first place, when ``source`` holds a colour twice); other colours stay.
    The opacity is ``target``'s when it has ``alpha``, else the colour's own."""

    source: Palette
    target: Palette

    def __post_init__(self) -> None:
        if len(self.source) != len(self.target):
            raise ParameterError(f"palette_map: the palettes differ in size ({len(self.source)} colours to "
                                 f"{len(self.target)}); a swap maps each colour to the one at its place",
                                 parameter="palette_map")

    def apply(self, rgba: np.ndarray) -> np.ndarray:
        """``(..., 4) uint8`` colours swapped (a new array; the input is not changed)."""
        rgba = np.asarray(rgba, np.uint8)
        index = self.source.index(rgba)
        out = rgba.copy()
        hit = index >= 0
        if hit.any():
            target = self.target.rgba[index[hit]]
            out[hit, :3] = target[:, :3]
            if self.target.alpha:
                out[hit, 3] = target[:, 3]
        return out


def parse_gpl(text: str, name: str = "<palette>") -> Palette:
    """A GIMP palette's text → :class:`Palette` (a :class:`ParameterError` naming the line
    that is not one)."""
    lines = text.lstrip("\ufeff").splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise ParameterError(f"{name}: not a GIMP palette (the first line must be {HEADER!r})", parameter="palette")
    title: str | None = None
    columns: int | None = None
    alpha = False
    entries: list[PaletteEntry] = []
    for number, line in enumerate(lines[1:], start=2):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        key, colon, value = stripped.partition(":")
        if colon and not entries and key.strip().lower() in ("name", "columns", "channels"):
            field = key.strip().lower()
            value = value.strip()
            if field == "name":
                title = value or None
            elif field == "columns":
                if not value.isdigit():
                    raise ParameterError(f"{name}: line {number}: Columns must be a number, not {value!r}",
                                         parameter="palette")
                columns = int(value)
            elif value.upper() in ("RGB", "RGBA"):
                alpha = value.upper() == "RGBA"
            else:
                raise ParameterError(f"{name}: line {number}: Channels must be RGB or RGBA, not {value!r}",
                                     parameter="palette")
            continue
        entries.append(_entry(stripped, alpha, f"{name}: line {number}"))
    return Palette(tuple(entries), title, columns, alpha)


_ENTRY = re.compile(r"(\d{1,3})\s+(\d{1,3})\s+(\d{1,3})(?:\s+(\d{1,3}))?(?:\s+(.*))?")


def _entry(line: str, alpha: bool, where: str) -> PaletteEntry:
    """One colour line: ``R G B [A] name``."""
    match = _ENTRY.fullmatch(line)
    values = [int(v) for v in match.groups()[:4] if v is not None] if match else []
    name = match.group(5) if match else None
    if match and not alpha and match.group(4) is not None:  # RGB: a fourth number starts the name
        values, name = values[:3], f"{match.group(4)} {name or ''}".strip()
    if not match or len(values) != 3 + alpha or max(values) > 255:
        shape = "R G B A name" if alpha else "R G B name"
        raise ParameterError(f"{where}: expected {shape!r} with numbers from 0 to 255, not {line!r}",
                             parameter="palette")
    name = (name or "").strip()
    rgba = (values[0], values[1], values[2], values[3] if alpha else 255)
    return PaletteEntry(rgba, None if name in ("", UNNAMED) else name)


def format_gpl(palette: Palette) -> str:
    """A :class:`Palette` as the text of a GIMP palette file (with ``Channels: RGBA`` when it
    has ``alpha``); :func:`parse_gpl` reads it back as the same palette."""
    lines = [HEADER]
    if palette.name:
        lines.append(f"Name: {_one_line(palette.name)}")
    if palette.columns is not None:
        lines.append(f"Columns: {palette.columns}")
    if palette.alpha:
        lines.append("Channels: RGBA")
    lines.append("#")
    for entry in palette.entries:
        numbers = entry.rgba if palette.alpha else entry.rgba[:3]
        lines.append(" ".join(f"{v:3d}" for v in numbers) + "\t" + (_one_line(entry.name) if entry.name else UNNAMED))
    return "\n".join(lines) + "\n"


def _one_line(text: str) -> str:
    return " ".join(text.split())


def read_palette(path: str | os.PathLike) -> Palette:
    """A palette file: a GIMP palette, or the palette of an Aseprite file."""
    shown = display_name(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_PALETTE_BYTES + 1)
    except OSError as exc:
        raise ParameterError(f"{shown}: cannot read the palette ({exc.strerror or exc})", parameter="palette") from None
    from .aseprite_format import is_aseprite  # noqa: PLC0415

    if is_aseprite(data):
        from .aseprite_format import parse_aseprite  # noqa: PLC0415

        entries = parse_aseprite(data, shown, None).palette
        return Palette(entries, Path(path).stem, None, any(e.rgba[3] != 255 for e in entries))
    if len(data) > MAX_PALETTE_BYTES:
        raise ParameterError(f"{shown}: over {MAX_PALETTE_BYTES // 1024} KiB, not a palette", parameter="palette")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ParameterError(f"{shown}: not a GIMP palette (not UTF-8 text)", parameter="palette") from None
    return parse_gpl(text, shown)


PaletteSource = Palette | str | os.PathLike | Sequence[Sequence[int]]


def as_palette(value: PaletteSource, parameter: str = "palette") -> Palette:
    """A palette option: a :class:`Palette`, a palette file (``.gpl``, ``.aseprite``) or
    colours (``(r, g, b)`` or ``(r, g, b, a)`` each, unnamed)."""
    if isinstance(value, Palette):
        return value
    try:
        if isinstance(value, (str, os.PathLike)):
            return read_palette(value)
        colours = [tuple(int(v) for v in colour) for colour in value]
    except ParameterError as exc:
        raise ParameterError(str(exc), parameter=parameter) from None
    except (TypeError, ValueError):
        raise ParameterError(f"{parameter} must be a Palette, a palette file or a list of colours",
                             parameter=parameter) from None
    if not all(len(c) in (3, 4) and all(0 <= v <= 255 for v in c) for c in colours):
        raise ParameterError(f"{parameter}: each colour is (r, g, b) or (r, g, b, a) from 0 to 255",
                             parameter=parameter)
    alpha = any(len(c) == 4 for c in colours)
    return Palette(tuple(PaletteEntry((c[0], c[1], c[2], c[3] if len(c) == 4 else 255)) for c in colours),
                   alpha=alpha)


#: a palette map's two files on the command line, ``FROM.gpl:TO.gpl`` (a colon after a
#: palette's extension; otherwise the last colon, so a Windows drive letter stays in a name)
_MAP_SPLIT = re.compile(r"(.+?\.(?:gpl|aseprite|ase)):(.+)", re.IGNORECASE)


PaletteMapSource = PaletteMap | str | tuple[PaletteSource, PaletteSource]


def as_palette_map(value: PaletteMapSource) -> PaletteMap:
    """A palette-map option: a :class:`PaletteMap`, ``"FROM.gpl:TO.gpl"`` or a pair of palettes."""
    if isinstance(value, PaletteMap):
        return value
    if isinstance(value, str):
        match = _MAP_SPLIT.fullmatch(value)
        parts = match.groups() if match else value.rsplit(":", 1)
        if len(parts) != 2 or not all(parts):
            raise ParameterError(f"palette_map must be FROM.gpl:TO.gpl, not {value!r}", parameter="palette_map")
        value = (parts[0], parts[1])
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ParameterError("palette_map must be a PaletteMap, 'FROM.gpl:TO.gpl' or a pair of palettes",
                             parameter="palette_map")
    return PaletteMap(as_palette(value[0], "palette_map"), as_palette(value[1], "palette_map"))
