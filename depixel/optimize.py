"""Stage 5 — paper §3.4 — splines → optimized splines (the default output).

Energy of a curve node i (equation 1-4 of the paper)::

    E(i) = E_s(i) + E_p(i),   E_s = ∫ |κ(s)| ds over the segments i influences,
                              E_p = ‖p_i − p̂_i‖⁴

The smoothness integral of a quadratic segment is taken by sampling its tangent at fixed
parameter steps (t = 0, ¼, ½, ¾, 1) and summing the absolute turning between samples;
the tangent of a quadratic Bézier turns monotonically, so this equals the integral exactly.

Corner patterns (paper Figure 7, docs/corners.md): a right-angle corner of a block whose
legs run straight for at least two pixel edges on both sides. Such a node is moved to its
lattice corner, fixed, and made a break point of its curve (beyond the paper: its §4.1
suggests knot multiplicity for sharp features), and the curve parts next to it are left out
of the smoothness integral.

Relaxation: ``iterations`` sweeps; in each sweep the nodes are visited class by class in a
random order of classes (nodes of one class are three or more positions apart along their
curve, so their energies are independent and they move together, vectorized); each node
tries ``candidates`` random offsets within ``radius`` of its current place and keeps the best
(or stays). All randomness comes from ``numpy.random.default_rng(seed)``.

Harmonic map: the nodes off the curves (and off the image border) then move by the
harmonic interpolation of the curve nodes' displacements (uniform weights, a sparse linear
solve), so cells next to moved curves follow them instead of folding.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix, diags
from scipy.sparse.linalg import spsolve

from .params import Params
from .splines import SplineSet, extract_splines
from .vector import VectorImage

_T = np.linspace(0.0, 1.0, 5)  # tangent samples per segment: quarters, halves at index 2


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
    """(N,) bool: interior curve nodes matching the right-angle corner pattern.

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


def optimize_splines(splines: SplineSet, params: Params = Params()) -> OptimizedSplines:
    """Relax the curve nodes (§3.4) and move the other nodes by a harmonic map."""
    cells = splines.cells
    corners = detect_corners(splines) if params.corner_patterns else np.zeros(len(cells.nodes), bool)
    if corners.any():
        splines = extract_splines(cells, params, breaks=corners)
    start = splines.positions.copy()
    q = cells.nodes[corners]
    start[corners] = 4 * np.round(q / 4.0) / 4.0  # a sharp corner sits on its lattice point

    prev, nxt = splines.neighbours()
    end = (prev < 0) | (nxt < 0)
    movable = ~end & ~corners[splines.curve_nodes]
    excluded = _excluded_halves(splines, corners)
    layout = _Layout(splines, prev, nxt, end, excluded)

    ctrl = splines.controls_for(start)  # T-junction ends snapped onto their curves
    anchor = ctrl.copy()
    snapped = end & splines.through_nodes()[splines.curve_nodes]
    energy_before = layout.total_energy(ctrl, anchor)
    rng = np.random.default_rng(params.seed)
    classes = _independent_classes(splines, movable)
    for _ in range(params.iterations):
        for c in rng.permutation(len(classes)):
            members = classes[c]
            if members.size == 0:
                continue
            angle = rng.uniform(0.0, 2.0 * np.pi, size=(members.size, params.candidates))
            radius = params.radius * np.sqrt(rng.uniform(0.0, 1.0, size=(members.size, params.candidates)))
            offsets = np.stack([np.cos(angle), np.sin(angle)], axis=-1) * radius[..., None]
            trial = np.concatenate([ctrl[members][:, None, :], ctrl[members][:, None, :] + offsets], axis=1)
            energy = layout.node_energy(ctrl, anchor, members, trial)
            too_far = np.linalg.norm(trial - anchor[members][:, None], axis=-1) > params.max_offset
            clear = layout.clearance(ctrl, members, trial)
            too_close = clear < np.minimum(params.centre_clearance, clear[:, :1])
            reject = too_far | too_close
            reject[:, 0] = False  # staying put is always allowed
            energy = np.where(reject, np.inf, energy)
            best = np.argmin(energy, axis=1)  # index 0 (stay) wins ties
            ctrl[members] = trial[np.arange(members.size), best]
        if snapped.any():  # ends that sit on a moved curve follow it
            moved = start.copy()
            moved[splines.curve_nodes[movable]] = ctrl[movable]
            ctrl[snapped] = splines.controls_for(moved)[snapped]
    energy_after = layout.total_energy(ctrl, anchor)

    positions = start.copy()
    positions[splines.curve_nodes[movable]] = ctrl[movable]
    positions = _harmonic_map(splines, start, positions, corners)
    positions = _keep_centres_inside(splines, start, positions, params.centre_clearance / 2)
    return OptimizedSplines(splines, corners, start, positions, energy_before, energy_after)


