"""Not in the paper — fidelity guards of §3.4: every pixel centre stays inside its cell.

The paper's energy lets a curve drift over the centre of the pixel it outlines; then that
pixel's colour no longer shows where the pixel was, and the seam-free underlay of the SVG
(docs/design.md, "Seams") needs the centre well inside its cell. Two guards:

* during the relaxation, a move is refused if it brings one of the node's spans closer
  than ``centre_clearance`` to a **protected point** beside it (:func:`protected_points`:
  the centres of the pixels on both sides, and the lattice corner of a diagonal link, where
  a thin diagonal feature must stay connected) — unless it was closer already — or if it is
  long enough to carry a span across one (:mod:`depixel.optimize.relax`);
* afterwards, :func:`keep_centres_inside` walks back, one relaxation round at a time, the
  nodes around any cell whose centre came nearer than half the clearance to its drawn
  boundary (slots moving together, T-junction ends following their curves: what the
  per-move check of one node cannot see).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from ..arrays import either, ranges, set_rows
from ..curves.bspline import flatten_edges_planes
from ..curves.drawing import Drawing
from ..curves.splines import SplineSet
from ..graph.cells import CellGraph, link_corners
from ..vector import VectorImage
from .joined import largest_image, pixel_centres, pixel_count
from .walkback import History, Moves, walk_back

#: stands for "no protected point" (far from every curve)
FAR = 1e6

#: image pixels up to which the revert's first round measures the initial drawing at every
#: pixel it checks in the same pass as the current drawing (:func:`_clearances`): one call's
#: fixed cost (~0.3 ms, most of a sprite's) against the work on pixels whose initial
#: clearance is never read (a frame's ~10^4: +15 % on its stage outside the relaxation) and
#: the drawings' points and controls copied side by side (on a 512² image, +1 % peak memory)
TOGETHER_PIXELS = 4096


def protected_points(splines: SplineSet, slots: np.ndarray | slice = slice(None)) -> np.ndarray:
    """(..., 3, 2) the points the spans at each slot of ``slots`` (an index array of any
    shape; all slots by default) must keep clear of: the centres of the pixels on both
    sides of the edge leaving the slot, and the lattice corner of a diagonal link at its
    node; :data:`FAR` where there is none."""
    cells = splines.cells
    w = cells.shape[1]
    edge = splines.slot_edges[slots]
    pix = np.where((edge >= 0)[..., None], cells.edge_pixels.take(np.maximum(edge, 0), axis=0), -1)
    rows, cols = np.divmod(np.maximum(pix, 0), w)
    out = np.empty(edge.shape + (3, 2))
    out[..., :2, 0] = np.where(pix >= 0, cols + 0.5, FAR)  # the centres beside the edge
    out[..., :2, 1] = np.where(pix >= 0, rows + 0.5, FAR)
    split, lattice = link_corners(cells.nodes.take(splines.curve_nodes[slots], axis=0))
    out[..., 2, :] = np.where(split[..., None], lattice / 4.0, FAR)
    return out


def unique_rows(points: np.ndarray) -> np.ndarray:
    """(M, Q, 2) → (M, Q', 2): each row's distinct points first, padded with :data:`FAR`.

    The points are ordered by a key of both coordinates, sorted as indices; each kept point
    goes to its rank among its row's kept ones (a running count: no second sort), its x and
    y written by two flat ``put`` (no ``take_along_axis``, no (N, 2) rows gathered).

    The key x * 4096 + y is exact and tells apart the points it is used for: those of
    :func:`protected_points`, pixel centres and quarter-pixel lattice corners, so two of a row
    with different x are at least 1/4 px apart in x and would need 1024 px between their y to
    share a key, while a row's points lie a few pixels from one slot."""
    m, q = points.shape[:2]
    key = points[..., 0] * 4096.0 + points[..., 1]
    order = key.argsort(axis=1, kind="stable")  # (~2x faster than the default on rows this short)
    order += (np.arange(m) * q)[:, None]  # flat indices, by key
    key = key.ravel().take(order)  # sorted (each temporary dropped once used: this runs on every movable slot)
    kept = points[..., 0].ravel().take(order) < FAR
    kept[:, 1:] &= key[:, 1:] != key[:, :-1]
    del key
    rank = kept.cumsum(axis=1)  # a kept point's rank in its row, from 1
    width = max(int(rank[:, -1].max(initial=0)) if q else 0, 1)
    rank += (np.arange(-1, m * width - 1, width))[:, None]  # its flat row in the result
    kept = kept.ravel()
    source = order.ravel().compress(kept)
    del order
    target = rank.ravel().compress(kept)
    del rank, kept
    target *= 2
    out = np.full((m, width, 2), FAR)
    flat = out.reshape(-1)
    flat.put(target, points[..., 0].ravel().take(source))
    target += 1
    flat.put(target, points[..., 1].ravel().take(source))
    return out


def centre_clearance(image: VectorImage, pixels: np.ndarray | None = None, samples: int = 3) -> np.ndarray:
    """(H*W,) signed distance of each pixel centre to its own drawn cell's boundary.

    Positive inside, negative outside (curves flattened into ``2 * samples`` pieces per
    edge); +inf for pixels outside the optional ``pixels`` mask. Inside-ness is even-odd
    ray casting from every centre towards +x against the flattened boundary of its own cell,
    all cells at once: each edge contributes its polyline to the cells on both sides.
    """
    curved = np.flatnonzero(image.curved)
    return _clearance(image.cells, Drawing(image.points, curved, image.controls[curved]), pixels, samples)


def _clearance(cells: CellGraph, drawing: Drawing, pixels: np.ndarray | None, samples: int = 3,
               below: float = np.inf) -> np.ndarray:
    """:func:`centre_clearance` of a :class:`depixel.curves.drawing.Drawing` of ``cells``, exact
    where it is below ``below``; a centre inside its cell by at least ``below`` gets some
    value ≥ ``below`` (:func:`_clearances` of the one drawing)."""
    return _clearances(cells, (drawing,), pixels, samples, below)[0]


def _clearances(cells: CellGraph, drawings: tuple[Drawing, ...], pixels: np.ndarray | None, samples: int = 3,
                below: float = np.inf) -> np.ndarray:
    """(K, H*W) :func:`_clearance` of each of K drawings of the same curves (the same
    curved edges, as every drawing of one SplineSet has), measured together: the pairs of
    wanted pixels and edges are read once, and each step below is one call over the pairs
    of all drawings (a drawing's pixels are numbered after the ones before).

    Each edge is paired with the wanted pixels on its two sides. An edge whose bounding box
    (its end points and Bézier controls) lies more than ``below`` from the centre is not
    flattened: it cannot bring the centre nearer, and it crosses the centre's ray an odd
    number of times only if the box lies right of the centre and its ends on both sides of
    the centre's row. The other pairs are measured segment by segment in one pass (the
    per-pixel minimum of the squared distances, then one square root: the same numbers as a
    minimum of square roots). The far edges of the centres found outside are measured
    after all."""
    k = len(drawings)
    first_drawing = drawings[0]
    n_edges = len(cells.edges)
    curved_edge = np.zeros(n_edges, bool)
    curved_edge[first_drawing.edges] = True
    control_row = np.zeros(n_edges, np.int64)  # where each curved edge's controls are
    control_row[first_drawing.edges] = np.arange(first_drawing.edges.size)
    n_px = pixel_count(cells)
    wanted = np.ones(n_px, bool) if pixels is None else pixels
    # the pairs: each wanted pixel with each edge of its cell, read off the cell polygons
    # (the work follows the wanted pixels, often a few, not the edges of the image)
    px = wanted.ravel().nonzero()[0]
    first = cells.cell_ptr.take(px)
    size = cells.cell_ptr.take(px + 1) - first
    edge = cells.cell_edges.take(ranges(first, size))
    pix = px.repeat(size)
    cx, cy = pixel_centres(cells, px)  # per pixel, then spread over its pairs
    cx, cy = cx.repeat(size), cy.repeat(size)
    # everything below as x and y columns, a pair at a time: numpy runs the rows of an
    # (N, 2) array two elements at a time
    start, stop = cells.edges.take(edge, axis=0).T.copy()
    bent = curved_edge.take(edge)
    if k == 1:
        points, controls = first_drawing.points, first_drawing.controls

        def control(pairs: np.ndarray) -> np.ndarray:
            """The rows of ``controls`` of the curved pairs ``pairs`` (no pair table: a frame's peak)."""
            return control_row.take(edge.take(pairs))
    else:  # the drawings' points and controls one after another, the pairs repeated for each
        n_nodes, n_curved = len(first_drawing.points), first_drawing.edges.size
        points = np.concatenate([d.points for d in drawings])
        controls = np.concatenate([d.controls for d in drawings])
        pix = np.concatenate([pix + i * n_px for i in range(k)])
        start = np.concatenate([start + i * n_nodes for i in range(k)])
        stop = np.concatenate([stop + i * n_nodes for i in range(k)])
        cx, cy, bent = np.concatenate([cx] * k), np.concatenate([cy] * k), np.concatenate([bent] * k)
        rows = control_row.take(edge)  # (meaningful where bent)
        control_rows = np.concatenate([rows + i * n_curved for i in range(k)])

        def control(pairs: np.ndarray) -> np.ndarray:
            """The rows of ``controls`` of the curved pairs ``pairs``."""
            return control_rows.take(pairs)
    ax, ay = points.take(start, axis=0).T.copy()
    bx, by = points.take(stop, axis=0).T.copy()
    n_all = k * n_px

    def measure(pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ray crossings and squared nearest distance (K*H*W,) of the pairs ``pairs``,
        segment by segment: a straight edge is one, a curve 2 * samples (the order of the
        segments does not matter: a count and a minimum per pixel). A curved edge beside
        two wanted pixels is flattened for each: the same numbers twice."""
        is_bent = bent.take(pairs)
        curved, straight = pairs.compress(is_bent), pairs.compress(~is_bent)
        poly_x, poly_y = flatten_edges_planes(points.take(start.take(curved), axis=0),  # (2 * samples + 1, C)
                                              controls.take(control(curved), axis=0),
                                              points.take(stop.take(curved), axis=0), samples)
        q0_x = np.concatenate([ax.take(straight), poly_x[:-1].ravel()])
        q0_y = np.concatenate([ay.take(straight), poly_y[:-1].ravel()])
        q1_x = np.concatenate([bx.take(straight), poly_x[1:].ravel()])
        q1_y = np.concatenate([by.take(straight), poly_y[1:].ravel()])
        segment_pair = np.concatenate([straight] + [curved] * (2 * samples))  # the segments piece by piece
        p, x, y = pix.take(segment_pair), cx.take(segment_pair), cy.take(segment_pair)
        seg_x, seg_y = q1_x - q0_x, q1_y - q0_y
        rel_x, rel_y = x - q0_x, y - q0_y
        straddle = (q0_y > y) != (q1_y > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = q0_x + rel_y * seg_x / seg_y
        crossings = np.bincount(p.compress(straddle & (x_at > x)), minlength=n_all)
        length2 = np.maximum(seg_x**2 + seg_y**2, 1e-12)
        along = np.divide(rel_x * seg_x + rel_y * seg_y, length2, out=length2)  # then clipped into [0, 1]
        np.minimum(np.maximum(along, 0.0, out=along), 1.0, out=along)
        dx, dy = rel_x - along * seg_x, rel_y - along * seg_y
        nearest2 = np.full(n_all, np.inf)
        np.minimum.at(nearest2, p, dx * dx + dy * dy)
        return crossings, nearest2

    if np.isfinite(below):
        # each pair's edge box (a curve's with its Bézier controls), then the pair's centre
        # against it; the boxes are dropped before the near pairs are measured
        curved = bent.nonzero()[0]
        if curved.size:  # x and y of c0, of c1, of c2
            c = controls.take(control(curved), axis=0).reshape(-1, 6).T
        # one side of the boxes at a time in one buffer (the side, then its distance beyond
        # the centre): a pair table a frame's size costs more in fresh pages than in arithmetic
        side = np.empty(ax.size)
        beyond = np.empty(ax.size, bool)
        far = np.zeros(ax.size, bool)
        for axis, (a, b, centre) in enumerate(((ax, bx, cx), (ay, by, cy))):
            for extreme in (np.minimum, np.maximum):
                extreme(a, b, out=side)
                if curved.size:
                    side[curved] = extreme(extreme(extreme(side.take(curved), c[axis]), c[2 + axis]), c[4 + axis])
                if extreme is np.minimum:
                    np.subtract(side, centre, out=side)
                else:
                    np.subtract(centre, side, out=side)
                np.greater(side, below, out=beyond)
                far |= beyond
                if axis == 0 and extreme is np.minimum:
                    right = beyond.copy()  # the box lies right of the centre
        del side, beyond, curved
        count = np.bincount(pix.compress(right & ((ay > cy) != (by > cy))), minlength=n_all)
        del right
        near_count, nearest2 = measure((~far).nonzero()[0])
        count += near_count
        # a centre outside its cell is measured against every edge (its crossings are counted)
        again = (far & (count % 2 == 0).take(pix)).nonzero()[0]
        if again.size:
            nearest2 = np.minimum(nearest2, measure(again)[1])
    else:
        count, nearest2 = measure(np.arange(ax.size))
    nearest = np.sqrt(nearest2, out=nearest2).reshape(k, n_px)  # in place: nearest2 is this call's own
    np.negative(nearest, out=nearest, where=(count % 2 == 0).reshape(k, n_px))  # outside
    np.copyto(nearest, np.inf, where=~wanted)
    return nearest


def keep_centres_inside(splines: SplineSet, start: np.ndarray, positions: np.ndarray, margin: float,
                        rounds: int = 8, drawing: Drawing | None = None,
                        initial: Drawing | None = None, moves: Sequence[Moves] | History = ()
                        ) -> tuple[np.ndarray, Drawing]:
    """Walk back the moves around any cell whose pixel centre came closer than ``margin`` to
    its boundary (or left it), until none does. Moves made elsewhere on a curve (a T-junction
    end follows the curve it ends on, neighbours move together) can reach a cell the
    relaxation did not check. Only cells next to an edge whose geometry changed are measured.

    ``moves``: the relaxation's rounds (:class:`Moves`, or their :class:`History`: several images'
    joined, :mod:`depixel.optimize.pack`, each node's rounds its image's); the curve nodes
    around a bad cell go back one round at a time (each round of the relaxation kept the
    curves clear, so a cell is usually fine again a round or two back, and the rest of the
    relaxation's work stays), the other nodes (moved by the harmonic map) to ``start``; in
    the last of ``rounds``, or past the first round, every node goes to ``start``.

    Returns the positions and their drawing (the last one measured, or a new one when
    the rounds ran out); ``drawing``: that of ``positions``, ``initial`` that of ``start``,
    when the caller has them."""
    cells = splines.cells
    positions = positions.copy()
    initial = splines.drawing(start) if initial is None else initial
    prev, nxt = splines.neighbours()
    n_px = pixel_count(cells)
    floor = np.full(n_px, np.nan)  # min(margin, initial clearance), filled in where needed
    reference = initial  # geometry already verified (or initial), to find what changed since
    current = splines.drawing(positions) if drawing is None else drawing
    back = np.zeros(len(positions), np.int64)  # rounds each node has gone back
    on_curve = np.zeros(len(positions), bool)
    on_curve[splines.curve_nodes] = True
    # the moves as tables, made when the first node goes back
    history: History | None = moves if isinstance(moves, History) else None
    for round_ in range(rounds):
        if round_:
            current = splines.drawing(positions)  # the same curved edges as the reference, in the same order
        changed = either(_differs(current.points, reference.points).take(cells.edges))  # an end moved
        changed[current.edges] |= _differs(current.controls, reference.controls)
        # the pixels beside the changed edges (a side without a pixel, -1, marks the extra last entry)
        beside = np.zeros(n_px + 1, bool)
        beside[cells.edge_pixels.compress(changed, axis=0).ravel()] = True
        pixels = beside[:-1]
        if not np.logical_or.reduce(pixels):
            return positions, current
        if round_ == 0 and largest_image(cells) <= TOGETHER_PIXELS:
            # the initial drawing is measured with the first at the same pixels (one pass
            # over their pairs: most sprites have a centre below the margin, whose initial
            # clearance is then needed; a pixel's clearance does not depend on the others')
            clearance, before = _clearances(cells, (current, initial), pixels, below=margin)
            floor = np.where(pixels, np.minimum(before, margin), np.nan)
            del before
        else:
            clearance = _clearance(cells, current, pixels, below=margin)
        # a clearance of at least the margin passes whatever the initial clearance: only
        # the centres below it are compared with their initial clearance, measured in a
        # later round if the first did not
        low = pixels & (clearance < margin - 1e-9)
        missing = low & np.isnan(floor)
        if np.logical_or.reduce(missing):
            floor[missing] = np.minimum(_clearance(cells, initial, missing, below=margin)[missing], margin)
        ok = ~low | (clearance >= floor - 1e-9)
        reference = current
        if np.logical_and.reduce(ok):
            return positions, current
        bad = either(np.append(~ok, False).take(cells.edge_pixels))  # a bad cell on either side
        revert = np.zeros(len(positions), bool)  # the nodes of the edges around a bad cell
        revert[cells.edges.compress(bad, axis=0).ravel()] = True
        # widen to the whole neighbourhood on the curves through those nodes
        on = revert.take(splines.curve_nodes)
        for step in (prev, nxt):
            near = step[on & (step >= 0)]
            on[near] = True
        revert[splines.curve_nodes.compress(on)] = True
        nodes = revert.nonzero()[0]
        if history is None:
            history = History(cast("Sequence[Moves]", moves))
        if round_ == rounds - 1:
            back[nodes] = history.rounds_of(nodes)
        walk_back(positions, start, nodes.compress(on_curve.take(nodes)), back, history)
        other = nodes.compress(~on_curve.take(nodes))
        set_rows(positions, other, start.take(other, axis=0))
    return positions, splines.drawing(positions)


def _differs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n,) bool: some coordinate of row i of ``a`` and ``b`` (n, ..., 2) differs by more than
    1e-12. The differences in one array, in place; each (x, y) pair's tests read as one
    2-byte word (a reduction over a short last axis costs several calls and passes)."""
    difference = np.subtract(a, b)
    far = np.abs(difference, out=difference) > 1e-12
    pairs = either(far.reshape(len(a), far[0:1].size // 2 if len(a) else 1, 2))  # (n, coordinates / 2)
    out = pairs[:, 0].copy()
    for column in pairs.T[1:]:
        out |= column
    return out
