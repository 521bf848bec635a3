"""Stage 7 — SVG export — how the shapes are painted: palette swap, swatches, the blur's σ.

:class:`Style` is what the writer (:mod:`depixel.svg.writer`) is told besides the geometry.
With a :class:`~depixel.prepare.gpl.PaletteMap` every shape is filled with its colour
swapped; the outlines are those of the art's own colours (the writer swaps the colours of
the shapes it was given, after their geometry is decided), so the path data is the same
bytes. With ``swatches`` every colour is one Inkscape swatch in ``<defs>``, a one-stop
``<linearGradient inkscape:swatch="solid">``, and each shape (band, smooth-shading tone)
is filled ``url(#swatch) #rrggbb``: editing the swatch's stop recolours every shape of that
colour; a renderer that cannot find the swatch draws the colour after the url.

One file made of several documents (an animation's frames, :mod:`depixel.svg.animation`;
a sheet's sprites, :mod:`depixel.svg.layers`) has one set of swatches: the documents are
named from the colours of all (:func:`shared_names`), so a colour is one swatch of one id in
all of them, and :class:`SharedSwatches` writes each swatch once (editing it recolours that
colour in every frame and sprite).

A swatch holds its colour's opacity (``stop-opacity``): a palette colour is RGBA (GIMP's
``Channels: RGBA``, Aseprite), so editing the swatch edits the whole colour, and the shapes
carry no ``fill-opacity`` of their own (it would multiply the swatch's).

The swatches are in the order of :func:`picture_colours`: the colours of the named palette
first, in its order, then the others where they first appear (rows top to bottom). A swatch
is named after its colour's name in the palette (made a valid id; with a palette map and no
palette, the map's target palette), else ``pal-NN-rrggbb`` (NN its place in that order).
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .stacking import ROLES
from .svgtext import number

if TYPE_CHECKING:  # (imported when a palette is used: a conversion without one never loads them)
    from ..prepare.gpl import Palette, PaletteMap

#: ids the document uses for its own elements (shapes ``role-rrggbb``, groups, filters, masks):
#: a swatch named like them is given the prefix ``swatch-``
RESERVED = (*ROLES, "region", "smooth", "hide", "cover", "pal", "swatch")


@dataclass(frozen=True)
class Style:
    """How a document paints its shapes: the smooth shading's blur (σ in pixels), the
    palette swap, and swatches named from ``palette``."""

    sigma: float | None = None  # the blur's standard deviation (pixels); None: the writer's default
    swatches: bool = False  # every colour an Inkscape swatch
    palette: Palette | None = None  # names the swatches
    palette_map: PaletteMap | None = None  # swaps the colours of the fills

    @property
    def names(self) -> Palette | None:
        """The palette that names the swatches: ``palette``, else the palette map's target."""
        return self.palette if self.palette is not None or self.palette_map is None else self.palette_map.target

def picture_colours(pixels: np.ndarray, palette: Palette | None = None,
                    palette_map: PaletteMap | None = None) -> np.ndarray:
    """``(K, 4) uint8`` the colours of ``(H, W, 4)`` pixels (alpha above 0; swapped by
    ``palette_map``): the colours of ``palette`` first, in its order, then the others in the
    order they first appear."""
    colours = _first_seen(np.asarray(pixels, np.uint8).reshape(-1, 4))
    colours = colours.compress(colours[:, 3] > 0, axis=0)
    if palette_map is not None:
        colours = _first_seen(palette_map.apply(colours))
    if palette is None or not len(palette):
        return colours
    place = palette.index(colours)
    rank = np.where(place >= 0, place, len(palette) + np.arange(place.size))
    return colours.take(np.argsort(rank, kind="stable"), axis=0)


def _first_seen(rgba: np.ndarray) -> np.ndarray:
    """The distinct rows of ``(N, 4) uint8`` in the order they first appear."""
    key = np.ascontiguousarray(rgba).view(np.uint32).ravel()  # one number a colour (equality only)
    _, first = np.unique(key, return_index=True)
    return rgba.take(np.sort(first), axis=0)


def swatch_names(colours: np.ndarray, palette: Palette | None = None) -> list[str]:
    """The name of each colour of ``colours`` (:func:`picture_colours`): its name in
    ``palette``, else ``pal-NN-rrggbb``."""
    names = []
    for k, colour in enumerate(colours.tolist()):
        named = palette.name_of(tuple(colour)) if palette is not None else None
        names.append(named or f"pal-{k:02d}-{bytes(colour[:3]).hex()}")
    return names


def document_palette(pixels: np.ndarray, style: Style, title: str | None = None) -> Palette:
    """The palette of a document: the colours its shapes are filled with (swapped), in the
    swatches' order, each with its swatch's name (``--export-palette``)."""
    from ..prepare.gpl import Palette, PaletteEntry  # noqa: PLC0415

    colours = picture_colours(pixels, style.names, style.palette_map)
    alpha = bool((colours[:, 3] != 255).any())
    entries = tuple(PaletteEntry((c[0], c[1], c[2], c[3]), name)
                    for c, name in zip(colours.tolist(), swatch_names(colours, style.names)))
    return Palette(entries, title, None, alpha)