class _Layout:
    """Index arithmetic for node energies over the flattened curve positions."""

    def __init__(self, splines: SplineSet, prev, nxt, end, excluded):
        self.prev, self.nxt, self.end = prev, nxt, end
        self.excluded = excluded  # (P, 2) bool: first / second half of segment p left out
        self.interior = ~end
        # centres of the pixels on both sides of the edge leaving each position (NaN if none)
        cells = splines.cells
        w = cells.shape[1]
        edge = splines.seg_edges
        pix = np.where(edge[:, None] >= 0, cells.edge_pixels[np.maximum(edge, 0)], -1)
        rows, cols = np.divmod(np.maximum(pix, 0), w)
        centre = np.stack([cols + 0.5, rows + 0.5], axis=-1).astype(np.float64)
        side = np.where((pix >= 0)[..., None], centre, np.nan)  # (P, 2, 2)
        # the lattice corner of a diagonal link: a thin diagonal feature must stay connected there
        q = cells.nodes[splines.curve_nodes]
        lattice = 4 * np.round(q / 4.0)
        split = (np.abs(q - lattice) == 1).all(axis=1)
        link = np.where(split[:, None], lattice / 4.0, np.nan)[:, None, :]
        self.side_centres = np.concatenate([side, link], axis=1)  # (P, 3, 2) protected points

    def clearance(self, ctrl, members, trial) -> np.ndarray:
        """(M, K) smallest distance from the three segments a node moves to the centres of
        the pixels along them (so a curve never sweeps over a pixel centre)."""
        m = members
        a, b = self.prev[m], self.nxt[m]
        a2 = np.where(~self.end[a], self.prev[a], a)
        b2 = np.where(~self.end[b], self.nxt[b], b)
        centres = np.concatenate([self.side_centres[a2], self.side_centres[a], self.side_centres[m],
                                  self.side_centres[b]], axis=1)  # (M, 8, 2)
        k = trial.shape[1]
        t = np.linspace(0.0, 1.0, 9)[:, None]

        def points(c_prev, c, c_next, prev_end, next_end):
            start, stop = self._segments(c_prev, c, c_next, prev_end, next_end)
            return ((1 - t) ** 2 * start[..., None, :] + 2 * t * (1 - t) * c[..., None, :]
                    + t**2 * stop[..., None, :])

        rep = lambda x: np.repeat(x[:, None], k, axis=1)  # noqa: E731
        own = points(rep(ctrl[a]), trial, rep(ctrl[b]), rep(self.end[a]), rep(self.end[b]))
        prev_seg = points(rep(ctrl[a2]), rep(ctrl[a]), trial, rep(self.end[a2]), np.zeros((m.size, k), bool))
        next_seg = points(trial, rep(ctrl[b]), rep(ctrl[b2]), np.zeros((m.size, k), bool), rep(self.end[b2]))
        prev_seg = np.where(rep(~self.end[a])[..., None, None], prev_seg, own[..., :1, :])
        next_seg = np.where(rep(~self.end[b])[..., None, None], next_seg, own[..., -1:, :])
        samples = np.concatenate([prev_seg, own, next_seg], axis=2)  # (M, K, 27, 2)
        diff = samples[:, :, :, None, :] - centres[:, None, None, :, :]
        dist = np.sqrt((diff**2).sum(axis=-1))  # (M, K, 27, 8)
        return np.nanmin(np.where(np.isnan(dist), np.inf, dist), axis=(2, 3))

    def _segments(self, c_prev, c, c_next, prev_end, next_end):
        start = np.where(prev_end[..., None], c_prev, (c_prev + c) / 2.0)
        stop = np.where(next_end[..., None], c_next, (c + c_next) / 2.0)
        return start, stop

    def _turning(self, start, c, stop, excluded):
        """∫|κ| ds of segments (start, c, stop), sampled; excluded halves left out."""
        t = _T.reshape((1,) * (c.ndim - 1) + (-1, 1))
        d0 = (c - start)[..., None, :]
        d1 = (stop - c)[..., None, :]
        tangent = (1.0 - t) * d0 + t * d1
        theta = np.arctan2(tangent[..., 1], tangent[..., 0])
        step = np.abs((np.diff(theta, axis=-1) + np.pi) % (2.0 * np.pi) - np.pi)  # (..., 4)
        keep = np.repeat(~excluded, 2, axis=-1)
        return (step * keep).sum(axis=-1)

    def total_energy(self, ctrl, anchor) -> float:
        p = np.flatnonzero(self.interior)
        a, b = self.prev[p], self.nxt[p]
        start, stop = self._segments(ctrl[a], ctrl[p], ctrl[b], self.end[a], self.end[b])
        smooth = self._turning(start, ctrl[p], stop, self.excluded[p]).sum()
        positional = (np.linalg.norm(ctrl - anchor, axis=1) ** 4).sum()
        return float(smooth + positional)

    def node_energy(self, ctrl, anchor, members, trial) -> np.ndarray:
        """(M, K) energy of each member node at each trial position."""
        m = members
        a, b = self.prev[m], self.nxt[m]  # both exist: members are interior
        k = trial.shape[1]
        c_a = np.repeat(ctrl[a][:, None], k, axis=1)
        c_b = np.repeat(ctrl[b][:, None], k, axis=1)
        end_a = np.repeat(self.end[a][:, None], k, axis=1)
        end_b = np.repeat(self.end[b][:, None], k, axis=1)
        # segment of the node itself
        start, stop = self._segments(c_a, trial, c_b, end_a, end_b)
        energy = self._turning(start, trial, stop, np.repeat(self.excluded[m][:, None], k, axis=1))
        # segment of the previous position, if it is interior: (a2, a, trial)
        has_a = ~self.end[a]
        a2 = np.where(has_a, self.prev[np.maximum(a, 0)], m)
        c_a2 = np.repeat(ctrl[np.maximum(a2, 0)][:, None], k, axis=1)
        end_a2 = np.repeat(self.end[np.maximum(a2, 0)][:, None], k, axis=1)
        start, stop = self._segments(c_a2, c_a, trial, end_a2, np.zeros_like(end_a2))
        e_prev = self._turning(start, c_a, stop, np.repeat(self.excluded[a][:, None], k, axis=1))
        energy += np.where(has_a[:, None], e_prev, 0.0)
        # segment of the next position, if interior: (trial, b, b2)
        has_b = ~self.end[b]
        b2 = np.where(has_b, self.nxt[np.maximum(b, 0)], m)
        c_b2 = np.repeat(ctrl[np.maximum(b2, 0)][:, None], k, axis=1)
        end_b2 = np.repeat(self.end[np.maximum(b2, 0)][:, None], k, axis=1)
        start, stop = self._segments(trial, c_b, c_b2, np.zeros_like(end_b2), end_b2)
        e_next = self._turning(start, c_b, stop, np.repeat(self.excluded[b][:, None], k, axis=1))
        energy += np.where(has_b[:, None], e_next, 0.0)
        energy += np.linalg.norm(trial - anchor[m][:, None], axis=-1) ** 4
        return energy


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
    """Split movable positions into classes whose members are ≥ 3 apart along each curve."""
    curve = splines.position_curve()
    first = splines.curve_ptr[:-1][curve]
    length = np.diff(splines.curve_ptr)[curve]
    index = np.arange(curve.size) - first
    closed = splines.curve_closed[curve]
    rest = length % 3
    colour = index % 3
    tail = closed & (index >= length - rest)  # wrap-around leftovers of a closed curve
    colour = np.where(tail, 3 + (index - (length - rest)), colour)
    return [np.flatnonzero(movable & (colour == c)) for c in range(5)]


