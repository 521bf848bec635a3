"""What a smooth group's blur must not see: the parts of its bands that shapes drawn above hide.

Part of stage 7 (:mod:`depixel.svg.markup`). In the stacked layout a group's bands continue
under the shapes drawn above them (no seam), so the group's own drawing holds colours that
no one sees, and a blur of it pulls them out around the shape on top: a ring of the hidden
colour (``sbm4_02``'s pink shoe lies on a light grey band inside a black outline, and the
grey haloed the shoe). So the bands of such a group are drawn inside a ``<g mask>`` that
takes away what the opaque shapes drawn after the group cover, and the blur's normalized
convolution sees only what the group shows (:data:`COVER_ID`'s filter turns the ``<use>`` of
each covering shape into black). The mask is the covering shapes eroded by
:data:`COVER_EROSION`, so under their anti-aliased edges the group keeps its full alpha and
its own shaded colour: the shape on top anti-aliases over the group's colour, never over what
lies beneath the group. The strip the erosion leaves is a sliver of the hidden colour, a few
levels at most in the blur (docs/svg.md, "Hidden parts").

A renderer without masks and filters draws the bands as they are; cairosvg reads a mask's
alpha (the white rectangle's: 1 everywhere), so its render is the flat document's.
"""
from __future__ import annotations

import numpy as np

from ..arrays import ranges, unique
from .outlines import Outlines, OutlineShapes
from .svgtext import number

#: the id of the filter that makes a mask's covering shapes black
COVER_ID = "cover"
#: not in paper: the mask takes the group's bands away only where a covering shape covers
#: a render pixel whole (8-bit coverage 255, ramping from 254): on a covering shape's
#: anti-aliased edge the group keeps its full alpha, so the shape on top anti-aliases over
#: the group's colour and never over what lies beneath the group (a coverage of 7/8 left
#: 12 see-through pixels on the corpus in resvg)
COVER_FROM = 254 / 255


def covering_shapes(shapes: Outlines | OutlineShapes, starts: np.ndarray, ends: np.ndarray) -> list[np.ndarray]:
    """For each smooth group (shapes ``starts[k]..ends[k]``, inclusive), the opaque shapes
    drawn after it whose face its bands cover (stacked layout: the faces drawn above a band
    that its shape stands under). Each of those shapes covers the faces it stands under in
    turn, and a hole the bands' union encloses is filled by the band and covered by them, so
    together they hide every hidden part of the group. None in the cutout layout, whose shapes
    do not continue under others."""
    member_key = getattr(shapes, "member_key", None)
    if member_key is None or starts.size == 0 or shapes.layout != "stacked":
        return [np.zeros(0, np.int64) for _ in starts.tolist()]
    member_ptr = shapes.member_ptr  # type: ignore[union-attr]
    n = member_ptr.size - 1
    face = shapes.face
    shape_of = np.full(n, -1, np.int64)
    shape_of[face] = np.arange(face.size)
    opaque = shapes.rgba[:, 3] == 255
    out = []
    for a, b in zip(starts.tolist(), ends.tolist()):
        own = face[a : b + 1]
        lo, hi = member_ptr.take(own), member_ptr.take(own + 1)
        covered = shape_of.take(member_key.take(ranges(lo, hi - lo)) % (n + 1))
        covered = unique(covered.compress(covered > b))
        out.append(covered.compress(opaque.take(covered)))
    return out


def cover_filter() -> str:
    """The filter that draws a mask's covering shapes in black where they cover a render
    pixel whole (alpha ``(coverage - COVER_FROM) / (1 - COVER_FROM)``)."""
    slope = 1.0 / (1.0 - COVER_FROM)
    return (f'<filter id="{COVER_ID}"><feComponentTransfer in="SourceAlpha"><feFuncA type="linear" '
            f'slope="{number(slope, 6)}" intercept="{number(1.0 - slope, 6)}"/></feComponentTransfer></filter>\n')


def mask(ident: str, shape: tuple[int, int], covering: list[str]) -> str:
    """A ``<mask>`` that keeps everything but the shapes ``covering`` (their ids)."""
    h, w = shape
    uses = "".join(f'<use xlink:href="#{c}"/>' for c in covering)
    return (f'<mask id="{ident}" maskUnits="userSpaceOnUse" x="-1" y="-1" width="{w + 2}" height="{h + 2}">'
            f'<rect x="-1" y="-1" width="{w + 2}" height="{h + 2}" fill="#fff"/>'
            f'<g filter="url(#{COVER_ID})">{uses}</g></mask>\n')
