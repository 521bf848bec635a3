"""Stage 6 — outlines — VectorImage → the shapes an SVG draws, as loops of segments.

A *face* is a group of linked cells of one RGBA colour (:mod:`depixel.vector`); every face
with any opacity becomes one *shape*. This module decides which area each shape covers and
in which order the shapes are drawn, and writes each shape's boundary as closed loops of
line and quadratic Bézier segments. :mod:`depixel.svg.writer` only formats the result.

Layouts:

* ``"stacked"`` (default; potrace's and vtracer's convention): shapes are drawn back to
  front and every shape continues under the shapes drawn above it. A shape covers its own
  face, every opaque neighbouring face drawn above it, and every hole that this union
  encloses unless the hole holds transparent or translucent pixels. So no shape cuts a hole
  for a shape on top of it, the lower of two touching shapes lies beneath their common
  boundary (no renderer can leave a seam there), and each shape's outline is made of its
  own boundary and of boundaries of the shapes above it, never of hidden fragments; where
  such a boundary is one that a shape above draws against a face below, the outline is
  pulled back under that shape (:mod:`depixel.svg.insets`: no thread of the lower colour
  through the upper shape's edge).
* ``"cutout"``: every shape is exactly its face, with holes; the shapes tile the image
  without overlap. Renderers that anti-alias each shape on its own leave a faint seam where
  two shapes meet (docs/svg.md).

Drawing order: by depth (the number of face boundaries to cross from the image border or
from a transparent area, so enclosing faces come first), then regions together, then
larger faces first, then scanline order. Anything inside a hole of a shape's union has a
greater depth than the shape, so it is drawn later: filling the hole never covers a shape
drawn earlier.

Segments: a run of cell edges along one B-spline curve becomes one quadratic Bézier per
span of the spline (TrueType's implied on-curve points, :class:`~depixel.vector.CurveTable`),
with half spans where the boundary joins or leaves the curve at a node; straight runs
become one line. With ``grid`` set, every coordinate is rounded to that grid once per node,
control point and joint (controls to twice the grid, so every implied on-curve point is
exact and a span may be written as SVG's ``T``): two shapes that share a boundary write
bit-identical numbers for it, in either direction.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..arrays import batch_bounds, in_sorted, ranges
from ..frozen import compact_repr
from ..vector import VectorImage
from .boundaries import CUBIC, LINE, QUAD, BoundaryPieces, build_pieces
from .holes import loops_to_keep, probe_keys
from .insets import InsetGuide, RunMarks, Segments, inset_runs, merge_lines, segment_insets
from .loops import Loops, trace_loops
from .passes import begun
from .runfit import fit_runs
from .simplify import simplify_pieces
from .stacking import FaceBoundaries, FaceTopology

LAYOUTS = ("stacked", "cutout")


@dataclass(frozen=True, eq=False)
class Outlines:
    """Shapes in drawing order (back to front), each a set of closed loops of segments.

    Loop l of shape s is ``loop_ptr[l]:loop_ptr[l+1]`` for l in ``shape_ptr[s]:shape_ptr[s+1]``;
    its segments run from the end of its last segment (the loop's start point) through
    ``seg_end`` in order. The shape's area is the nonzero-rule fill of its loops.
    """

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    shape: tuple[int, int]  # (H, W) of the image, in pixels
    layout: str
    grid: float | None  # coordinates are multiples of this (None: exact)
    face: np.ndarray  # (S,) face label of each shape
    rgba: np.ndarray  # (S, 4) uint8 fill colour and opacity
    region: np.ndarray  # (S,) region label (paper §3.3) of each shape's face
    role: np.ndarray  # (S,) int8 index into ROLES
    shape_ptr: np.ndarray  # (S+1,) loops of each shape
    loop_ptr: np.ndarray  # (L+1,) segments of each loop
    kind: np.ndarray  # (K,) uint8 LINE, QUAD or CUBIC
    ctrl: np.ndarray  # (K, 2) float64 control point of a QUAD, first of a CUBIC (NaN for a LINE)
    ctrl2: np.ndarray  # (K, 2) float64 second control point of a CUBIC (NaN otherwise)
    end: np.ndarray  # (K, 2) float64 end point

    def __len__(self) -> int:
        return int(self.face.size)

    def shapes(self, first: int, stop: int) -> Outlines:
        """Shapes ``first:stop`` alone (views of these arrays)."""
        loop_a, loop_b = int(self.shape_ptr[first]), int(self.shape_ptr[stop])
        seg_a, seg_b = int(self.loop_ptr[loop_a]), int(self.loop_ptr[loop_b])
        segs = slice(seg_a, seg_b)
        return Outlines(
            shape=self.shape, layout=self.layout, grid=self.grid, face=self.face[first:stop],
            rgba=self.rgba[first:stop], region=self.region[first:stop], role=self.role[first:stop],
            shape_ptr=self.shape_ptr[first : stop + 1] - loop_a, loop_ptr=self.loop_ptr[loop_a : loop_b + 1] - seg_a,
            kind=self.kind[segs], ctrl=self.ctrl[segs], ctrl2=self.ctrl2[segs], end=self.end[segs],
        )

    def loop_starts(self) -> np.ndarray:
        """(L, 2) start point of every loop (the end of its last segment)."""
        return self.end[self.loop_ptr[1:] - 1]

    def loops_of(self, s: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Shape ``s`` as a list of loops ``(start, kind, ctrl, ctrl2, end)`` (for tests and tools)."""
        out = []
        starts = self.loop_starts()
        for loop in range(int(self.shape_ptr[s]), int(self.shape_ptr[s + 1])):
            a, b = int(self.loop_ptr[loop]), int(self.loop_ptr[loop + 1])
            out.append((starts[loop], self.kind[a:b], self.ctrl[a:b], self.ctrl2[a:b], self.end[a:b]))
        return out


def build_outlines(image: VectorImage, layout: str = "stacked", grid: float | None = None,
                   simplify: float = 0.0) -> Outlines:
    """The shapes of a vector image in ``layout`` (see the module docstring).

    ``grid`` rounds every coordinate to a multiple of it (the SVG writer passes 10^-precision);
    ``None`` keeps exact coordinates. ``simplify`` > 0 replaces the exact spline by fewer
    quadratics within that many pixels of it (:mod:`depixel.svg.simplify`).
    """
    shapes = outline_shapes(image, layout, grid, simplify)
    return _joined(shapes, list(shapes.batches()))


class OutlineShapes:
    """The shapes of a vector image in drawing order, known before their outlines are traced
    (``face``, ``rgba``, ``region``, ``role`` as in :class:`Outlines`; ``group`` their smooth
    groups), and their outlines a batch of consecutive shapes at a time (:meth:`batches`):
    the SVG writer formats each batch as it comes, so the loops and segments of the whole
    image are never held at once.
    """

    def __init__(self, image: VectorImage, layout: str, grid: float | None, simplify: float) -> None:
        if layout not in LAYOUTS:
            raise ValueError(f"unknown layout {layout!r}; choose one of {', '.join(LAYOUTS)}")
        self.image, self.layout, self.grid = image, layout, grid
        self.shape = image.cells.shape
        stacked = layout == "stacked"
        if (ahead := begun(image, layout, grid, simplify)) is not None:  # simplified with others (passes.py)
            topo, pieces = ahead
        else:
            topo = FaceTopology(image, stacked)
            pieces = build_pieces(image, topo.junction, grid)
            if simplify > 0:
                pieces = simplify_pieces(pieces, image, simplify, grid=grid)
        self.pieces = pieces
        member_key = topo.members(_edge_costs(image, pieces) if stacked else None)
        # sorted keys owner * (F + 1) + member of the (owner, member) pairs: base F + 1, so that
        # no key of the outside (member -1) is a member's
        member_key += member_key // topo.n_faces
        self.member_key = member_key
        self.member_ptr = member_key.searchsorted(np.arange(topo.n_faces + 1) * (topo.n_faces + 1))  # per owner
        self.face = topo.face_of_rank.compress(topo.drawn.take(topo.face_of_rank))
        self.rgba, self.region = topo.face_rgba.take(self.face, axis=0), topo.face_region.take(self.face)
        self.role = topo.role.take(self.face)
        self.group = topo.group.take(self.face)  # each shape's smooth group (depixel.svg.smoothgroups), -1: none
        clear = (~topo.opaque).nonzero()[0]  # a pixel of each transparent or translucent face
        self.probe_key = probe_keys(topo.first_pixel[clear], self.shape[1]) if clear.size else None
        self.faces = topo.boundaries()  # the rest of the topology is dropped here
        self.guide = InsetGuide(image, self.faces) if stacked else None

    def __len__(self) -> int:
        return int(self.face.size)

    def batches(self) -> Iterator[Outlines]:
        """The outlines of the shapes, consecutive batches of about :data:`LOOP_BATCH`
        boundary half-edges (the result does not depend on the batches)."""
        faces, member_ptr = self.faces, self.member_ptr
        per_member = (faces.entry_ptr[1:] - faces.entry_ptr[:-1]).take(self.member_key % (faces.n_faces + 1))
        entries = np.concatenate(([0], per_member.cumsum()))  # running
        del per_member
        sizes = (entries.take(member_ptr[1:]) - entries.take(member_ptr[:-1])).take(self.face)
        del entries
        for a, b in batch_bounds(sizes, LOOP_BATCH):
            yield self._outlines(a, b)

    def _outlines(self, first: int, stop: int) -> Outlines:
        """The outlines of shapes ``first:stop``."""
        faces, face = self.faces, self.face[first:stop]
        lo = self.member_ptr.take(face)
        count = self.member_ptr.take(face + 1) - lo
        member = self.member_key.take(ranges(lo, count)) % (faces.n_faces + 1)
        owner_face, entry, inset = _batch_entries(faces, face, np.arange(face.size).repeat(count), member,
                                                  self.member_key)
        u = faces.entry_from.take(entry)
        loops = trace_loops(faces.rank.take(owner_face), u, faces.entry_to.take(entry), points=faces.nodes)
        keep = loops_to_keep(loops, u, faces.nodes, self.probe_key, self.shape[1], self.layout == "stacked")
        kind, ctrl, ctrl2, end, loop_ptr = _segments_in_batches(
            self.image, self.pieces, loops, keep, _HalfEdges(faces.entry_edge.take(entry), u, inset, owner_face),
            self.guide, self.grid)
        shape_rank = loops.owner.take(keep)
        bounds = np.concatenate((faces.rank.take(face), [np.iinfo(np.int64).max]))
        shape_ptr = np.asarray(shape_rank.searchsorted(bounds), np.int64)
        return Outlines(
            shape=self.shape, layout=self.layout, grid=self.grid, face=face, rgba=self.rgba[first:stop],
            region=self.region[first:stop], role=self.role[first:stop], shape_ptr=shape_ptr,
            loop_ptr=loop_ptr, kind=kind, ctrl=ctrl, ctrl2=ctrl2, end=end,
        )


def outline_shapes(image: VectorImage, layout: str = "stacked", grid: float | None = None,
                   simplify: float = 0.0) -> OutlineShapes:
    """The shapes of a vector image, their outlines to come a batch at a time
    (:func:`build_outlines` has the parameters)."""
    return OutlineShapes(image, layout, grid, simplify)


def _joined(shapes: OutlineShapes, parts: list[Outlines]) -> Outlines:
    """One :class:`Outlines` of consecutive batches."""
    if not parts:
        return Outlines(shape=shapes.shape, layout=shapes.layout, grid=shapes.grid, face=shapes.face,
                        rgba=shapes.rgba, region=shapes.region, role=shapes.role, shape_ptr=np.zeros(1, np.int64),
                        loop_ptr=np.zeros(1, np.int64), kind=np.zeros(0, np.uint8), ctrl=np.zeros((0, 2)),
                        ctrl2=np.zeros((0, 2)), end=np.zeros((0, 2)))
    loop_offset = np.cumsum([0] + [p.loop_ptr.size - 1 for p in parts[:-1]])
    seg_offset = np.cumsum([0] + [p.kind.size for p in parts[:-1]])
    return Outlines(
        shape=shapes.shape, layout=shapes.layout, grid=shapes.grid, face=shapes.face, rgba=shapes.rgba,
        region=shapes.region, role=shapes.role,
        shape_ptr=np.concatenate([parts[0].shape_ptr[:1]] + [p.shape_ptr[1:] + o for p, o in zip(parts, loop_offset)]),
        loop_ptr=np.concatenate([parts[0].loop_ptr[:1]] + [p.loop_ptr[1:] + o for p, o in zip(parts, seg_offset)]),
        kind=np.concatenate([p.kind for p in parts]), ctrl=np.concatenate([p.ctrl for p in parts]),
        ctrl2=np.concatenate([p.ctrl2 for p in parts]), end=np.concatenate([p.end for p in parts]),
    )


def _edge_costs(image: VectorImage, pieces: BoundaryPieces) -> np.ndarray:
    """(E,) what drawing each cell edge in an outline costs, in segments: its piece's
    segments shared out over the piece's edges (a straight edge: a little, since straight
    runs merge into one line)."""
    cost = np.full(len(image.cells.edges), 0.25)
    curved = (pieces.edge_piece >= 0).nonzero()[0]
    piece = pieces.edge_piece.take(curved)
    per_edge = (pieces.ptr[1:] - pieces.ptr[:-1]) / np.maximum(np.bincount(piece, minlength=len(pieces)), 1)
    cost.put(curved, per_edge.take(piece))
    return cost


def _batch_entries(faces: FaceBoundaries, face: np.ndarray, shape: np.ndarray, member: np.ndarray,
                   member_key: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(owner face, boundary entry, inset) of the union of member faces of each shape of a
    batch: ``face`` the shapes' faces, ``(shape, member)`` the pairs (shape: a place in
    ``face``), ``member_key`` of all pairs of the image (sorted). ``inset``: where the entry
    bounds a face drawn above the owner against a face that no shape above the owner covers
    (drawn below it, transparent or translucent), that face (:mod:`depixel.svg.insets`
    pulls the outline back into it), else -2 where the entry bounds another face than the
    owner's (hidden under the shapes above), -1 where it bounds the owner's own."""
    lo = faces.entry_ptr.take(member)
    count = faces.entry_ptr.take(member + 1) - lo
    entry = ranges(lo, count)
    other = faces.entry_other.take(entry)
    # a half-edge bounds the union unless the face across is a member of the same shape
    n = faces.n_faces + 1
    place = shape.repeat(count)
    if face.size * n <= DENSE_MEMBERS * entry.size:
        # a sprite's batch: a dense (shape, face) table of the members (key n - 1, where the
        # outside -1 of the next shape falls, is no face): a lookup instead of a binary search
        table = np.zeros(face.size * n, bool)
        key = shape * n
        key += member
        table.put(key, True)
        key = place * n
        key += other
        outside = ~table.take(key, mode="wrap")  # (the first shape's -1 wraps to the last key)
    else:
        key = face.take(place) * n + other
        outside = ~((other >= 0) & in_sorted(member_key, key))
    owner, entry, other = face.take(place.compress(outside)), entry.compress(outside), other.compress(outside)
    covered = (other >= 0) & faces.opaque.take(other) & (faces.rank.take(other) > faces.rank.take(owner))
    inside = member.repeat(count).compress(outside)
    pulled = (inside != owner) & (other >= 0) & ~covered
    return owner, entry, np.where(pulled, inside, np.where(inside != owner, -2, -1))


#: a batch's members are looked up in a dense (shape, face) table of booleans while it has at
#: most this many bytes a boundary entry (as much as two of the batch's int64 entry arrays),
#: else by a binary search of the sorted keys: a paper sprite's ratio is 0.1-17, a frame
#: batch's 0.1-90 (hundreds of shapes among ~1000 faces)
DENSE_MEMBERS = 16


#: loops are turned into segments in batches of about this many half-edges, to bound the
#: temporary memory (a few hundred bytes a half-edge); the result does not depend on it
LOOP_BATCH = 1 << 13


class _HalfEdges(NamedTuple):
    """Per boundary half-edge of a batch's loops (what ``loops.halfedges`` index)."""

    edge: np.ndarray  # its cell edge
    start: np.ndarray  # the node it leaves
    inset: np.ndarray  # the face its run is pulled back into, or -1 / -2 (:func:`_batch_entries`)
    owner: np.ndarray  # the face of the shape it bounds


def _segments_in_batches(image: VectorImage, pieces: BoundaryPieces, loops: Loops, keep: np.ndarray,
                         halfedges: _HalfEdges, guide: InsetGuide | None, grid: float | None) -> Segments:
    """:func:`_loop_segments` of the kept loops, a batch of loops at a time."""
    sizes = loops.ptr[1:].take(keep) - loops.ptr[:-1].take(keep)
    bounds = batch_bounds(sizes, LOOP_BATCH) or [(0, 0)]  # no loop: one empty batch
    parts = [_loop_segments(image, pieces, loops, keep[a:b], halfedges, guide, grid) for a, b in bounds]
    if len(parts) == 1:
        return parts[0]
    kind, ctrl, ctrl2, end, ptrs = zip(*parts)
    offsets = np.cumsum([0] + [p[-1] for p in ptrs[:-1]])
    loop_ptr = np.concatenate([ptrs[0][:1]] + [p[1:] + off for p, off in zip(ptrs, offsets)])
    return Segments(np.concatenate(kind), np.concatenate(ctrl), np.concatenate(ctrl2), np.concatenate(end), loop_ptr)


def _loop_segments(image: VectorImage, pieces: BoundaryPieces, loops: Loops, keep: np.ndarray,
                   halfedges: _HalfEdges, guide: InsetGuide | None, grid: float | None) -> Segments:
    """Segments of the kept loops: a straight cell edge is a line, a run along a curve is its
    pieces, each written where the loop enters it, in the loop's direction; the runs along a
    face that ``halfedges.inset`` names pulled back into it."""
    cells = image.cells
    first = loops.ptr[:-1].take(keep)
    counts = loops.ptr[1:].take(keep) - first
    he = loops.halfedges.take(ranges(first, counts))
    edge, x = halfedges.edge.take(he), halfedges.start.take(he)
    # edge k's nodes are at 2k and 2k + 1 of the flat (E, 2) array (a column's take copies
    # the whole column first; gathered rows would leave strided columns)
    u, v = cells.edges.ravel().take(2 * edge), cells.edges.ravel().take(2 * edge + 1)
    stored = x == u  # the half-edge runs the way its edge is stored
    y = np.where(stored, v, u)
    loop_of = np.arange(keep.size).repeat(counts)
    piece = pieces.edge_piece.take(edge)
    curved = piece >= 0
    forward_edge = image.curves.edge_forward.take(edge) if image.curves is not None else np.ones(edge.size, bool)
    along = stored == forward_edge
    enters = curved & np.where(along, pieces.edge_first.take(edge), pieces.edge_last.take(edge))
    length = np.concatenate((pieces.ptr[1:] - pieces.ptr[:-1], [0]))  # (a sentinel for images without curves)
    n_seg = np.where(curved, np.where(enters, length.take(piece), 0), 1)  # (piece -1: the sentinel)
    total = int(n_seg.sum())
    step = np.arange(edge.size).repeat(n_seg)
    index = ranges(0, n_seg)  # within the piece
    line = ~curved.take(step)
    # every coordinate a column at a time, picked by np.where from gathers of all rows
    # (masked writes into (total, 2) rows cost numpy a row-by-row copy): a line ends at
    # its cell edge's far node, a run along a curve is its pieces' segments, forwards
    # (``src``) or backwards (``back``, a cubic's controls swapped, ending where the
    # segment before it ends, or at the piece's start)
    point = _on_grid(image.points.take(y.take(step), axis=0), grid)
    end = point
    if pieces.kind.size:  # (no curves: lines only)
        p = np.maximum(piece.take(step), 0)
        first_seg = pieces.ptr.take(p)
        fwd = along.take(step)
        back = first_seg + length.take(p) - 1 - index  # the segment traversed backwards
        src = np.where(fwd, first_seg + index, back)
        src[line] = 0
        kind = np.where(line, LINE, pieces.kind.take(src)).astype(np.uint8)
        swap = ~fwd & (kind == CUBIC)  # a cubic backwards swaps its control points
        at_start = ~line & ~fwd & (back == first_seg)
        end_at = np.where(fwd, src, back - 1)
        end_at[line | at_start] = 0
        firsts, seconds = pieces.ctrl.take(src, axis=0), pieces.ctrl2.take(src, axis=0)
        starts, ends = pieces.start.take(p, axis=0), pieces.end.take(end_at, axis=0)
        ctrl, ctrl2 = np.empty((total, 2)), np.empty((total, 2))
        for c in range(2):
            first, second = firsts[:, c], seconds[:, c]
            ctrl[:, c] = np.where(line, np.nan, np.where(swap, second, first))
            ctrl2[:, c] = np.where(line, np.nan, np.where(swap, first, second))
            end[:, c] = np.where(line, point[:, c], np.where(at_start, starts[:, c], ends[:, c]))
        span = np.where(line, -1, pieces.span_slot.take(src).astype(np.int64))
    else:
        kind = np.full(total, LINE, np.uint8)
        ctrl = np.full((total, 2), np.nan)
        ctrl2 = np.full((total, 2), np.nan)
        span = np.full(total, -1, np.int64)
    seg_loop = loop_of.take(step)
    margin, f_in, f_out = segment_insets(guide, halfedges.inset.take(he), halfedges.owner.take(he), x, loop_of, n_seg)
    # where a loop goes on along its curve through a junction, the two halves of the span
    # there (the end of one piece, the start of the next) are that one span
    whole = ((span[:-1] >= 0) & (span[:-1] == span[1:]) & (seg_loop[:-1] == seg_loop[1:])
                           & (kind[:-1] == QUAD) & (kind[1:] == QUAD)
                           & (margin[:-1] == margin[1:]) & np.isnan(f_out[:-1, 0])
                           & np.isnan(f_in[1:, 0])).nonzero()[0]  # (straight halves merge as lines)
    if whole.size:
        ctrl[whole + 1] = pieces.span_ctrl(span[whole])
        keep_seg = np.ones(total, bool)
        keep_seg[whole] = False
        f_in[whole + 1] = np.where(np.isnan(f_in[whole]), f_in[whole + 1], f_in[whole])  # (a run's first half)
        kind, seg_loop, margin = kind.compress(keep_seg), seg_loop.compress(keep_seg), margin.compress(keep_seg)
        ctrl, ctrl2, end, f_in, f_out = (a.compress(keep_seg, axis=0) for a in (ctrl, ctrl2, end, f_in, f_out))
    loop_ptr = seg_loop.searchsorted(np.arange(keep.size + 1)).astype(np.int64)
    segments, run, run_margin = inset_runs(*merge_lines(Segments(kind, ctrl, ctrl2, end, loop_ptr),
                                                        RunMarks(margin, f_in, f_out), grid), grid)
    return fit_runs(segments, run, run_margin, grid)


def _on_grid(xy: np.ndarray, grid: float | None) -> np.ndarray:
    return xy.copy() if grid is None else (xy / grid).round() * grid