def centre_clearance(image: VectorImage, samples: int = 8) -> np.ndarray:
    """(H*W,) signed distance of each pixel centre to its own drawn cell's boundary.

    Positive inside, negative outside (curves flattened into ``2 * samples`` pieces per
    edge). Inside-ness is even-odd ray casting from every centre towards +x against the
    flattened boundary of its own cell, all cells at once: each edge contributes its
    polyline to the cells on both sides.
    """
    cells = image.cells
    h, w = cells.shape
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    a, b = image.points[u], image.points[v]
    t = np.linspace(0.0, 1.0, samples + 1)[None, :, None]
    c0, c1, c2 = image.controls[:, 0], image.controls[:, 1], image.controls[:, 2]
    # curved edge = Q(a, c0, c1) then Q(c1, c2, b); sample both halves
    first = (1 - t) ** 2 * a[:, None] + 2 * t * (1 - t) * c0[:, None] + t**2 * c1[:, None]
    second = (1 - t) ** 2 * c1[:, None] + 2 * t * (1 - t) * c2[:, None] + t**2 * b[:, None]
    curve = np.concatenate([first, second[:, 1:]], axis=1)
    line = a[:, None] + np.linspace(0.0, 1.0, 2 * samples + 1)[None, :, None] * (b - a)[:, None]
    poly = np.where(image.curved[:, None, None], curve, line)  # (E, S, 2)
    p0, p1 = poly[:, :-1], poly[:, 1:]
    count = np.zeros(h * w, dtype=np.int64)
    nearest = np.full(h * w, np.inf)
    for side in (0, 1):
        pix = cells.edge_pixels[:, side]
        has = pix >= 0
        rows, cols = np.divmod(pix[has], w)
        cx, cy = (cols + 0.5)[:, None], (rows + 0.5)[:, None]
        q0, q1 = p0[has], p1[has]
        straddle = (q0[..., 1] > cy) != (q1[..., 1] > cy)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = q0[..., 0] + (cy - q0[..., 1]) * (q1[..., 0] - q0[..., 0]) / (q1[..., 1] - q0[..., 1])
        hits = (straddle & (x_at > cx)).sum(axis=1)
        np.add.at(count, pix[has], hits)
        seg = q1 - q0
        rel = np.stack([cx, cy], axis=-1) - q0
        length2 = np.maximum((seg**2).sum(axis=-1), 1e-12)
        along = np.clip((rel * seg).sum(axis=-1) / length2, 0.0, 1.0)
        dist = np.sqrt(((rel - along[..., None] * seg) ** 2).sum(axis=-1)).min(axis=1)
        np.minimum.at(nearest, pix[has], dist)
    return np.where(count % 2 == 1, nearest, -nearest)


