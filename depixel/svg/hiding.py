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

from ..arrays import in_sorted, ranges, unique
from .outlines import Outlines, OutlineShapes
from .stacking import FaceBoundaries
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
        covered = covered.compress(opaque.take(covered))
        out.append(covered.compress(~_inside_another(covered, face, member_key, n, shapes.faces)))  # type: ignore[union-attr]
    return out


def _inside_another(covered: np.ndarray, face: np.ndarray, member_key: np.ndarray, n: int,
                    faces: FaceBoundaries) -> np.ndarray:
    """(k,) whether each shape of ``covered`` lies wholly inside another of them: its face
    is one that the other covers (a member of its shape) and borders no face drawn below the
    other (or not opaque), so the other pulls back from none of its edges
    (:mod:`depixel.svg.insets`) and its ``<use>`` already takes the whole area out of the
    mask."""
    if covered.size < 2:
        return np.zeros(covered.size, bool)
    own = face.take(covered)
    # every (other, this) pair of the list: this face a member of the other's shape
    key = np.repeat(own.astype(np.int64), own.size) * (n + 1) + np.tile(own, own.size)
    hit = in_sorted(member_key, key).reshape(own.size, own.size)
    np.fill_diagonal(hit, False)
    rank = faces.rank.take(own)
    for j in np.flatnonzero(np.logical_or.reduce(hit, axis=0)).tolist():
        around = faces.entry_other[faces.entry_ptr[own[j]]:faces.entry_ptr[own[j] + 1]]
        low = np.where((around >= 0) & faces.opaque.take(np.maximum(around, 0)),
                       faces.rank.take(np.maximum(around, 0)), -1)
        for i in np.flatnonzero(hit[:, j]).tolist():
            hit[i, j] = bool(((around == own[i]) | (low > rank[i])).all())
    return np.logical_or.reduce(hit, axis=0)


def cover_filter(shape: tuple[int, int]) -> str:
    """The filter that draws a mask's covering shapes in black where they cover a render
    pixel whole (alpha ``(coverage - COVER_FROM) / (1 - COVER_FROM)``), and the white
    rectangle over the image that every mask keeps (:data:`KEEP_ID`)."""
    h, w = shape
    slope = 1.0 / (1.0 - COVER_FROM)
    return (f'<filter id="{COVER_ID}"><feComponentTransfer in="SourceAlpha"><feFuncA type="linear" '
            f'slope="{number(slope, 6)}" intercept="{number(1.0 - slope, 6)}"/></feComponentTransfer></filter>\n'
            f'<rect id="{KEEP_ID}" x="-1" y="-1" width="{w + 2}" height="{h + 2}" fill="#fff"/>\n')


def mask(ident: str, shape: tuple[int, int], covering: list[str]) -> str:
    """A ``<mask>`` that keeps everything but the shapes ``covering`` (their ids). It spans
    the image and a pixel more (cairosvg fades a mask at its region's edge: the default
    region, the masked group's box and a tenth more, changed 352 render pixels of
    ``icon_disk`` by up to 112 levels)."""
    h, w = shape
    uses = "".join(f'<use xlink:href="#{c}"/>' for c in covering)
    return (f'<mask id="{ident}" maskUnits="userSpaceOnUse" x="-1" y="-1" width="{w + 2}" height="{h + 2}">'
            f'<use xlink:href="#{KEEP_ID}"/><g filter="url(#{COVER_ID})">{uses}</g></mask>\n')


#: the id of the white rectangle over the image that the masks keep (in ``<defs>``)
KEEP_ID = "keep"
