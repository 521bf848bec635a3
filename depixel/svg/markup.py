"""Stage 7 — SVG export — the elements around the path data: labels, groups, smooth shading.

:mod:`depixel.svg.writer` formats the path data and the document; this module writes what
wraps it: each shape's ``<path>`` with its ``id`` and ``inkscape:label``, the ``<g>`` of a
run of shapes of one region, and the smooth shading of paper §3.5 (docs/svg.md).

The bands of a smooth group (:mod:`depixel.svg.smoothgroups`, drawn one after another) stay
where the flat document draws them, in a ``<g>`` (the region's own when the group is the
whole run of its region) filtered by one shared filter:

* a Gaussian blur of the group's colours (SVG blurs premultiplied colours);
* alpha set to 1: ``feComponentTransfer`` works on unpremultiplied colours, so the colour
  left is the blur's weighted average of the colours under it, a normalized convolution in
  which nothing but the group's bands takes part;
* ``in`` SourceAlpha: the result kept to the group's own area and opacity, which is what a
  clip to the bands' outline would do, without new path data. Against a shape drawn
  before (beneath) the group that is the contour itself, so nothing of the blur leaves the
  group and the contour stays crisp. In the stacked layout the bands continue under the
  shapes drawn above them, which cover that part as they cover the flat bands; a
  ``<g mask>`` inside the group keeps that hidden part out of the blur
  (:mod:`depixel.svg.hiding`).

A renderer without filters draws the flat bands; the document paints the same areas as the
flat one, in the same order, so it never opens a seam.
"""
from __future__ import annotations

import numpy as np

from ..arrays import unique
from .hiding import cover_filter, covering_shapes, mask
from .outlines import Outlines, OutlineShapes
from .stacking import ROLES
from .svgtext import number
from .swatches import Swatches

#: the id of the smooth shading's filter
FILTER_ID = "smooth"


class Labels:
    """What the elements of all shapes say besides their paths: each shape's ``id``
    (``role-rrggbb``, with ``-2``, ``-3``… where that repeats), its run of shapes of one
    region (a ``<g>`` when the run has several), and with ``smooth`` the smooth groups of
    ``shapes`` (an :class:`~depixel.svg.outlines.OutlineShapes`; outlines alone have none);
    the shapes are filled with ``swatches`` (:mod:`depixel.svg.swatches`) when given."""

    def __init__(self, shapes: Outlines | OutlineShapes, smooth: bool = False,
                 swatches: Swatches | None = None) -> None:
        self.swatches = swatches
        region = shapes.region
        self.run_start = np.concatenate(([True], region[1:] != region[:-1]))
        self.run_end = np.empty_like(self.run_start)  # the last shape of its run
        self.run_end[:-1], self.run_end[-1:] = self.run_start[1:], True
        self.run_id = self.run_start.cumsum() - 1
        self.run_size = np.bincount(self.run_id)
        self.grouped = self.run_size.take(self.run_id) > 1
        rgba = shapes.rgba.astype(np.int64)
        key = (shapes.role.astype(np.int64) << 24) | (rgba[:, 0] << 16) | (rgba[:, 1] << 8) | rgba[:, 2]
        order = key.argsort(kind="stable")
        ranked = key[order]
        self.count = np.empty(key.size, np.int64)  # the how-manieth shape of its id
        self.count[order] = np.arange(key.size) - ranked.searchsorted(ranked) + 1
        self.role, self.rgba = shapes.role, shapes.rgba
        group = getattr(shapes, "group", None)
        self.smooth = Smooth(shapes, self, group if smooth and group is not None else np.full(len(shapes), -1))

    def fills(self, rgba: np.ndarray) -> list[str]:
        """The fill attributes of shapes of colours ``(S, 4) uint8``: ``fill="#rrggbb"`` and
        ``fill-opacity`` when not opaque, or the swatch (which holds the opacity)."""
        if self.swatches is not None:
            return self.swatches.fills(rgba)
        colours = rgba[:, :3].tobytes().hex(" ", 3).split()  # "rrggbb" each
        return [f' fill="#{colour}"' + ("" if alpha == 255 else f' fill-opacity="{number(alpha / 255.0, 3)}"')
                for colour, alpha in zip(colours, rgba[:, 3].tolist())]

    def idents(self, first: int, stop: int) -> list[str]:
        """The ``id`` of shapes ``first:stop``."""
        colours = self.rgba[first:stop, :3].tobytes().hex(" ", 3).split()
        return [f"{ROLES[role]}-{colour}" if count == 1 else f"{ROLES[role]}-{colour}-{count}"
                for role, colour, count in zip(self.role[first:stop].tolist(), colours,
                                               self.count[first:stop].tolist())]