def _keep_centres_inside(splines: SplineSet, start: np.ndarray, positions: np.ndarray,
                         margin: float, rounds: int = 8) -> np.ndarray:
    """Undo moves around any cell whose pixel centre came closer than ``margin`` to its
    boundary (or left it), until none does. Moves made elsewhere on a curve (a T-junction
    end follows the curve it ends on) can reach a cell the relaxation did not check."""
    cells = splines.cells
    positions = positions.copy()
    floor = np.minimum(centre_clearance(splines.vector_image(start)), margin)
    for _ in range(rounds):
        ok = centre_clearance(splines.vector_image(positions)) >= floor - 1e-9
        if ok.all():
            break
        bad = np.flatnonzero(~ok)
        touched = np.isin(cells.edge_pixels, bad).any(axis=1)
        nodes = np.unique(cells.edges[touched])
        # widen to the whole neighbourhood on the curves through those nodes
        prev, nxt = splines.neighbours()
        on = np.isin(splines.curve_nodes, nodes)
        for step in (prev, nxt):
            on |= np.isin(np.arange(on.size), step[on & (step >= 0)])
        nodes = np.union1d(nodes, splines.curve_nodes[on])
        positions[nodes] = start[nodes]
    return positions


def _harmonic_map(splines: SplineSet, start: np.ndarray, positions: np.ndarray,
                  corners: np.ndarray) -> np.ndarray:
    """Move free nodes by the harmonic interpolation of the constrained displacements."""
    cells = splines.cells
    n = len(start)
    q = cells.nodes
    h, w = cells.shape
    border = (q[:, 0] == 0) | (q[:, 1] == 0) | (q[:, 0] == 4 * w) | (q[:, 1] == 4 * h)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[splines.curve_nodes] = True
    fixed = on_curve | border | corners
    free = np.flatnonzero(~fixed)
    if free.size == 0:
        return positions
    display = splines.geometry(positions)[0]
    displacement = np.where(on_curve[:, None], display - start, 0.0)
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    rows = np.concatenate([u, v])
    cols = np.concatenate([v, u])
    adjacency = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)).tocsr()
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    sub = adjacency[free]
    a_ff = sub[:, free]
    a_fc = sub[:, np.flatnonzero(fixed)]
    system = diags(degree[free]) - a_ff
    rhs = a_fc @ displacement[fixed]
    solved = np.column_stack([spsolve(system.tocsc(), rhs[:, i]) for i in range(2)])
    out = positions.copy()
    out[free] = start[free] + solved
    return out
