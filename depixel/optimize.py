"""Stage 5 — paper §3.4 — splines → optimized splines (the default output).

Energy of a curve node i (equation 1-4 of the paper)::

    E(i) = E_s(i) + E_p(i),   E_s = ∫ |κ(s)| ds over the segments i influences,
                              E_p = ‖p_i − p̂_i‖⁴

The smoothness integral of a quadratic segment is taken by sampling its tangent at fixed
parameter steps (t = 0, ½, 1) and summing the absolute turning between samples; the
tangent of a quadratic Bézier turns monotonically, so this equals the integral exactly.

Corner patterns (paper Figure 7, docs/corners.md): a right-angle corner of a block whose
legs run straight for at least two pixel edges on both sides (moved onto its lattice
corner), and long straight runs of the quantized outline meeting at 80° or more or across a
short bevel. Corner nodes are fixed and made break points of their curves (beyond the
paper: its §4.1 suggests knot multiplicity for sharp features), and the curve parts next to
them are left out of the smoothness integral.

Fidelity constraints (not in the paper): a move is refused if it brings one of the node's
segments closer than ``centre_clearance`` to a pixel centre beside it or to the lattice
corner of a diagonal link, or takes the node farther than ``max_offset`` from its start;
afterwards, cells whose centre came too near their boundary get their nodes reverted.

Relaxation: ``iterations`` sweeps; in each sweep the nodes are visited class by class in a
random order of classes (nodes of one class are three or more slots apart along their
curve, so their energies are independent and they move together, vectorized); each node
tries ``candidates`` random offsets within ``radius`` of its current place and keeps the best
(or stays). All randomness comes from ``numpy.random.default_rng(seed)``.

Harmonic map: the nodes off the curves (and off the image border) then move by the
harmonic interpolation of the curve nodes' displacements (uniform weights, conjugate
gradients on the nodes near a displacement), so cells next to moved curves follow them
instead of folding.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bspline import flatten, flatten_edges, half_turns, span
from .params import Params
from .splines import SplineSet, extract_splines
from .vector import VectorImage


@dataclass(frozen=True, eq=False)
class OptimizedSplines:
    """The curves (split at corners) and their optimized node positions (pixel units)."""

    splines: SplineSet  # curves after splitting at the detected corners
    corners: np.ndarray  # (N,) bool: node matched a corner pattern
    initial: np.ndarray  # (N, 2) positions before relaxation (corners already snapped)
    positions: np.ndarray  # (N, 2) final positions: relaxed curve nodes, harmonic others
    energy_before: float  # total node energy before relaxation
    energy_after: float  # and after

    def vector_image(self) -> VectorImage:
        return self.splines.vector_image(self.positions, stage="optimized")


def detect_corners(splines: SplineSet) -> np.ndarray:
    """(N,) bool: interior curve nodes matching the axis-aligned right-angle corner pattern.

    In quarter-pixel units: the node K = P + (sx, sy) sits one quarter off a lattice point P
    diagonally (a corner cut by a diagonal link), its curve neighbours are the lattice points
    P + 4(sx, 0) and P + 4(0, sy), and the curve continues straight beyond both, to
    P + 8(sx, 0) and P + 8(0, sy).
    """
    cells = splines.cells
    q = cells.nodes
    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    prev2 = np.where(prev >= 0, prev[np.maximum(prev, 0)], -1)
    next2 = np.where(nxt >= 0, nxt[np.maximum(nxt, 0)], -1)
    ok = ~end & (prev2 >= 0) & (next2 >= 0)
    node = splines.curve_nodes
    k = q[node]
    lattice = 4 * np.round(k / 4.0).astype(np.int64)
    off = k - lattice
    cut = (np.abs(off) == 1).all(axis=1)
    sx, sy = off[:, 0], off[:, 1]
    leg_x = lattice + 4 * np.stack([sx, np.zeros_like(sx)], axis=1)
    leg_y = lattice + 4 * np.stack([np.zeros_like(sy), sy], axis=1)
    far_x = lattice + 8 * np.stack([sx, np.zeros_like(sx)], axis=1)
    far_y = lattice + 8 * np.stack([np.zeros_like(sy), sy], axis=1)

    def at(pos: np.ndarray) -> np.ndarray:
        return q[node[np.maximum(pos, 0)]]

    a, b = at(prev), at(nxt)
    a2, b2 = at(prev2), at(next2)
    same = lambda u, v: (u == v).all(axis=1)  # noqa: E731
    forward = same(a, leg_x) & same(b, leg_y) & same(a2, far_x) & same(b2, far_y)
    backward = same(a, leg_y) & same(b, leg_x) & same(a2, far_y) & same(b2, far_x)
    match = ok & cut & (forward | backward)
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
    corners[node[match]] = True
    return corners


def detect_run_corners(splines: SplineSet, tolerance: float = 0.3, short: float = 1.4,
                       long: float = 2.5, min_turn: float = np.radians(80.0),
                       min_bend: float = np.radians(25.0)) -> np.ndarray:
    """(N,) bool: nodes where long straight runs of the quantized outline meet at an angle.

    From every curve node, the run behind and the run ahead are extended node by node as
    long as every node in between stays within ``tolerance`` pixels of the chord (up to 4 px).
    A staircase of any slope is one run (its quarter-pixel nodes stay within the tolerance
    of a single chord); a smooth curve bends before its chords get long. Two patterns:

    * a sharp corner: runs of at least ``long`` on both sides turning by ``min_turn`` (80°)
      or more;
    * a bevelled corner: a long run, a short one (``short`` ≤ length < ``long``) and a long
      one, bending at both ends of the short run by ``min_bend`` or more and by ``min_turn``
      or more in all — the apex pixels of a 45°-rotated rectangle, like the corners of the
      Windows 3.1 "386" chip. Both ends of the short run are corners.

    A pixel circle is an octagon of runs turning by 45° at a time, over runs longer than a
    bevel: no node of it matches.
    """
    q = splines.cells.nodes.astype(np.float64) / 4.0
    prev, nxt = splines.neighbours()
    node = splines.curve_nodes
    here = q[node]
    interior = (prev >= 0) & (nxt >= 0)

    def run(step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vector from each node to the far end of its straight run along ``step``, and the
        slot of that far end (-1 for none)."""
        chord = np.zeros_like(here)
        far_pos = np.full(node.size, -1, dtype=np.int64)
        alive = interior.copy()
        walk = np.arange(node.size)
        visited: list[np.ndarray] = []
        for _ in range(12):
            walk = np.where(alive, step[np.maximum(walk, 0)], -1)
            alive &= walk >= 0
            far = q[node[np.maximum(walk, 0)]]
            candidate = far - here
            length = np.linalg.norm(candidate, axis=1)
            ok = alive.copy()
            for mid in visited:  # every node passed must stay near the new chord
                rel = mid - here
                cross = np.abs(candidate[:, 0] * rel[:, 1] - candidate[:, 1] * rel[:, 0])
                ok &= cross <= tolerance * np.maximum(length, 1e-9)
            alive &= ok
            chord = np.where(alive[:, None], candidate, chord)
            far_pos = np.where(alive, walk, far_pos)
            alive &= length < 4.0
            visited.append(far)
        return chord, far_pos

    def turn(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Angle between directions u and v (0 = straight on)."""
        cos = (u * v).sum(axis=1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-12)
        return np.arccos(np.clip(cos, -1.0, 1.0))

    back, _ = run(prev)
    ahead, ahead_end = run(nxt)
    lb, la = np.linalg.norm(back, axis=1), np.linalg.norm(ahead, axis=1)
    incoming = -back  # direction of travel arriving at the node
    sharp = interior & (lb >= long) & (la >= long) & (turn(incoming, ahead) >= min_turn)

    k = np.maximum(ahead_end, 0)
    after = ahead[k]
    bevel = (interior & (ahead_end >= 0) & (lb >= long) & (la >= short) & (la < long)
             & (np.linalg.norm(after, axis=1) >= long)
             & (turn(incoming, ahead) >= min_bend) & (turn(ahead, after) >= min_bend)
             & (turn(incoming, after) >= min_turn))
    # the same bevel found from its other end, walking the curve backwards
    corners = np.zeros(len(q), dtype=bool)
    corners[node[sharp]] = True
    corners[node[bevel]] = True
    corners[node[k[bevel]]] = True
    return corners


def optimize_splines(splines: SplineSet, params: Params = Params()) -> OptimizedSplines:
    """Relax the curve nodes (§3.4) and move the other nodes by a harmonic map."""
    cells = splines.cells
    square = detect_corners(splines) if params.corner_patterns else np.zeros(len(cells.nodes), bool)
    diagonal = detect_run_corners(splines) if params.corner_patterns else square
    corners = square | diagonal
    if corners.any():
        splines = extract_splines(cells, params, breaks=corners)
    start = splines.positions.copy()
    q = cells.nodes[square]
    start[square] = 4 * np.round(q / 4.0) / 4.0  # a right-angle corner sits on its lattice point

    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    movable = ~end & ~corners[splines.curve_nodes]
    relax = _Relaxation(splines, prev, nxt, end, _excluded_halves(splines, corners))

    ctrl = splines.controls_for(start)  # T-junction ends snapped onto their curves
    anchor = ctrl.copy()
    energy_before = relax.total_energy(ctrl, anchor)
    rng = np.random.default_rng(params.seed)
    classes = [relax.prepare(m) for m in _independent_classes(splines, movable) if m.size]
    for _ in range(params.iterations):
        for c in rng.permutation(len(classes)):
            group = classes[c]
            size = (group.members.size, params.candidates)
            angle = rng.uniform(0.0, 2.0 * np.pi, size=size)
            radius = params.radius * np.sqrt(rng.uniform(0.0, 1.0, size=size))
            here = ctrl[group.members][:, None, :]
            offsets = np.stack([np.cos(angle), np.sin(angle)], axis=-1) * radius[..., None]
            trial = np.concatenate([here, here + offsets], axis=1)  # (M, K+1, 2), 0 = stay
            energy = relax.energy(ctrl, anchor, group, trial)
            too_far = ((trial - anchor[group.members][:, None]) ** 2).sum(axis=-1) > params.max_offset**2
            too_far[:, 0] = False
            best = np.argmin(np.where(too_far, np.inf, energy), axis=1)  # ties keep the lower index
            # the best trial must not bring a curve closer to a protected point than allowed
            # (unless it was closer already); only moving nodes need the check
            rows = np.flatnonzero(best > 0)
            chosen = trial[rows, best[rows]][:, None]
            clear = relax.clearance(ctrl, group, chosen, rows)[:, 0]
            near = clear < params.centre_clearance
            if near.any():
                stay = trial[rows[near], 0][:, None]
                clear_stay = relax.clearance(ctrl, group, stay, rows[near])[:, 0]
                refuse = np.zeros(rows.size, bool)
                refuse[near] = clear[near] < clear_stay
                best[rows[refuse]] = 0
            ctrl[group.members] = trial[np.arange(best.size), best]
        ctrl = splines.snap(ctrl)  # ends that sit on a moved curve follow it
    energy_after = relax.total_energy(ctrl, anchor)

    positions = start.copy()
    positions[splines.curve_nodes[movable]] = ctrl[movable]
    positions = _harmonic_map(splines, start, positions, corners)
    positions = _keep_centres_inside(splines, start, positions, params.centre_clearance / 2)
    return OptimizedSplines(splines, corners, start, positions, energy_before, energy_after)


@dataclass(frozen=True, eq=False)
class _Group:
    """One class of independent nodes with every index its evaluation needs, precomputed."""

    members: np.ndarray  # (M,) slots being moved
    a: np.ndarray  # previous slots
    b: np.ndarray  # next slots
    a2: np.ndarray  # slot before a (a itself when a is an end)
    b2: np.ndarray  # slot after b
    has_a: np.ndarray  # (M,) bool: segment of a exists (a is interior)
    has_b: np.ndarray
    end_a: np.ndarray  # (M, 1) bool, broadcastable over candidates
    end_b: np.ndarray
    end_a2: np.ndarray
    end_b2: np.ndarray
    keep_own: np.ndarray  # (M, 1, 2) bool: halves of each segment counted in E_s
    keep_a: np.ndarray
    keep_b: np.ndarray
    protected: np.ndarray  # (M, 1, 1, Q, 2) points the segments must keep clear of


class _Relaxation:
    """Node energies and clearances over the curve slots."""

    def __init__(self, splines: SplineSet, prev, nxt, end, excluded):
        self.prev, self.nxt, self.end = prev, nxt, end
        self.keep = ~excluded  # (P, 2) halves counted in E_s
        # protected points per slot: centres of the pixels on both sides of the edge
        # leaving it, and the lattice corner of a diagonal link at its node (a thin
        # diagonal feature must stay connected there); far away where there is none
        cells = splines.cells
        w = cells.shape[1]
        edge = splines.slot_edges
        pix = np.where(edge[:, None] >= 0, cells.edge_pixels[np.maximum(edge, 0)], -1)
        rows, cols = np.divmod(np.maximum(pix, 0), w)
        centre = np.stack([cols + 0.5, rows + 0.5], axis=-1).astype(np.float64)
        side = np.where((pix >= 0)[..., None], centre, _FAR)  # (P, 2, 2)
        q = cells.nodes[splines.curve_nodes]
        lattice = 4 * np.round(q / 4.0)
        split = (np.abs(q - lattice) == 1).all(axis=1)
        link = np.where(split[:, None], lattice / 4.0, _FAR)[:, None, :]
        self.protected = np.concatenate([side, link], axis=1)  # (P, 3, 2)

    def prepare(self, members: np.ndarray) -> _Group:
        a, b = self.prev[members], self.nxt[members]
        has_a, has_b = ~self.end[a], ~self.end[b]
        a2 = np.where(has_a, self.prev[a], a)
        b2 = np.where(has_b, self.nxt[b], b)
        protected = _unique_rows(np.concatenate([self.protected[x] for x in (a2, a, members, b)], axis=1))
        col = lambda x: x[:, None]  # noqa: E731
        return _Group(
            members, a, b, a2, b2, has_a, has_b,
            col(self.end[a]), col(self.end[b]), col(self.end[a2]), col(self.end[b2]),
            col(self.keep[members]), col(self.keep[a]), col(self.keep[b]),
            protected[:, None, None],
        )

    def _segments(self, ctrl, g: _Group, trial, rows=slice(None)):
        """The three segments a member shapes: before (of a), own, after (of b)."""
        c_a, c_b = ctrl[g.a[rows]][:, None], ctrl[g.b[rows]][:, None]
        c_a2, c_b2 = ctrl[g.a2[rows]][:, None], ctrl[g.b2[rows]][:, None]
        end_a, end_b = g.end_a[rows][..., None], g.end_b[rows][..., None]
        end_a2, end_b2 = g.end_a2[rows][..., None], g.end_b2[rows][..., None]
        own = span(c_a, trial, c_b, end_a, end_b)
        before = span(c_a2, c_a, trial, end_a2)
        after = span(trial, c_b, c_b2, after_is_end=end_b2)
        return before, own, after

    def energy(self, ctrl, anchor, g: _Group, trial) -> np.ndarray:
        """(M, K) energy of each member at each trial position."""
        before, own, after = self._segments(ctrl, g, trial)
        energy = _turning(*own, g.keep_own)
        energy = energy + np.where(g.has_a[:, None], _turning(*before, g.keep_a), 0.0)
        energy = energy + np.where(g.has_b[:, None], _turning(*after, g.keep_b), 0.0)
        return energy + (((trial - anchor[g.members][:, None]) ** 2).sum(axis=-1)) ** 2

    def clearance(self, ctrl, g: _Group, trial, rows) -> np.ndarray:
        """(R, K) smallest distance from the three segments of the members ``rows`` to their
        protected points (pixel centres beside them, diagonal-link corners), per trial."""
        before, own, after = self._segments(ctrl, g, trial, rows)
        points = np.concatenate([
            flatten(*before, 4)[..., :-1, :], flatten(*own, 4), flatten(*after, 4)[..., 1:, :],
        ], axis=-2)  # (M, K, 13, 2)
        gap = ((points[..., None, :] - g.protected[rows]) ** 2).sum(axis=-1).min(axis=(-1, -2))
        return np.sqrt(gap)

    def total_energy(self, ctrl, anchor) -> float:
        p = np.flatnonzero(~self.end)
        a, b = self.prev[p], self.nxt[p]
        spans = span(ctrl[a], ctrl[p], ctrl[b], self.end[a][:, None], self.end[b][:, None])
        smooth = _turning(*spans, self.keep[p]).sum()
        positional = ((((ctrl - anchor) ** 2).sum(axis=1)) ** 2).sum()
        return float(smooth + positional)


_FAR = 1e6  # stands for "no protected point"


def _unique_rows(points: np.ndarray) -> np.ndarray:
    """(M, Q, 2) → (M, Q', 2): each row's distinct points first, padded with _FAR."""
    key = points[..., 0] * 4096.0 + points[..., 1]
    order = np.argsort(key, axis=1)
    key = np.take_along_axis(key, order, axis=1)
    pts = np.take_along_axis(points, order[..., None], axis=1)
    repeat = np.zeros(key.shape, bool)
    repeat[:, 1:] = key[:, 1:] == key[:, :-1]
    pts = np.where((repeat | (pts[..., 0] >= _FAR))[..., None], _FAR, pts)
    keep = np.argsort(pts[..., 0] >= _FAR, axis=1, kind="stable")
    pts = np.take_along_axis(pts, keep[..., None], axis=1)
    width = max(int((pts[..., 0] < _FAR).sum(axis=1).max(initial=0)), 1)
    return pts[:, :width]


def _turning(start, c, stop, keep) -> np.ndarray:
    """E_s of spans (start, c, stop): ∫|κ| ds over the halves that ``keep`` (..., 2) selects
    (corner parts are left out)."""
    first, second = half_turns(start, c, stop)
    return first * keep[..., 0] + second * keep[..., 1]


def _excluded_halves(splines: SplineSet, corners: np.ndarray) -> np.ndarray:
    """(P, 2) bool: halves of segments that touch a corner node (left out of E_s)."""
    prev, nxt = splines.neighbours()
    at_corner = corners[splines.curve_nodes]
    excluded = np.zeros((splines.curve_nodes.size, 2), dtype=bool)
    excluded[:, 0] = (prev >= 0) & at_corner[np.maximum(prev, 0)]
    excluded[:, 1] = (nxt >= 0) & at_corner[np.maximum(nxt, 0)]
    excluded |= at_corner[:, None]
    return excluded


def _independent_classes(splines: SplineSet, movable: np.ndarray) -> list[np.ndarray]:
    """Split movable slots into classes whose members are ≥ 3 slots apart along each curve."""
    curve = splines.slot_curve()
    first = splines.curve_ptr[:-1][curve]
    length = np.diff(splines.curve_ptr)[curve]
    index = np.arange(curve.size) - first
    closed = splines.curve_closed[curve]
    rest = length % 3
    colour = index % 3
    tail = closed & (index >= length - rest)  # wrap-around leftovers of a closed curve
    colour = np.where(tail, 3 + (index - (length - rest)), colour)
    return [np.flatnonzero(movable & (colour == c)) for c in range(5)]


def centre_clearance(image: VectorImage, pixels: np.ndarray | None = None, samples: int = 3) -> np.ndarray:
    """(H*W,) signed distance of each pixel centre to its own drawn cell's boundary.

    Positive inside, negative outside (curves flattened into ``2 * samples`` pieces per
    edge); +inf for pixels outside the optional ``pixels`` mask. Inside-ness is even-odd
    ray casting from every centre towards +x against the flattened boundary of its own cell,
    all cells at once: each edge contributes its polyline to the cells on both sides.
    """
    cells = image.cells
    h, w = cells.shape
    n_px = h * w
    wanted = np.ones(n_px, bool) if pixels is None else pixels
    sides = cells.edge_pixels
    use = (wanted[np.maximum(sides, 0)] & (sides >= 0)).any(axis=1)
    pix_all, hits_all, dist_all = [], [], []
    for curved in (False, True):  # a straight edge is one segment, a curve 2 * samples
        edge = np.flatnonzero(use & (image.curved == curved))
        a, b = image.points[cells.edges[edge, 0]], image.points[cells.edges[edge, 1]]
        if curved:
            poly = flatten_edges(a, image.controls[edge], b, samples)  # (E', 2 * samples + 1, 2)
        else:
            poly = np.stack([a, b], axis=1)
        p0, p1 = poly[:, :-1], poly[:, 1:]
        for side in (0, 1):
            pix = sides[edge, side]
            has = (pix >= 0) & wanted[np.maximum(pix, 0)]
            rows, cols = np.divmod(pix[has], w)
            cx, cy = (cols + 0.5)[:, None], (rows + 0.5)[:, None]
            q0, q1 = p0[has], p1[has]
            straddle = (q0[..., 1] > cy) != (q1[..., 1] > cy)
            with np.errstate(divide="ignore", invalid="ignore"):
                x_at = q0[..., 0] + (cy - q0[..., 1]) * (q1[..., 0] - q0[..., 0]) / (q1[..., 1] - q0[..., 1])
            hits_all.append((straddle & (x_at > cx)).sum(axis=1))
            seg = q1 - q0
            rel_x, rel_y = cx - q0[..., 0], cy - q0[..., 1]
            length2 = np.maximum(seg[..., 0] ** 2 + seg[..., 1] ** 2, 1e-12)
            along = np.clip((rel_x * seg[..., 0] + rel_y * seg[..., 1]) / length2, 0.0, 1.0)
            dx, dy = rel_x - along * seg[..., 0], rel_y - along * seg[..., 1]
            dist_all.append(np.sqrt((dx * dx + dy * dy).min(axis=1)))
            pix_all.append(pix[has])
    pix = np.concatenate(pix_all)
    count = np.bincount(pix, weights=np.concatenate(hits_all), minlength=n_px)
    nearest = np.full(n_px, np.inf)
    if pix.size:
        order = np.argsort(pix, kind="stable")
        sorted_pix = pix[order]
        starts = np.flatnonzero(np.r_[True, sorted_pix[1:] != sorted_pix[:-1]])
        nearest[sorted_pix[starts]] = np.minimum.reduceat(np.concatenate(dist_all)[order], starts)
    inside = count.astype(np.int64) % 2 == 1
    return np.where(wanted, np.where(inside, nearest, -nearest), np.inf)


def _keep_centres_inside(splines: SplineSet, start: np.ndarray, positions: np.ndarray,
                         margin: float, rounds: int = 8) -> np.ndarray:
    """Undo moves around any cell whose pixel centre came closer than ``margin`` to its
    boundary (or left it), until none does. Moves made elsewhere on a curve (a T-junction
    end follows the curve it ends on) can reach a cell the relaxation did not check.
    Only cells next to an edge whose geometry changed are measured."""
    cells = splines.cells
    positions = positions.copy()
    initial = splines.vector_image(start)
    prev, nxt = splines.neighbours()
    n_px = cells.shape[0] * cells.shape[1]
    floor = np.full(n_px, np.nan)  # min(margin, initial clearance), filled in on demand
    reference = initial  # geometry already verified (or initial), to find what changed since
    for _ in range(rounds):
        current = splines.vector_image(positions)
        changed = (
            (np.abs(current.points - reference.points).max(axis=1)[cells.edges] > 1e-12).any(axis=1)
            | (np.abs(current.controls - reference.controls).max(axis=(1, 2)) > 1e-12)
        )
        pixels = np.zeros(n_px, bool)
        sides = cells.edge_pixels[changed].ravel()
        pixels[sides[sides >= 0]] = True
        if not pixels.any():
            break
        missing = pixels & np.isnan(floor)
        if missing.any():
            floor[missing] = np.minimum(centre_clearance(initial, missing)[missing], margin)
        ok = ~pixels | (centre_clearance(current, pixels) >= floor - 1e-9)
        reference = current
        if ok.all():
            break
        bad = np.flatnonzero(~ok)
        touched = np.isin(cells.edge_pixels, bad).any(axis=1)
        nodes = np.unique(cells.edges[touched])
        # widen to the whole neighbourhood on the curves through those nodes
        on = np.isin(splines.curve_nodes, nodes)
        for step in (prev, nxt):
            near = step[on & (step >= 0)]
            on[near] = True
        nodes = np.union1d(nodes, splines.curve_nodes[on])
        positions[nodes] = start[nodes]
    return positions


def _harmonic_map(splines: SplineSet, start: np.ndarray, positions: np.ndarray,
                  corners: np.ndarray, reach: int = 6) -> np.ndarray:
    """Move free nodes by the harmonic interpolation of the constrained displacements.

    Constrained: every curve node (displaced from its initial place to its display point),
    the border and corners (not displaced). The system — each free node's displacement is
    the mean of its neighbours' (uniform weights) — is solved for the free nodes within
    ``reach`` edges of a displaced node; farther free nodes are held at their place (the
    harmonic field has decayed to nothing there), which keeps full frames cheap. The
    solver is conjugate gradients in numpy (the system is symmetric positive definite),
    run to far below the output precision.
    """
    cells = splines.cells
    n = len(start)
    q = cells.nodes
    h, w = cells.shape
    border = (q[:, 0] == 0) | (q[:, 1] == 0) | (q[:, 0] == 4 * w) | (q[:, 1] == 4 * h)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[splines.curve_nodes] = True
    display = splines.geometry(positions)[0]
    displacement = np.where(on_curve[:, None], display - start, 0.0)
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    near = np.abs(displacement).max(axis=1) > 1e-12
    for _ in range(reach):
        grown = near.copy()
        grown[u[near[v]]] = True
        grown[v[near[u]]] = True
        near = grown
    free = ~(on_curve | border | corners) & near
    if not free.any():
        return positions
    degree = np.bincount(u, minlength=n) + np.bincount(v, minlength=n)
    # the system on the free nodes only: compact indices, free–free edges for the operator,
    # free–fixed edges for the right-hand side
    index = np.cumsum(free) - 1
    m = int(free.sum())
    inner = free[u] & free[v]
    fu, fv = index[u[inner]], index[v[inner]]
    rhs = np.zeros((m, 2))
    for a, b in ((u, v), (v, u)):  # a free, b fixed
        edge = free[a] & ~free[b]
        for i in range(2):
            rhs[:, i] += np.bincount(index[a[edge]], displacement[b[edge], i], minlength=m)
    diagonal = degree[free][:, None].astype(np.float64)

    def apply(x: np.ndarray) -> np.ndarray:
        out = diagonal * x
        for i in range(2):
            out[:, i] -= np.bincount(fu, x[fv, i], minlength=m) + np.bincount(fv, x[fu, i], minlength=m)
        return out

    x = np.zeros((m, 2))
    r = rhs.copy()
    p = r.copy()
    rr = (r * r).sum(axis=0)
    target = 1e-18 * max(float(rr.max()), 1e-30)
    for _ in range(4 * m + 10):
        if rr.max() <= target:
            break
        ap = apply(p)
        step = rr / np.maximum((p * ap).sum(axis=0), 1e-300)
        x += step * p
        r -= step * ap
        rr_new = (r * r).sum(axis=0)
        p = r + (rr_new / np.maximum(rr, 1e-300)) * p
        rr = rr_new
    out = positions.copy()
    out[free] = start[free] + x
    return out
