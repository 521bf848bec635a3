"""Stage 5a — paper §3.4 (Figure 7) — splines → the corners the optimizer keeps sharp.

The smoothness energy cannot tell staircasing from intended corners, so corners are found
as patterns of the quantized outline (docs/corners.md has the drawings):

* :func:`detect_square_corners` — the right-angle corner of a block whose legs run straight
  for two pixel edges on both sides (moved back onto its lattice point);
* :func:`detect_run_corners` — long straight runs meeting at an angle, directly or across a
  short bevel (the corners of the 45°-rotated Windows 3.1 "386" chip, which the paper's own
  patterns miss, §4.1).

Beyond the paper (its §4.1 suggests knot multiplicity for sharp features), every corner
node becomes a break point of its curves (:func:`depixel.splines.split_at`), stays where it
is during the relaxation, and the curve halves next to it are left out of E_s
(:func:`excluded_halves`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arrays import batch_slices
from .cells import link_corners
from .frozen import freeze
from .params import Params
from .splines import SplineSet

#: slots whose straight runs are followed together: bounds the memory of the run search
#: (about 0.5 KB a slot) whatever the number of curve slots
RUN_BATCH = 16384


@dataclass(frozen=True, eq=False)
class Corners:
    """Corner nodes of a cell graph, by pattern; arrays are read-only."""

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
        q = splines.cells.nodes[self.square]
        start[self.square] = 4 * np.round(q / 4.0) / 4.0
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
    slot = np.flatnonzero(cut_node[node] & (prev >= 0) & (nxt >= 0))
    prev1, next1 = prev[slot], nxt[slot]
    prev2, next2 = prev[prev1], nxt[next1]
    ok = (prev2 >= 0) & (next2 >= 0)
    slot, prev1, next1, prev2, next2 = slot[ok], prev1[ok], next1[ok], prev2[ok], next2[ok]
    k = q[node[slot]]
    lattice = 4 * np.round(k / 4.0).astype(np.int64)
    off = k - lattice
    sx, sy = off[:, 0], off[:, 1]
    leg_x = lattice + 4 * np.stack([sx, np.zeros_like(sx)], axis=1)
    leg_y = lattice + 4 * np.stack([np.zeros_like(sy), sy], axis=1)
    far_x = lattice + 8 * np.stack([sx, np.zeros_like(sx)], axis=1)
    far_y = lattice + 8 * np.stack([np.zeros_like(sy), sy], axis=1)

    def same(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return (u == v).all(axis=1)

    a, b = q[node[prev1]], q[node[next1]]
    a2, b2 = q[node[prev2]], q[node[next2]]
    forward = same(a, leg_x) & same(b, leg_y) & same(a2, far_x) & same(b2, far_y)
    backward = same(a, leg_y) & same(b, leg_x) & same(a2, far_y) & same(b2, far_x)
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
    across = g.right[ro, np.minimum(co, ck).clip(0, max(w - 2, 0))] if w > 1 else np.zeros_like(valid)
    along = g.down[np.minimum(ro, rk).clip(0, max(h - 2, 0)), co] if h > 1 else np.zeros_like(valid)
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
    tolerance, short, long = params.run_tolerance, params.run_short, params.run_long
    min_turn, min_bend = np.radians(params.run_turn), np.radians(params.run_bend)
    q = splines.cells.nodes.astype(np.float64) / 4.0
    prev, nxt = splines.neighbours()
    node = splines.curve_nodes
    interior = np.flatnonzero((prev >= 0) & (nxt >= 0))
    # nodes are at least a quarter pixel apart diagonally (0.35 px): this many steps reach
    steps = int(np.ceil(params.run_reach / 0.35))

    def run(step: np.ndarray, at: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vector from the node ``at`` each of ``starts`` to the far end of its straight run
        along ``step``, and the index of that far end (-1 for none). Only the runs still
        growing are carried from one step to the next, :data:`RUN_BATCH` at a time."""
        chord = np.zeros((at.size, 2))
        far_slot = np.full(at.size, -1, dtype=np.int64)
        for part in batch_slices(starts.size, RUN_BATCH):
            rows = walk = starts[part]  # the runs still growing
            start = q.take(at[rows], axis=0)
            passed = np.empty((rows.size, steps, 2))  # the far node of every earlier step
            for i in range(steps):
                walk = step[walk]
                go = walk >= 0
                rows, walk, start, passed = rows[go], walk[go], start[go], passed[go]
                far = q.take(at[walk], axis=0)
                candidate = far - start
                length = np.sqrt(candidate[:, 0] * candidate[:, 0] + candidate[:, 1] * candidate[:, 1])
                # every node passed must stay near the new chord
                rel = passed[:, :i] - start[:, None]
                cross = np.abs(candidate[:, None, 0] * rel[..., 1] - candidate[:, None, 1] * rel[..., 0])
                ok = (cross <= (tolerance * np.maximum(length, 1e-9))[:, None]).all(axis=1)
                chord[rows[ok]] = candidate[ok]
                far_slot[rows[ok]] = walk[ok]
                go = ok & (length < params.run_reach)
                passed[:, i] = far
                rows, walk, start, passed = rows[go], walk[go], start[go], passed[go]
                if rows.size == 0:
                    break
        return chord, far_slot

    def turn(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Angle between directions u and v (0 = straight on)."""
        cos = (u * v).sum(axis=1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-12)
        return np.arccos(np.clip(cos, -1.0, 1.0))

    # both directions in one walk: index j + P is slot j walking ahead
    p = node.size
    chord, far_slot = run(np.concatenate([prev, np.where(nxt >= 0, nxt + p, -1)]), np.concatenate([node, node]),
                          np.concatenate([interior, interior + p]))
    back, ahead_all = chord[:p], chord[p:]
    ahead_end_all = np.where(far_slot[p:] >= 0, far_slot[p:] - p, -1)
    # both patterns need a long run behind: the rest is tested on those slots alone
    lb = np.linalg.norm(back, axis=1)
    slot = interior[lb[interior] >= long]
    lb, back = lb[slot], back[slot]
    ahead, ahead_end = ahead_all[slot], ahead_end_all[slot]
    la = np.linalg.norm(ahead, axis=1)
    incoming = -back  # direction of travel arriving at the node
    sharp = (la >= long) & (turn(incoming, ahead) >= min_turn)

    k = np.maximum(ahead_end, 0)
    after = ahead_all[k]
    bevel = ((ahead_end >= 0) & (la >= short) & (la < long)
             & (np.linalg.norm(after, axis=1) >= long)
             & (turn(incoming, ahead) >= min_bend) & (turn(ahead, after) >= min_bend)
             & (turn(incoming, after) >= min_turn))
    corners = np.zeros(len(q), dtype=bool)
    corners[node[slot[sharp]]] = True
    corners[node[slot[bevel]]] = True
    corners[node[k[bevel]]] = True  # the bevel's far end
    return corners


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