class Smooth:
    """The smooth groups of a document: the markup that opens each group before its first
    band and closes it after its last, and the masks that keep from each group's blur what
    the shapes drawn after it hide (:mod:`depixel.svg.hiding`)."""

    def __init__(self, shapes: Outlines | OutlineShapes, labels: Labels, group: np.ndarray) -> None:
        self.opens: dict[int, str] = {}  # shape → markup written before it
        self.closes: dict[int, str] = {}  # shape → markup written after it
        self.merged = np.zeros(len(shapes), bool)  # the <g> of the shape's region run is its group's
        self.shape = shapes.shape
        shaded = group >= 0
        starts = (shaded & np.concatenate(([True], group[1:] != group[:-1]))).nonzero()[0]
        ends = (shaded & np.concatenate((group[1:] != group[:-1], [True]))).nonzero()[0]
        assert unique(group.take(starts)).size == starts.size, "a smooth group is drawn in one run"
        self.n_groups = int(starts.size)
        self.masks: list[tuple[str, list[str]]] = []  # (id, the ids of the covering shapes)
        colours = shapes.rgba[:, :3].take(starts, axis=0).tobytes().hex(" ", 3).split()
        covering = covering_shapes(shapes, starts, ends)
        for a, b, colour, cover in zip(starts.tolist(), ends.tolist(), colours, covering):
            merged = bool(labels.grouped[a] and labels.run_start[a] and labels.run_end[b])
            ident = f"region-{int(shapes.region[a])}-{int(labels.run_id[a])}" if merged else f"smooth-{a}"
            self.opens[a] = (f'<g id="{ident}" inkscape:label="smooth shading #{colour} ({b + 1 - a} tones)" '
                             f'filter="url(#{FILTER_ID})">\n')
            closes = "" if merged else "</g>\n"
            if cover.size:
                self.masks.append((f"hide-{a}", [i for c in cover.tolist() for i in labels.idents(c, c + 1)]))
                self.opens[a] += f'<g mask="url(#hide-{a})">\n'
                closes = "</g>\n" + closes
            if closes:
                self.closes[b] = closes
            self.merged[a] = merged

    def defs(self, sigma: float) -> str:
        """The ``<defs>`` of the filter and the masks, or nothing when there is no group."""
        if not self.n_groups:
            return ""
        return (f'<defs>\n<filter id="{FILTER_ID}" color-interpolation-filters="sRGB">'
                f'<feGaussianBlur stdDeviation="{number(sigma, 6)}"/>'
                '<feComponentTransfer><feFuncA type="table" tableValues="1 1"/></feComponentTransfer>'
                '<feComposite in2="SourceAlpha" operator="in"/></filter>\n'
                + (cover_filter(self.shape) if self.masks else "")
                + "".join(mask(ident, self.shape, cover) for ident, cover in self.masks)
                + '</defs>\n')


def elements(outlines: Outlines, first: int, labels: Labels, data: list[str]) -> str:
    """The elements of a batch of shapes (``data`` their path data), the first being shape
    ``first``."""
    n = len(outlines)
    if n == 0:
        return ""
    stop = first + n
    smooth = labels.smooth
    # Python lists and strings made for the whole batch at once: the loop reads a few values
    # per shape (numpy scalars cost ~100 ns apiece; the colours' hex digits in one call)
    grouped = labels.grouped[first:stop]
    opens = (grouped & labels.run_start[first:stop] & ~smooth.merged[first:stop]).tolist()
    closes = (grouped & labels.run_end[first:stop]).tolist()
    colours = outlines.rgba[:, :3].tobytes().hex(" ", 3).split()  # "rrggbb" each
    lines = []
    for i, (role, colour, fill, ident, d) in enumerate(zip(outlines.role.tolist(), colours,
                                                           labels.fills(outlines.rgba), labels.idents(first, stop),
                                                           data)):
        s = first + i
        if opens[i]:
            run = int(labels.run_id[s])
            lines.append(f'<g id="region-{int(outlines.region[i])}-{run}" '
                         f'inkscape:label="shading #{colour} ({int(labels.run_size[run])} tones)">\n')
        if s in smooth.opens:
            lines.append(smooth.opens[s])
        lines.append(f'<path id="{ident}" inkscape:label="{ROLES[role]} #{colour}"{fill} d="{d}"/>\n')
        if s in smooth.closes:
            lines.append(smooth.closes[s])
        if closes[i]:
            lines.append("</g>\n")
    return "".join(lines)