def shared_names(pixels: Sequence[np.ndarray], style: Style, title: str | None = None) -> Palette:
    """The palette that names the swatches of several documents of one file (``(H, W, 4)``
    pixels each: an animation's frames, a sheet's sprites): :func:`document_palette` of all
    their pixels, so each colour is named (and numbered) once for the whole file."""
    return document_palette(np.concatenate([np.asarray(p, np.uint8).reshape(-1, 4) for p in pixels]), style, title)


#: a swatch's line in a document's ``<defs>`` (:meth:`Swatches.defs`)
_SWATCH = re.compile(r'<linearGradient id="([^"]*)" inkscape:swatch="solid"[^\n]*</linearGradient>\n')


class SharedSwatches:
    """The swatches of several documents put into one file: each distinct swatch once (the
    same colour and name: the same swatch), under its id; one id for two different swatches
    is made unique (``-2``) in the document that comes later, and its fills follow."""

    def __init__(self) -> None:
        self.lines: list[str] = []  # each swatch's <linearGradient>, in the order they came
        self.ids: set[str] = set()
        self._by_text: dict[str, str] = {}  # a swatch's line without its id → its id in the file

    def take(self, svg: str) -> str:
        """``svg`` without its swatches (and without a ``<defs>`` they alone filled), which
        join the file's, its fills pointing to them."""
        renamed: dict[str, str] = {}

        def taken(found: re.Match[str]) -> str:
            ident = found.group(1)
            text = found.group(0).replace(f' id="{ident}"', "", 1)
            if text not in self._by_text:
                unique, n = ident, 1
                while unique in self.ids:
                    n += 1
                    unique = f"{ident}-{n}"
                self._by_text[text] = unique
                self.ids.add(unique)
                self.lines.append(found.group(0).replace(f' id="{ident}"', f' id="{unique}"', 1))
            if self._by_text[text] != ident:
                renamed[ident] = self._by_text[text]
            return ""

        svg = _SWATCH.sub(taken, svg).replace("<defs>\n</defs>\n", "", 1)
        if renamed:
            svg = re.sub(r"url\(#([^)]*)\)", lambda m: f"url(#{renamed.get(m.group(1), m.group(1))})", svg)
        return svg


class Swatches:
    """The swatches of a document, one per colour of ``colours`` (:func:`picture_colours`):
    their ids, their ``<defs>`` and the fill of a shape."""

    def __init__(self, colours: np.ndarray, palette: Palette | None) -> None:
        self.colours = colours
        self.names = swatch_names(colours, palette)
        self.ids: list[str] = []
        taken: set[str] = set()
        for name in self.names:
            ident = _ident(name)
            base, n = ident, 1
            while ident in taken:
                n += 1
                ident = f"{base}-{n}"
            taken.add(ident)
            self.ids.append(ident)
        self._by_key = {bytes(c): i for i, c in zip(self.ids, colours.tolist())}

    def defs(self) -> str:
        """Every swatch's ``<linearGradient>``."""
        out = []
        for ident, name, colour in zip(self.ids, self.names, self.colours.tolist()):
            label = "" if name == ident else f' inkscape:label="{_attribute(name)}"'
            out.append(f'<linearGradient id="{ident}" inkscape:swatch="solid"{label}><stop offset="0" '
                       f'style="stop-color:#{bytes(colour[:3]).hex()};stop-opacity:{number(colour[3] / 255.0, 3)}"/>'
                       '</linearGradient>\n')
        return "".join(out)

    def fills(self, rgba: np.ndarray) -> list[str]:
        """The fill attribute of shapes of colours ``(S, 4) uint8``: the swatch, then the
        colour for a renderer without it."""
        return [f' fill="url(#{self._by_key[bytes(c)]}) #{bytes(c[:3]).hex()}"' for c in rgba.tolist()]


def _ident(name: str) -> str:
    """``name`` as an XML id: runs of other characters than letters, digits, ``_``, ``.``
    and ``-`` become ``-``; one that starts otherwise than with a letter or ``_``, or like
    the document's own ids (:data:`RESERVED`), gets the prefix ``swatch-``."""
    ident = re.sub(r"[^\w.-]+", "-", name).strip("-")
    head = ident.split("-", 1)[0]
    if not ident or not (ident[0].isalpha() or ident[0] == "_") or (head in RESERVED and not _default(name)):
        ident = f"swatch-{ident}".rstrip("-")
    return ident


def _default(name: str) -> bool:
    return re.fullmatch(r"pal-\d{2,}-[0-9a-f]{6}", name) is not None


def _attribute(text: str) -> str:
    """``text`` as an attribute's value: one line, XML's special and control characters gone."""
    text = "".join(c for c in " ".join(text.split()) if c >= " " and c not in "\ufffe\uffff")
    return text.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")
