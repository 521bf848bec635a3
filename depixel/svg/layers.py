"""Output — several SVG documents → one, each a layer at its place: a sprite sheet's sprites,
each converted alone, back on their sheet.

Each document becomes ``<g inkscape:groupmode="layer" inkscape:label="NAME"
transform="translate(x,y)">`` (Inkscape's layers panel lists them) holding the document's
content as it was: its path data is not rewritten, so a layer drawn alone is its document
moved to its place. A document whose viewBox is not its rectangle at 1:1 (art converted from
an upscaled input: :mod:`depixel.render.overlay`) is mapped onto its rectangle by a scale
after the translation. The documents' ``id``\\ s (the writer's ``outline-181425``,
``region-3-5``, the smooth shading's ``smooth`` filter…) would collide across documents: each
layer's ids, and every ``url(#…)`` and ``href="#…"`` that points at them, get the layer's own
prefix. The documents' titles are dropped (the layer's label names it) and so is what comes
before the ``<svg>`` element (the XML declaration, a stamp comment).

This is how a sheet's frames could be put in one animated SVG too: the same per-document
prefix keeps each frame's ids apart, and each layer could be shown in turn.
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from .svgtext import number
from .writer import INKSCAPE_NS, SVG_HEADER, XLINK, _escape

_SVG_OPEN = re.compile(r"<svg\b[^>]*>")
_VIEWBOX = re.compile(r"""\sviewBox\s*=\s*["']([^"']*)["']""")
_TITLE = re.compile(r"<title>.*?</title>\n?", re.S)
_REFERENCES = re.compile(r"""(\sid=")|(url\(#)|(href="#)""")


@dataclass(frozen=True)
class Placed:
    """One document and its place: ``x``, ``y``, ``width``, ``height`` in the combined
    document's user units (a sheet's pixels)."""

    name: str
    svg: str
    x: float
    y: float
    width: float
    height: float


def layer_ids(names: Sequence[str]) -> list[str]:
    """An XML id for each name: its letters, digits, ``-`` and ``_`` (others ``_``), starting
    with a letter, made unique with ``-2``, ``-3``…"""
    out: list[str] = []
    taken: set[str] = set()
    for name in names:
        base = re.sub(r"[^A-Za-z0-9_-]", "_", name)
        base = base if base[:1].isalpha() else "s" + base
        ident, n = base, 1
        while ident in taken or any(other.startswith(ident + "-") for other in taken):
            n += 1
            ident = f"{base}-{n}"
        taken.add(ident)
        out.append(ident)
    return out


def compose_layers(layers: Sequence[Placed], width: int, height: int, *, scale: float = 1.0,
                   title: str | None = None, precision: int = 6) -> str:
    """One SVG of ``width`` × ``height`` user units (shown ``scale`` times that size) holding
    each of ``layers`` as an Inkscape layer at its place, in order (the first drawn first)."""
    contents = [_content(layer.svg, layer.name) for layer in layers]
    xlink = XLINK if any("xlink:" in content for content, _ in contents) else ""  # (the smooth shading's masks)
    head = (f'{SVG_HEADER}<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="{INKSCAPE_NS}"{xlink} version="1.1" '
            f'width="{number(width * scale, 3)}" height="{number(height * scale, 3)}" '
            f'viewBox="0 0 {width} {height}">\n')
    parts = [head + (f"<title>{_escape(title)}</title>\n" if title else "")]
    for layer, ident, (content, box) in zip(layers, layer_ids([layer.name for layer in layers]), contents):
        content = _REFERENCES.sub(r"\g<0>" + ident + "-", content)  # (ident: letters, digits, - and _)
        transform = f"translate({number(layer.x, precision)},{number(layer.y, precision)})"
        if box != (0.0, 0.0, layer.width, layer.height):
            sx, sy = layer.width / box[2], layer.height / box[3]
            transform += f" scale({number(sx, precision)},{number(sy, precision)})"
            if box[0] or box[1]:
                transform += f" translate({number(-box[0], precision)},{number(-box[1], precision)})"
        parts.append(f'<g id="{ident}" inkscape:groupmode="layer" inkscape:label="{_escape(layer.name)}" '
                     f'transform="{transform}">\n{content}</g>\n')
    parts.append("</svg>\n")
    return "".join(parts)


def _content(svg: str, name: str) -> tuple[str, tuple[float, float, float, float]]:
    """What a document draws (inside its ``<svg>``, its title dropped) and its viewBox."""
    opening = _SVG_OPEN.search(svg)
    end = svg.rfind("</svg>")
    if opening is None or end < opening.end():
        raise ValueError(f"layer {name!r}: not an SVG document (no <svg>…</svg>)")
    found = _VIEWBOX.search(opening.group(0))
    try:
        box = tuple(float(v) for v in re.split(r"[\s,]+", found.group(1).strip())) if found else ()
    except ValueError:
        box = ()
    if len(box) != 4 or box[2] <= 0 or box[3] <= 0:
        raise ValueError(f"layer {name!r}: the SVG has no usable viewBox")
    body = svg[opening.end():end].lstrip("\n")
    return _TITLE.sub("", body, count=1), (box[0], box[1], box[2], box[3])
