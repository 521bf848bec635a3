"""Stage 5a — paper §3.4 (Figure 7) — splines → the corners the optimizer keeps sharp.

The smoothness energy cannot tell staircasing from intended corners, so corners are found
as patterns of the quantized outline (docs/corners.md has the drawings):

* :func:`detect_square_corners` — the right-angle corner of a block whose legs run straight
  for two pixel edges on both sides (moved back onto its lattice point);
* :func:`detect_run_corners` — long straight runs meeting at an angle, directly or across a
  short bevel (the corners of the 45°-rotated Windows 3.1 "386" chip, which the paper's own
  patterns miss, §4.1).

Beyond the paper (its §4.1 suggests knot multiplicity for sharp features), every corner
node becomes a break point of its curves (:func:`depixel.curves.splines.split_at`), stays where it
is during the relaxation, and the curve halves next to it are left out of E_s
(:func:`excluded_halves`).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..arrays import batch_slices, set_rows
from ..curves.splines import SplineSet
from ..frozen import compact_repr, freeze
from ..graph.cells import link_corners
from ..params import Params

#: slots whose straight runs are followed together: bounds the memory of the run search
#: (about 0.5 KB a slot) whatever the number of curve slots
RUN_BATCH = 16384


@dataclass(frozen=True, eq=False)
class Corners:
    """Corner nodes of a cell graph, by pattern; arrays are read-only."""

    __repr__ = compact_repr  # arrays as their shape, not their numbers

    square: np.ndarray  # (N,) bool: right-angle corner of a block (sits on its lattice point)
    runs: np.ndarray  # (N,) bool: straight runs meet there at an angle

    def __post_init__(self) -> None:
        freeze(self)

    @property
    def nodes(self) -> np.ndarray:
        """(N,) bool: every corner node."""
        return self.square | self.runs

    def place(self, splines: SplineSet) -> np.ndarray:
        """(N, 2) the nodes' initial positions with every right-angle corner moved onto its
        lattice point (the cut made by the diagonal link is undone)."""
        start = splines.positions.copy()
        square = self.square.nonzero()[0]
        q = splines.cells.nodes.take(square, axis=0)
        set_rows(start, square, 4 * (q / 4.0).round() / 4.0)
        return start


def detect_corners(splines: SplineSet, params: Params = Params()) -> Corners:
    """Both corner patterns, or none when ``params.corner_patterns`` is off."""
    if not params.corner_patterns:
        none = np.zeros(len(splines.positions), dtype=bool)
        return Corners(none, none)
    return Corners(detect_square_corners(splines), detect_run_corners(splines, params))


def detect_square_corners(splines: SplineSet) -> np.ndarray:
    """(N,) bool: interior curve nodes matching the axis-aligned right-angle corner pattern.

    In quarter-pixel units: the node K = P + (sx, sy) sits one quarter off a lattice point P
    diagonally (a corner cut by a diagonal link), its curve neighbours are the lattice points
    P + 4(sx, 0) and P + 4(0, sy), and the curve continues straight beyond both, to
    P + 8(sx, 0) and P + 8(0, sy). The cutting link must be redundant (the pixel opposite
    the corner is linked to both linked pixels), so that restoring the corner cannot cut a
    thin diagonal line.
    """
    cells = splines.cells
    q = cells.nodes
    prev, nxt = splines.neighbours()
    node = splines.curve_nodes
    # only interior slots at a cut node with two more slots on both sides can match: the
    # pattern is tested on those alone (the rest would only cost memory)
    cut_node = link_corners(q)[0]
    slot = (cut_node[node] & (prev >= 0) & (nxt >= 0)).nonzero()[0]
    prev1, next1 = prev[slot], nxt[slot]
    prev2, next2 = prev[prev1], nxt[next1]
    ok = (prev2 >= 0) & (next2 >= 0)
    slot, prev1, next1, prev2, next2 = slot[ok], prev1[ok], next1[ok], prev2[ok], next2[ok]
    k = q.take(node.take(slot), axis=0)
    lattice = 4 * (k / 4.0).round().astype(np.int64)
    off = k - lattice
    sx, sy = off[:, 0], off[:, 1]
    lx, ly = lattice[:, 0], lattice[:, 1]
    # the pattern's points as x and y columns: the legs P + 4(sx, 0), P + 4(0, sy) and the
    # points beyond them P + 8(sx, 0), P + 8(0, sy)
    leg_x, leg_y, far_x, far_y = lx + 4 * sx, ly + 4 * sy, lx + 8 * sx, ly + 8 * sy

    def at(slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        point = q.take(node.take(slots), axis=0)
        return point[:, 0], point[:, 1]

    (ax, ay), (bx, by), (a2x, a2y), (b2x, b2y) = at(prev1), at(next1), at(prev2), at(next2)
    forward = ((ax == leg_x) & (ay == ly) & (bx == lx) & (by == leg_y)
               & (a2x == far_x) & (a2y == ly) & (b2x == lx) & (b2y == far_y))
    backward = ((ax == lx) & (ay == leg_y) & (bx == leg_x) & (by == ly)
                & (a2x == lx) & (a2y == far_y) & (b2x == far_x) & (b2y == ly))
    match = forward | backward
    # The cut must come from a redundant link: the pixel opposite the corner is linked to
    # both linked pixels, so restoring the corner cannot disconnect a thin diagonal line.
    g = cells.graph
    h, w = g.shape
    r_k = lattice[:, 1] // 4 - (sy < 0)  # the pixel whose corner K is
    c_k = lattice[:, 0] // 4 - (sx < 0)
    r_o = lattice[:, 1] // 4 - (sy > 0)  # the opposite pixel of the 2×2 block
    c_o = lattice[:, 0] // 4 - (sx > 0)
    valid = match & (r_k >= 0) & (r_k < h) & (c_k >= 0) & (c_k < w) & (r_o >= 0) & (r_o < h) & (c_o >= 0) & (c_o < w)
    rk, ck, ro, co = (np.where(valid, x, 0) for x in (r_k, c_k, r_o, c_o))
    across = g.right[ro, np.minimum(np.minimum(co, ck), max(w - 2, 0))] if w > 1 else np.zeros_like(valid)
    along = g.down[np.minimum(np.minimum(ro, rk), max(h - 2, 0)), co] if h > 1 else np.zeros_like(valid)
    match = valid & across & along
    corners = np.zeros(len(q), dtype=bool)
    corners[node[slot[match]]] = True
    return corners


def detect_run_corners(splines: SplineSet, params: Params = Params()) -> np.ndarray:
    """(N,) bool: nodes where long straight runs of the quantized outline meet at an angle.

    From every curve node, the run behind and the run ahead are extended node by node as
    long as every node in between stays within ``run_tolerance`` pixels of the chord (up to
    ``run_reach`` px). A staircase of any slope is one run (its quarter-pixel nodes stay
    within the tolerance of a single chord); a smooth curve bends before its chords get
    long. Two patterns:

    * a sharp corner: runs of at least ``run_long`` on both sides turning by ``run_turn``
      (80°) or more;
    * a bevelled corner: a long run, a short one (``run_short`` ≤ length < ``run_long``) and a
      long one, bending at both ends of the short run by ``run_bend`` or more and by
      ``run_turn`` or more in all — the apex pixels of a 45°-rotated rectangle, like the
      corners of the Windows 3.1 "386" chip. Both ends of the short run are corners.

    A pixel circle is an octagon of runs turning by 45° at a time, over runs longer than a
    bevel: no node of it matches.
    """
    tolerance = params.run_tolerance
    nodes = splines.cells.nodes
    # the node coordinates (px) as x and y columns: numpy runs an (N, 2) array's rows two
    # elements at a time, and copies them one by one under fancy indexing
    qx, qy = nodes[:, 0] / 4.0, nodes[:, 1] / 4.0
    prev, nxt = splines.neighbours()
    node = splines.curve_nodes
    interior = ((prev >= 0) & (nxt >= 0)).nonzero()[0]
    # nodes are at least a quarter pixel apart diagonally (0.35 px): this many steps reach
    steps = int(np.ceil(params.run_reach / 0.35))

    def run(step: np.ndarray, at: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vector (x, y) from the node ``at`` each of ``starts`` to the far end of its
        straight run along ``step``, and the index of that far end (-1 for none). Only the
        runs still growing are carried from one step to the next, :data:`RUN_BATCH` at a
        time."""
        far_slot = np.full(at.size, -1, dtype=np.int64)
        for part in batch_slices(starts.size, RUN_BATCH):
            # per run still growing: its row and the slot it reached (ids), and in one float
            # table of rows (filtered by one gather a step) its start x, y, then the x and the
            # y of the vector from the start to the far node of every earlier step; the table
            # holds the rows filled so far and the two of the step (a frame's runs are
            # megabytes: a full-width table would be copied, and its fresh pages touched, for
            # steps not reached)
            ids = np.stack([starts[part], step.take(starts[part])], axis=1)
            ids = ids.compress(ids[:, 1] >= 0, axis=0)
            first = at.take(ids[:, 0])
            geo = np.empty((4, ids.shape[0]))
            geo[0], geo[1] = qx.take(first), qy.take(first)
            for i in range(steps):
                if ids.shape[0] == 0:
                    break
                rows, walk = ids[:, 0], ids[:, 1]
                far = at.take(walk)
                candidate_x = np.subtract(qx.take(far), geo[0], out=geo[2 + 2 * i])
                candidate_y = np.subtract(qy.take(far), geo[1], out=geo[3 + 2 * i])
                length = np.sqrt(candidate_x * candidate_x + candidate_y * candidate_y)
                # every node passed must stay near the new chord
                cross = np.abs(candidate_x * geo[3:2 + 2 * i:2] - candidate_y * geo[2:2 + 2 * i:2])
                ok = np.logical_and.reduce(cross <= tolerance * np.maximum(length, 1e-9), axis=0)
                far_slot[rows.compress(ok)] = walk.compress(ok)  # the run reaches this far (so far)
                ids[:, 1] = step.take(walk)  # the next step, if the run goes on
                go = (ok & (length < params.run_reach) & (ids[:, 1] >= 0)).nonzero()[0]
                ids = ids.take(go, axis=0)
                kept = np.empty((6 + 2 * i, go.size))
                geo.take(go, axis=1, out=kept[:4 + 2 * i], mode="clip")  # (in range; "raise" would copy first)
                geo = kept
        # the chord to the far end, the same subtraction as the accepted candidate's
        reached = far_slot >= 0
        far = at.take(np.maximum(far_slot, 0))
        chord_x = np.where(reached, qx.take(far) - qx.take(at), 0.0)
        chord_y = np.where(reached, qy.take(far) - qy.take(at), 0.0)
        return chord_x, chord_y, far_slot

    def turn(ux: np.ndarray, uy: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
        """Angle between directions u and v (0 = straight on)."""
        norms = np.sqrt(ux * ux + uy * uy) * np.sqrt(vx * vx + vy * vy)
        cos = (ux * vx + uy * vy) / np.maximum(norms, 1e-12)
        np.maximum(cos, -1.0, out=cos)  # clipped into [-1, 1] in place, the angle too (no fresh arrays)
        return np.arccos(np.minimum(cos, 1.0, out=cos), out=cos)

    # both directions in one walk: index j + P is slot j walking ahead
    p = node.size
    chord_x, chord_y, far_slot = run(np.concatenate([prev, np.where(nxt >= 0, nxt + p, -1)]),
                                     np.concatenate([node, node]), np.concatenate([interior, interior + p]))
    behind_end = far_slot[:p]
    ahead_end = np.where(far_slot[p:] >= 0, far_slot[p:] - p, -1)
    corners = np.zeros(len(nodes), dtype=bool)
    # each pattern read along the curve and against it: a bevel met from its other end is the
    # same bevel, so the corners do not depend on which way the curve runs
    for back, ahead, ahead_end_all in (((chord_x[:p], chord_y[:p]), (chord_x[p:], chord_y[p:]), ahead_end),
                                       ((chord_x[p:], chord_y[p:]), (chord_x[:p], chord_y[:p]), behind_end)):
        sharp, bevel, far = _patterns(interior, back, ahead, ahead_end_all, params, turn)
        corners[node[sharp]] = True
        corners[node[bevel]] = True
        corners[node[far]] = True  # the bevel's far end
    return corners


def _patterns(interior: np.ndarray, back: tuple[np.ndarray, np.ndarray], ahead_all: tuple[np.ndarray, np.ndarray],
              ahead_end_all: np.ndarray, params: Params,
              turn: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slots of :func:`detect_run_corners`' two patterns read one way along the curves: the
    sharp corners, the bevels' near ends and their far ends; ``back`` and ``ahead_all`` the
    (x, y) chords (P,) to the far ends of the straight runs behind and ahead of every slot,
    ``ahead_end_all`` the far end of each run ahead (-1: none)."""
    long, short = params.run_long, params.run_short
    min_turn, min_bend = np.radians(params.run_turn), np.radians(params.run_bend)
    ahead_all_x, ahead_all_y = ahead_all
    # both patterns need a long run behind: the rest is tested on those slots alone
    back_x, back_y = back
    lb = np.sqrt(back_x * back_x + back_y * back_y)
    slot = interior.compress(lb.take(interior) >= long)
    in_x, in_y = -back_x.take(slot), -back_y.take(slot)  # direction of travel arriving at the node
    ahead_x, ahead_y, ahead_end = ahead_all_x.take(slot), ahead_all_y.take(slot), ahead_end_all.take(slot)
    la = np.sqrt(ahead_x * ahead_x + ahead_y * ahead_y)
    bend_in = turn(in_x, in_y, ahead_x, ahead_y)
    sharp = (la >= long) & (bend_in >= min_turn)

    k = np.maximum(ahead_end, 0)
    after_x, after_y = ahead_all_x.take(k), ahead_all_y.take(k)
    bevel = ((ahead_end >= 0) & (la >= short) & (la < long)
             & (np.sqrt(after_x * after_x + after_y * after_y) >= long)
             & (bend_in >= min_bend) & (turn(ahead_x, ahead_y, after_x, after_y) >= min_bend)
             & (turn(in_x, in_y, after_x, after_y) >= min_turn))
    return slot.compress(sharp), slot.compress(bevel), k.compress(bevel)


def excluded_halves(splines: SplineSet, corners: np.ndarray) -> np.ndarray:
    """(P, 2) bool: the halves of each slot's span left out of E_s — both halves at a
    corner node, and the half next to a neighbouring corner node."""
    prev, nxt = splines.neighbours()
    at_corner = corners[splines.curve_nodes]
    excluded = np.zeros((splines.curve_nodes.size, 2), dtype=bool)
    excluded[:, 0] = (prev >= 0) & at_corner[np.maximum(prev, 0)]
    excluded[:, 1] = (nxt >= 0) & at_corner[np.maximum(nxt, 0)]
    excluded |= at_corner[:, None]
    return excluded
