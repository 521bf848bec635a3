"""Stage 4 — paper §3.3 — reshaped cell graph → quadratic B-spline curves.

Visible edges separate dissimilar pixels (also a visible pixel from a fully transparent
one); the image border is never visible and stays straight. At every node the visible
edges are paired:

* visible valence 2: the two edges continue each other;
* valence 3 (T-junction): with exactly one shading edge (YUV distance ≤ 100) and two contour
  edges, the contour edges continue each other; otherwise the pair whose angle is closest
  to 180°; the third curve ends on the continuing one;
* valence 1 or ≥ 4: every curve ends there.

Chains of paired edges are curves: open (clamped, from end node to end node) or closed
(periodic). A curve's control points are its node positions. It is drawn as TrueType-style
quadratic segments: segment i has off-curve point C_i and on-curve ends at the midpoints of
C_{i-1}C_i and C_iC_{i+1} (or at the clamped end points). Each cell-graph edge gets the
part of the curve between the curve points of its two nodes — S_i, the middle (t = ½) of
segment i — written as two quadratic Béziers, which is exact (de Casteljau split).

A curve that ends at a T-junction gets that end's control point moved to the point S of
the continuing curve, so the two meet exactly (§3.3, last paragraph). Because S itself
depends on neighbouring control points, the snapping is iterated ``Params.snap_passes`` times.

The steps (:mod:`depixel.curves.pairing`): :func:`visible_edges` and :func:`shading_edges` say which
edges carry curves and of what kind; :func:`pair_ends` applies the rules above at every node;
:func:`chain_curves` walks the pairs into curves. This module holds the product,
:class:`SplineSet` (the curves, their control points and their drawing), and
:func:`extract_splines`, which runs those steps. The optimizer cuts curves at corners with
:func:`split_at`, which cuts the chains themselves (nothing is extracted or walked twice).
The curve maths is in :mod:`depixel.curves.bspline`, the drawing's products and the fixed
plans of drawing and snapping in :mod:`depixel.curves.drawing`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..arrays import batch_slices, flat_rows
from ..frozen import compact_repr, freeze
from ..graph.cells import INDEX, CellGraph
from ..params import Params
from ..vector import CurveTable, VectorImage, linked_edges
from .bspline import Bezier, between_curve_points, midpoint, slot_spans
from .drawing import Drawing, DrawPlan, Geometry, SnapPlan
from .pairing import Chains, HalfEnds, band_edges, chain_curves, cut_chains, pair_ends, shading_edges, visible_edges

#: slots whose curve geometry is computed together: bounds the temporaries of the spans and
#: Béziers (a few hundred bytes a slot) whatever the number of slots
GEOMETRY_BATCH = 1 << 15

#: slots up to which :meth:`SplineSet.drawings` draws several position sets in one pass (a
#: sprite's few thousand); above, one at a time, which keeps a frame's temporaries as they were
TOGETHER_SLOTS = 8192


@dataclass(frozen=True, eq=False)
class SplineSet:
    """Curves over the cell graph and the initial control points (pixel units); arrays
    are read-only.

    Vocabulary: the curves are stored one after another in flat arrays; an index into them
    is a **slot** (``P`` slots in all; an open curve has one slot per node, both ends
    included, a closed one one slot per edge). A node's **position** is always its
    coordinates ``(x, y)`` in pixels; the **control point** of a slot is its node's position
    (with T-junction ends snapped, :meth:`controls_for`).
    """

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    cells: CellGraph
    visible: np.ndarray  # (E,) bool: edge separates dissimilar pixels
    shading: np.ndarray  # (E,) bool: visible edge between colours within shading_distance
    curve_ptr: np.ndarray  # (C+1,) int32: curve c owns slots curve_ptr[c]:curve_ptr[c+1]
    curve_nodes: np.ndarray  # (P,) int32 node at each slot (an open curve lists both end nodes)
    curve_closed: np.ndarray  # (C,) bool
    slot_edges: np.ndarray  # (P,) int32 edge from slot j to j+1 (wrapping for closed); -1 after an open end
    slot_forward: np.ndarray  # (P,) bool: that edge is stored u→v in the direction of the curve
    positions: np.ndarray  # (N, 2) float64 initial node positions (quarter-pixel grid, in pixels)
    half_ends: HalfEnds  # the pairing the curves were chained from (for split_at)
    snap_passes: int  # Params.snap_passes

    def __post_init__(self) -> None:
        freeze(self)

    # --- derived layout helpers (all (P,) arrays) -----------------------------------------
    @property
    def n_curves(self) -> int:
        return int(self.curve_closed.size)

    @property
    def n_slots(self) -> int:
        return int(self.curve_nodes.size)

    def slot_curve(self) -> np.ndarray:
        """(P,) the curve each slot belongs to."""
        ptr = self.curve_ptr
        return np.arange(self.n_curves, dtype=INDEX).repeat(ptr[1:] - ptr[:-1])

    def neighbours(self) -> tuple[np.ndarray, np.ndarray]:
        """Previous and next slot of every slot along its curve (-1 past an open end).

        Computed once per SplineSet (the arrays are shared, hence read-only)."""
        return self._links

    @cached_property
    def _links(self) -> tuple[np.ndarray, np.ndarray]:
        p = self.curve_nodes.size
        prev, nxt = np.arange(-1, p - 1, dtype=INDEX), np.arange(1, p + 1, dtype=INDEX)
        # then each curve's first and last slot (per curve, not per slot)
        first, last = self.curve_ptr[:-1], self.curve_ptr[1:] - 1
        prev[first] = np.where(self.curve_closed, last, -1)
        nxt[last] = np.where(self.curve_closed, first, -1)
        prev.setflags(write=False)
        nxt.setflags(write=False)
        return prev, nxt

    def is_end(self) -> np.ndarray:
        """(P,) bool: the slot is an open curve's end point (clamped, interpolated)."""
        prev, nxt = self.neighbours()
        return (prev < 0) | (nxt < 0)

    def through_nodes(self) -> np.ndarray:
        """(N,) bool: node lies inside a curve (the curve passes smoothly through it)."""
        mask = np.zeros(len(self.positions), dtype=bool)
        mask[self.curve_nodes[~self.is_end()]] = True
        return mask

    # --- geometry -------------------------------------------------------------------------
    def snap_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """Open-curve ends at T-junctions and the slot of the curve passing through their
        node: ``(ends, through)``, both (T,) slot indices."""
        end = self.is_end()
        where = np.full(len(self.positions), -1, dtype=np.int64)
        interior = (~end).nonzero()[0]
        where[self.curve_nodes[interior]] = interior
        ends = (end & (where[self.curve_nodes] >= 0)).nonzero()[0]
        return ends, where[self.curve_nodes[ends]]

    def snap(self, ctrl: np.ndarray) -> np.ndarray:
        """Move the T-junction end control points of ``ctrl`` (P, 2) onto the curve point of
        the curve continuing through their node (iterated: those points may depend on
        other snapped ends). Returns a new array."""
        return self._snap_in_place(ctrl.copy())

    def _snap_in_place(self, ctrl: np.ndarray) -> np.ndarray:
        """:meth:`snap` on ``ctrl`` itself (returned)."""
        plan, chained = self._snap_plans
        if plan.ends.size:
            plan.move(ctrl, check=False)
            # the other ends would get the same points again, and so would these once a
            # pass leaves them where they are
            for _ in range(self.snap_passes - 1 if chained.ends.size else 0):
                if not chained.move(ctrl):
                    break
        return ctrl

    @cached_property
    def _snap_plans(self) -> tuple[SnapPlan, SnapPlan]:
        """Indices :meth:`snap` needs, computed once per SplineSet: every T-junction end,
        and those of them snapped again after the first pass."""
        ends, through = self.snap_pairs()
        prev, nxt = self.neighbours()
        end = (prev < 0) | (nxt < 0)
        a, b = prev[through], nxt[through]
        plan = SnapPlan.of(ends, through, a, b, end[a][:, None], end[b][:, None])
        return plan, plan.chained(self.n_slots)

    def controls_for(self, positions: np.ndarray) -> np.ndarray:
        """(P, 2) control point of every slot for node ``positions`` (N, 2), with T-junction
        ends snapped."""
        return self._snap_in_place(positions.take(self.curve_nodes, axis=0))

    def spans(self, ctrl: np.ndarray) -> Bezier:
        """The quadratic Bézier span ``(start, C_j, stop)`` of every slot, each (P, 2), for
        control points ``ctrl`` (P, 2) (from :meth:`controls_for`). The B-spline is exactly
        the chain of the spans of a curve's interior slots; rows of end slots
        (:meth:`is_end`) are meaningless."""
        prev, nxt = self.neighbours()
        return slot_spans(ctrl, prev, nxt, self.is_end())

    def _table(self, ctrl: np.ndarray) -> np.ndarray:
        """(3P, 2) [C; S; J] in one array, the rows the drawing's gathers read: the control
        points ``ctrl``, the point of the curve belonging to each slot (S_j; an end: the
        end) and the joints J_j = joint(C_j, C_next) (past an open end: meaningless);
        :data:`GEOMETRY_BATCH` slots at a time (the spans' ends are twice the result)."""
        plan = self._draw_plan
        p = ctrl.shape[0]
        table = np.empty((3 * p, ctrl.shape[1]))  # (two columns a position set)
        c, s, j = table[:p], table[p:2 * p], table[2 * p:]
        c[...] = ctrl
        parts = batch_slices(p, GEOMETRY_BATCH)
        for part in parts:
            np.add(c[part], ctrl.take(plan.after[part], axis=0), out=j[part])
        j /= 2.0  # joint(): (a + b) / 2.0
        for part in parts:
            start, stop = table.take(plan.ends[:, part], axis=0)
            s[part] = midpoint(start, c[part], stop)
            np.copyto(s[part], c[part], where=plan.is_end[part])
        return table

    def _curve_points(self, ctrl: np.ndarray) -> np.ndarray:
        """(P, 2) S_j: the point of the curve belonging to each slot (an end: the end)."""
        p = ctrl.shape[0]
        return self._table(ctrl)[p:2 * p]

    @cached_property
    def _draw_plan(self) -> DrawPlan:
        """The indices of a drawing, computed once per SplineSet."""
        prev, nxt = self.neighbours()
        end = self.is_end()
        p = end.size
        before, after = np.maximum(prev, 0), np.maximum(nxt, 0)
        ends = np.empty((2, p), INDEX)  # rows written in place (np.stack is a Python function)
        ends[0] = np.where(end.take(before), before, 2 * p + before)
        ends[1] = np.where(end.take(after), after, 2 * p + np.arange(p))
        inner = (~end).nonzero()[0]
        a = (nxt >= 0).nonzero()[0]
        a = a.compress(~(end.take(a) & end.take(nxt.take(a))))  # an edge between two end points is straight
        b = nxt.take(a)
        a_end, b_end = end.take(a), end.take(b)
        near_a, near_b = np.where(b_end, p + a, a), np.where(a_end, p + b, b)  # C, or S where the other is the end
        forward = self.slot_forward.take(a)
        operands = np.empty((5, a.size), INDEX)
        operands[0] = 2 * p + a
        operands[1] = np.where(forward, near_a, near_b)
        operands[2] = np.where(forward, near_b, near_a)
        operands[3] = np.where(a_end, a, p + a)
        operands[4] = np.where(b_end, b, p + b)
        # int32 indices: the plan lives as long as the SplineSet (a frame's peak memory)
        return DrawPlan(after, ends, end[:, None], inner.astype(INDEX),
                         flat_rows(self.curve_nodes.take(inner), 2).astype(INDEX), operands,
                         (a_end | b_end)[:, None], self.slot_edges.take(a))

    def _display(self, s: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """(N, 2) ``positions`` with every curve's inner nodes moved to their curve points ``s``."""
        plan = self._draw_plan
        display = positions.copy()
        display.put(plan.inner_flat, s.take(plan.inner, axis=0))
        return display

    def display_points(self, positions: np.ndarray) -> np.ndarray:
        """(N, 2) the display points of :meth:`geometry` alone."""
        return self._display(self._curve_points(self.controls_for(positions)), positions)

    def geometry(self, positions: np.ndarray) -> Geometry:
        """Display points (N, 2), curved flags (E,) and Bézier controls (E, 3, 2) for given
        node positions — shared by the splines stage and the optimizer's result."""
        return self._geometry(self.controls_for(positions), positions)

    def drawing(self, positions: np.ndarray) -> Drawing:
        """:meth:`geometry` with the controls of the curved edges alone."""
        return self._drawing(self.controls_for(positions), positions)

    def drawings(self, *positions: np.ndarray) -> list[Drawing]:
        """:meth:`drawing` of each of several node positions (N, 2), the sets side by side as
        the columns of one (N, 2K) array while there are at most :data:`TOGETHER_SLOTS` slots:
        every operation of a drawing runs once for all of them (a sprite's drawing is its
        ~40 numpy calls' fixed cost), on the same numbers in the same order."""
        if len(positions) == 1 or self.n_slots > TOGETHER_SLOTS:
            return [self.drawing(one) for one in positions]
        wide = np.concatenate(positions, axis=1)
        ctrl = self._snap_in_place(wide.take(self.curve_nodes, axis=0))
        plan = self._draw_plan
        p = ctrl.shape[0]
        table = self._table(ctrl)  # [C; S; J]
        controls = np.empty((plan.edges.size, 3, wide.shape[1]), dtype=np.float64)
        mid, near_a, near_b, start, stop = table.take(plan.operands, axis=0)
        between_curve_points(mid, near_a, near_b, start, stop, plan.split, controls)
        out = []
        for i, one in enumerate(positions):
            columns = slice(2 * i, 2 * i + 2)
            out.append(Drawing(self._display(table[p:2 * p, columns], one), plan.edges,
                               np.ascontiguousarray(controls[:, :, columns]), ctrl[:, columns].copy()))
        return out

    def _geometry(self, ctrl: np.ndarray, positions: np.ndarray) -> Geometry:
        points, edge, trio, _ = self._drawing(ctrl, positions)
        n_edges = len(self.cells.edges)
        curved = np.zeros(n_edges, dtype=bool)
        curved[edge] = True
        controls = np.zeros(n_edges * 6, dtype=np.float64)  # (E, 3, 2) written flat, six numbers an edge
        controls[flat_rows(edge, 6)] = trio.reshape(-1)
        return Geometry(points, curved, controls.reshape(n_edges, 3, 2))

    def _drawing(self, ctrl: np.ndarray, positions: np.ndarray) -> Drawing:
        plan = self._draw_plan
        p = ctrl.shape[0]
        table = self._table(ctrl)  # [C; S; J]
        display = self._display(table[p:2 * p], positions)
        controls = np.empty((plan.edges.size, 3, 2), dtype=np.float64)
        for part in batch_slices(plan.edges.size, GEOMETRY_BATCH):  # the operands are five times the result
            mid, near_a, near_b, start, stop = table.take(plan.operands[:, part], axis=0)
            between_curve_points(mid, near_a, near_b, start, stop, plan.split[part], controls[part])
        return Drawing(display, plan.edges, controls, ctrl)

    def vector_image(self, positions: np.ndarray | None = None, stage: str = "splines") -> VectorImage:
        positions = self.positions if positions is None else positions
        ctrl = self.controls_for(positions)
        points, curved, controls = self._geometry(ctrl, positions)
        return VectorImage(self.cells, points, curved, controls, stage, self.curve_table(ctrl, curved))

    def curve_table(self, ctrl: np.ndarray, curved: np.ndarray) -> CurveTable:
        """The slot-by-slot B-spline data of the curved edges (:class:`CurveTable`) for
        control points ``ctrl`` (P, 2) and the edges drawn curved."""
        prev, nxt = self.neighbours()
        n_edges = len(self.cells.edges)
        slots = (self.slot_edges >= 0).nonzero()[0]
        edge = self.slot_edges[slots]
        keep = curved[edge]
        edge_slot = np.full(n_edges, -1, dtype=INDEX)
        edge_slot[edge[keep]] = slots[keep]
        edge_forward = np.zeros(n_edges, dtype=bool)
        edge_forward[edge[keep]] = self.slot_forward[slots[keep]]
        return CurveTable(self.curve_nodes, self.slot_curve(), self.curve_closed, prev, nxt, ctrl,
                          edge_slot, edge_forward)


def extract_splines(cells: CellGraph, params: Params = Params()) -> SplineSet:
    """Pair the curve edges at their nodes and chain them into curves (§3.3).

    Contours (visible edges) are paired by the paper's rules. Shading-band edges
    (:func:`band_edges`) are paired among themselves by the same rules at nodes no contour
    touches, and end where they meet a contour (a T-junction, snapped as the paper's)."""
    linked = linked_edges(cells)
    visible = visible_edges(cells, linked)
    shading = shading_edges(cells, visible, params)
    contours = pair_ends(cells, visible.nonzero()[0], shading)
    bands = pair_ends(cells, band_edges(cells, linked).nonzero()[0], np.zeros(len(cells.edges), bool))
    on_contour = np.zeros(len(cells.nodes), dtype=bool)
    on_contour[contours.node] = True
    band_partner = np.where(on_contour[bands.node] | (bands.partner < 0), -1, bands.partner + contours.node.size)
    half_ends = HalfEnds(np.concatenate([contours.edges, bands.edges]), np.concatenate([contours.node, bands.node]),
                         np.concatenate([contours.partner, band_partner]))
    del contours, bands, band_partner  # in half_ends now
    return SplineSet(cells, visible, shading, *chain_curves(half_ends),
                     positions=cells.nodes.astype(np.float64) / 4.0, half_ends=half_ends,
                     snap_passes=params.snap_passes)


def split_at(splines: SplineSet, breaks: np.ndarray) -> SplineSet:
    """The same curves cut at the nodes ``breaks`` (N,) bool: every curve through such a
    node ends there (both pieces are clamped, so the outline keeps a true kink). The
    curves are cut as they are (:func:`depixel.curves.pairing.cut_chains`: the chains
    :func:`depixel.curves.pairing.chain_curves` gives the pairing with the pairs at the breaks
    undone, which ``half_ends`` records); without a break the SplineSet itself."""
    half_ends = splines.half_ends
    cut = breaks[half_ends.node]
    if not np.logical_or.reduce(cut):
        return splines
    partner = half_ends.partner.copy()
    partner[cut] = -1
    chains = cut_chains(Chains(splines.curve_ptr, splines.curve_nodes, splines.curve_closed, splines.slot_edges,
                               splines.slot_forward), half_ends.edges, len(splines.cells.edges), breaks)
    return replace(splines, **chains._asdict(), half_ends=half_ends._replace(partner=partner))


