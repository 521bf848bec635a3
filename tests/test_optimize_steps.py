"""Paper §3.4, step by step: each behaviour of the optimizer pinned by a direct test on a
tiny drawn case with a hand-checked expectation (the golden renders cannot see moves of a
tenth of a pixel). Each test was checked by breaking its behaviour in the code."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES, art

from depixel.curves.bspline import evaluate, flatten_edges, flatten_edges_planes, half_turns, midpoint
from depixel.curves.splines import SplineSet, split_at
from depixel.optimize import energy as energy_module
from depixel.optimize import harmonic as harmonic_module
from depixel.optimize import relax as relax_module
from depixel.optimize.corners import detect_corners, detect_square_corners, excluded_halves
from depixel.optimize.energy import A_ROW, B_ROW, MEMBER_ROW, Energy, Group, smoothness
from depixel.optimize.fidelity import FAR, centre_clearance, keep_centres_inside, protected_points, unique_rows
from depixel.optimize.harmonic import conjugate_gradients, follow, harmonic_map, row_dots
from depixel.optimize.relax import propose, relax, shares
from depixel.optimize.trials import CANDIDATES, PATTERN, TRIALS, candidates, trials
from depixel.params import Params
from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render.raster import render_rgba
from depixel.svg.writer import to_svg
from depixel.vector import faces

RED, PINK, ORANGE, WHITE = (200, 40, 40, 255), (255, 110, 110, 255), (230, 80, 40, 255), (255, 255, 255, 255)


def splines_of(img: np.ndarray, params: Params = Params()) -> SplineSet:
    splines = depixelize(img, params, stage="splines").splines
    assert splines is not None
    return splines


def slot_at(splines: SplineSet, xy: tuple[float, float], interior: bool = True) -> int:
    """The (interior) slot of the node at pixel coordinates ``xy``."""
    at = (splines.cells.nodes[splines.curve_nodes] == np.multiply(xy, 4)).all(axis=1)
    if interior:
        at &= ~splines.is_end()
    found = np.flatnonzero(at)
    assert found.size == 1, f"{found.size} slots at {xy}"
    return int(found[0])


def corner_points(splines: SplineSet, corners: np.ndarray) -> set[tuple[float, float]]:
    return {tuple(p) for p in (splines.cells.nodes[corners] / 4.0).tolist()}


# --- E_s: the turning integral --------------------------------------------------------------

def numerical_turning(p0, p1, p2, t0: float, t1: float, n: int = 200_001) -> float:
    """∫|κ| ds = ∫ |B' × B''| / |B'|² dt, by the trapezoid rule."""
    t = np.linspace(t0, t1, n)[:, None]
    d1 = 2 * ((1 - t) * (p1 - p0) + t * (p2 - p1))
    d2 = 2 * (p2 - 2 * p1 + p0)
    f = np.abs(d1[:, 0] * d2[1] - d1[:, 1] * d2[0]) / (d1 ** 2).sum(axis=1)
    return float(((f[1:] + f[:-1]) / 2).sum() * (t1 - t0) / (n - 1))


def test_turning_of_each_half_is_the_integral_of_the_curvature():
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(40):
        p0, p1, p2 = rng.uniform(-1, 1, (3, 2))
        first, second = half_turns(p0, p1, p2)
        if first + second > 2.5:  # nearly a cusp: the numerical integral needs far more steps
            continue
        assert float(first) == pytest.approx(numerical_turning(p0, p1, p2, 0.0, 0.5), abs=1e-6)
        assert float(second) == pytest.approx(numerical_turning(p0, p1, p2, 0.5, 1.0), abs=1e-6)
        checked += 1
    assert checked > 20


@pytest.mark.parametrize("count", [0, 1, 37])
def test_flattened_edges_as_planes_are_the_same_numbers(count):
    rng = np.random.default_rng(count)
    start, stop = rng.normal(size=(count, 2)) * 9, rng.normal(size=(count, 2)) * 9
    controls = rng.normal(size=(count, 3, 2)) * 9
    rows = flatten_edges(start, controls, stop, 3)  # (E, 7, 2)
    planes = flatten_edges_planes(start, controls, stop, 3)  # (7, E) each
    for axis in range(2):
        assert planes[axis].shape == (7, count)
        assert np.array_equal(planes[axis], rows[..., axis].T)  # bit for bit, not approximately


def test_smoothness_counts_only_the_kept_halves():
    spans = (np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([1.0, 1.0]))  # turns by 90°
    first, second = half_turns(*spans)
    assert float(first + second) == pytest.approx(np.pi / 2)
    assert smoothness(spans, np.array([True, True])) == pytest.approx(np.pi / 2)
    assert smoothness(spans, np.array([True, False])) == pytest.approx(float(first))
    assert smoothness(spans, np.array([False, True])) == pytest.approx(float(second))
    assert smoothness(spans, np.array([False, False])) == 0.0


# --- E_p: the positional term -----------------------------------------------------------------

def test_positional_energy_is_the_fourth_power_of_the_distance():
    # a straight horizontal outline: moving a node along it keeps every span straight
    # (E_s = 0), so the energy of a trial is the positional term alone
    img = art("""
    ########
    ########
    ........
    ........
    """)
    splines = splines_of(img)
    slot = slot_at(splines, (4, 2))
    model = Energy(splines, np.zeros((splines.n_slots, 2), bool))
    ctrl = splines.controls_for(splines.positions)
    distances = np.array([0.0, 0.1, 0.2, 0.4])
    trial = ctrl[slot] + np.stack([distances, np.zeros_like(distances)], axis=1)[None]
    energy = model.energy(ctrl, ctrl, model.prepare(np.array([slot])), trial)[0]
    assert energy == pytest.approx(distances**4, abs=1e-15)


# --- corners (Figure 7 and the run patterns) ----------------------------------------------

DIAMOND = art("""
..............
......##......
.....####.....
....######....
...########...
..##########..
...########...
....######....
.....####.....
......##......
..............
""")  # the "386" chip's shape: a square turned by 45°, with two-pixel apexes


def test_bevelled_apex_marks_both_ends_of_the_bevel():
    splines = splines_of(DIAMOND)
    found = corner_points(splines, detect_corners(splines).runs)
    # each two-pixel apex is a 1.5-pixel bevel between two 45° staircases: both of its ends
    # are corners, whichever way the curve runs (one end is found from the other)
    for bevel in (((6.25, 1.25), (7.75, 1.25)), ((6.25, 9.75), (7.75, 9.75)),
                  ((2.25, 5.25), (2.25, 5.75)), ((11.75, 5.25), (11.75, 5.75))):
        assert set(bevel) <= found, (bevel, sorted(found))
    # and nothing along the staircase sides: every corner is at an apex
    apexes = np.array([(7, 1), (7, 10), (2, 5.5), (12, 5.5)])
    for point in found:
        assert np.abs(apexes - point).max(axis=1).min() <= 1.0, point


#: a pyramid with a three-pixel top, its left side a 45° staircase and its right side a
#: steeper one (two rows a step): the top's right end is a bevel's far end
LOPSIDED_APEX = art("""
.................
.........###.....
........####.....
.......######....
......#######....
.....#########...
....##########...
...############..
..#############..
.................
""")


def test_a_bevel_found_from_one_end_marks_its_far_end_too():
    """The runs grown from a node depend on where they start, so a bevel can match from one
    of its ends only: here from (10, 1), where the 45° side's run takes in the top's first
    pixel, then the 1.77 px run to the top's right end (11.75, 1.25) and the steep side.
    Read from (11.75, 1.25) the other way, no bevel starts there; it is a corner because it
    is the far end of the one found (left unmarked, the top's right end would be rounded)."""
    splines = splines_of(LOPSIDED_APEX)
    found = corner_points(splines, detect_corners(splines).runs)
    apex = {p for p in found if p[1] < 3}
    assert apex == {(10.0, 1.0), (11.75, 1.25)}, sorted(found)


def test_octagon_has_no_corners():
    # straight sides of 8 px joined by 45° staircases of 3 px: every vertex turns by 45°,
    # which is rounded, as in the paper
    n = 18
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    inside = (np.maximum(abs(xx - n / 2), abs(yy - n / 2)) <= 7) & (abs(xx - n / 2) + abs(yy - n / 2) <= 10)
    img = np.full((n, n, 4), 255, np.uint8)
    img[inside, :3] = 0
    splines = splines_of(img)
    assert splines.n_curves == 1
    corners = detect_corners(splines)
    assert not corners.nodes.any(), sorted(corner_points(splines, corners.nodes))


@pytest.mark.parametrize("k", [1, 2, 4, 6])
def test_staircase_is_not_a_corner(k):
    # a right triangle whose hypotenuse is a k:1 staircase from its k-pixel top (1..1+k, 1)
    # down to (1 + 6k, 7): corners are at its vertices, none along the staircase, whose
    # steps turn one way and back (no total turn)
    width = 6 * k + 4
    rows = ["." * width]
    rows += ["." + "#" * (k * r + k) + "." * (width - 1 - k * (r + 1)) for r in range(6)]
    rows += ["." * width]
    splines = splines_of(art("\n".join(rows)))
    corners = detect_corners(splines)
    found = corner_points(splines, corners.nodes)
    vertices = np.array([(1, 1), (1 + k, 1), (1, 7), (1 + 6 * k, 7)])
    away = [p for p in found if np.abs(vertices - p).max(axis=1).min() > 0.75]
    assert not away, sorted(found)
    assert (1.25, 6.75) in corner_points(splines, corners.square)  # the right angle, cut


#: a 4 × 4 block with four right-angle corners
SQUARE_BLOCK = """
......
.####.
.####.
.####.
.####.
......
"""


def test_square_corner_is_found_and_placed_on_its_lattice_point():
    img = art(SQUARE_BLOCK)
    splines = splines_of(img)
    square = detect_square_corners(splines)
    # the cut corner nodes, a quarter pixel inside the block
    assert corner_points(splines, square) == {(1.25, 1.25), (4.75, 1.25), (1.25, 4.75), (4.75, 4.75)}
    corners = detect_corners(splines)
    start = corners.place(splines)
    assert {tuple(p) for p in start[square].tolist()} == {(1.0, 1.0), (5.0, 1.0), (1.0, 5.0), (5.0, 5.0)}


def test_split_at_cuts_the_curves_at_the_corners_only():
    img = art(SQUARE_BLOCK)
    splines = splines_of(img)
    assert splines.n_curves == 1 and splines.curve_closed[0]
    corners = detect_corners(splines).nodes
    cut = split_at(splines, corners)
    # one open curve per side, each ending at two corners; the same edges, each once
    assert cut.n_curves == 4 and not cut.curve_closed.any()
    assert np.array_equal(np.sort(cut.slot_edges[cut.slot_edges >= 0]), np.sort(splines.slot_edges))
    assert corners[cut.curve_nodes[cut.is_end()]].all()
    assert not corners[cut.curve_nodes[~cut.is_end()]].any()
    assert split_at(splines, np.zeros_like(corners)) is splines


def test_corner_halves_are_left_out_of_the_smoothness():
    # one closed curve around a block; pretend the node of slot 2 is a corner
    splines = splines_of(art(".....\n.###.\n.###.\n.###.\n....."))
    assert splines.n_curves == 1 and splines.curve_closed[0] and splines.n_slots >= 6
    corner = np.zeros(len(splines.positions), bool)
    corner[splines.curve_nodes[2]] = True
    expected = np.zeros((splines.n_slots, 2), bool)
    expected[2] = True  # the corner's own span: both halves
    expected[1, 1] = True  # the span before it: the half that reaches the corner
    expected[3, 0] = True  # the span after it: likewise
    assert np.array_equal(excluded_halves(splines, corner), expected)


# --- T-junctions ------------------------------------------------------------------------------

# Two T-junctions one edge apart: at (3, 2) the red|pink edge ends on the turning
# red|white–pink|white curve; at (2, 2) the orange|pink edge ends on the red|orange–red|pink
# curve, whose neighbouring control point is that first snapped end. Red, pink and orange
# are shading edges to each other, white a contour to all.
CHAINED_T = art("""
AAAAAA
AAAAAA
DDBCCC
DDBCCC
""", dict(A=RED, B=PINK, C=WHITE, D=ORANGE))


def snap_gaps(splines: SplineSet) -> np.ndarray:
    ends, through = splines.snap_pairs()
    ctrl = splines.controls_for(splines.positions)
    return np.abs(ctrl[ends] - midpoint(*splines.spans(ctrl))[through]).max(axis=1)


def test_chained_t_junction_ends_meet_their_curves_exactly():
    splines = splines_of(CHAINED_T)
    ends, _ = splines.snap_pairs()
    assert corner_points(splines, splines.curve_nodes[ends]) == {(2.0, 2.0), (3.0, 2.0)}
    assert snap_gaps(splines).max() < 1e-12
    # the chain is real: one pass of snapping leaves the second end off its curve
    assert snap_gaps(splines_of(CHAINED_T, Params(snap_passes=1))).max() > 0.01


# --- the harmonic map ---------------------------------------------------------------------------

def test_harmonic_map_moves_each_free_node_by_the_mean_of_its_neighbours():
    img = art("""
    .......
    .......
    .......
    ...##..
    ...##..
    .......
    .......
    """)
    splines = splines_of(img)
    cells = splines.cells
    n = len(cells.nodes)
    start = splines.positions.copy()
    positions = start.copy()
    on_curve = np.zeros(n, bool)
    on_curve[splines.curve_nodes] = True
    positions[on_curve] += np.random.default_rng(3).uniform(-0.2, 0.2, (int(on_curve.sum()), 2))
    out = harmonic_map(splines, start, positions, np.zeros(n, bool), reach=6)
    assert np.array_equal(out[on_curve], positions[on_curve])
    # displacement of every node: curve nodes to their display points, border nodes none
    q = cells.nodes
    border = (q == 0).any(axis=1) | (q[:, 0] == 4 * 7) | (q[:, 1] == 4 * 7)
    moved = np.where(on_curve[:, None], splines.geometry(positions).points - start, out - start)
    assert not moved[border & ~on_curve].any()
    free = np.flatnonzero(~on_curve & ~border)
    assert free.size >= 10 and np.abs(moved[free]).max() > 1e-3
    for node in free:
        u, v = cells.edges[:, 0], cells.edges[:, 1]
        neighbours = np.r_[v[u == node], u[v == node]]
        assert moved[node] == pytest.approx(moved[neighbours].mean(axis=0), abs=1e-5)  # the solver's residual


def test_harmonic_map_runs_in_the_pipeline():
    result = depixelize(DIAMOND)
    opt = result.optimized
    on_curve = np.zeros(len(opt.positions), bool)
    on_curve[opt.splines.curve_nodes] = True
    q = opt.splines.cells.nodes
    inside = ~on_curve & (q > 0).all(axis=1) & (q[:, 0] < 4 * 14) & (q[:, 1] < 4 * 11)
    assert np.abs(opt.positions[inside] - opt.initial[inside]).max() > 0.01


@pytest.mark.parametrize("seed", [0, 1])
def test_harmonic_operator_by_neighbour_table_adds_as_the_scatter_does(monkeypatch, seed):
    # frames use the padded neighbour table, sprites the bincount: the same sums in the same
    # order, so the same positions to the bit, on an image with cut corners and diagonals
    rng = np.random.default_rng(seed)
    img = np.where(rng.random((24, 24, 1)) < 0.45, [[[200, 40, 40, 255]]], [[[250, 250, 250, 255]]]).astype(np.uint8)
    img[8:16, 8:16] = DIAMOND[1:9, 3:11]
    opt = depixelize(img).optimized
    splines, start = opt.splines, opt.initial
    positions = start.copy()
    positions[splines.curve_nodes] = opt.positions[splines.curve_nodes]
    corners = opt.corners.nodes
    monkeypatch.setattr(harmonic_module, "TABLE_UNKNOWNS", 10**9)
    by_scatter = harmonic_map(splines, start, positions, corners)
    monkeypatch.setattr(harmonic_module, "TABLE_UNKNOWNS", 0)
    by_table = harmonic_map(splines, start, positions, corners)
    assert np.abs(by_scatter - start).max() > 0.01  # the free nodes moved
    assert np.array_equal(by_table, by_scatter)


def test_conjugate_gradients_solves_each_row_to_the_residual_it_promises():
    rng = np.random.default_rng(7)
    root = rng.normal(size=(40, 40))
    matrix = root @ root.T + 40 * np.eye(40)  # symmetric positive definite
    rhs = rng.normal(size=(3, 40))

    def apply(x: np.ndarray, out: np.ndarray) -> None:
        out[...] = x @ matrix

    x = conjugate_gradients(apply, rhs)
    exact = np.linalg.solve(matrix, rhs.T).T
    assert x.shape == rhs.shape
    residual = np.linalg.norm(x @ matrix - rhs, axis=1)
    assert (residual <= 1e-5 * np.linalg.norm(rhs, axis=1).max() * 1.0001).all()
    assert np.abs(x - exact).max() < 1e-5


def test_row_dots_are_the_dot_products_of_the_rows():
    a, b = np.arange(6.0).reshape(2, 3), np.array([[1.0, 2.0, 3.0], [-1.0, 0.5, 2.0]])
    assert row_dots(a, b) == [8.0, -3.0 + 2.0 + 10.0]
    assert row_dots(a, b, np.empty((2, 3))) == [8.0, 9.0]


def test_follow_gives_the_display_points_of_nodes_moved_off_the_curves():
    result = depixelize(DIAMOND)
    opt = result.optimized
    splines = opt.splines
    before = opt.positions
    off_curve = np.ones(len(before), bool)
    off_curve[splines.curve_nodes] = False
    after = before.copy()
    after[off_curve] += 0.125
    display = splines.display_points(before)
    followed = follow(display, before, after)
    assert np.array_equal(followed, splines.display_points(after))
    assert not np.array_equal(followed, display)


def test_the_optimized_result_draws_its_positions():
    """The drawing kept from the revert is that of the final positions: the output is what
    drawing them again gives, array for array."""
    for img in (DIAMOND, CHAINED_T):
        opt = depixelize(img).optimized
        again = opt.splines.vector_image(opt.positions, stage="optimized")
        kept = opt.vector_image()
        for name in ("points", "curved", "controls"):
            assert np.array_equal(getattr(kept, name), getattr(again, name)), name
        assert kept.curves is not None and again.curves is not None
        assert np.array_equal(kept.curves.ctrl, again.curves.ctrl)
        assert np.array_equal(kept.curves.edge_slot, again.curves.edge_slot)


@pytest.mark.parametrize("rounds", [1, 8])
def test_the_revert_returns_the_drawing_of_its_positions(rounds):
    opt = depixelize(DIAMOND).optimized
    splines = opt.splines
    wild = opt.initial + np.random.default_rng(5).uniform(-0.6, 0.6, opt.initial.shape)
    positions, drawing = keep_centres_inside(splines, opt.initial, wild, 0.075, rounds)
    assert not np.array_equal(positions, wild)  # something was put back
    again = splines.drawing(positions)
    for kept, drawn in zip(drawing, again):
        assert np.array_equal(kept, drawn)
    # given the drawing of the positions it starts from, the same result
    given = keep_centres_inside(splines, opt.initial, wild, 0.075, rounds, splines.drawing(wild))
    assert np.array_equal(given[0], positions)


def test_unique_rows_keeps_each_rows_distinct_points_in_key_order():
    points = np.array([
        [[2.5, 1.5], [FAR, FAR], [0.5, 3.5], [2.5, 1.5], [1.0, 2.0]],
        [[FAR, FAR], [4.5, 0.5], [FAR, FAR], [4.5, 0.5], [4.5, 0.5]],
        [[FAR, FAR]] * 5,
    ])
    out = unique_rows(points)
    assert out.shape == (3, 3, 2)  # as wide as the row with the most distinct points
    assert out[0].tolist() == [[0.5, 3.5], [1.0, 2.0], [2.5, 1.5]]  # ordered by x, then y
    assert out[1].tolist() == [[4.5, 0.5], [FAR, FAR], [FAR, FAR]]
    assert (out[2] == FAR).all()
    assert unique_rows(np.full((0, 4, 2), FAR)).shape == (0, 1, 2)


def test_protected_points_are_the_centres_beside_each_edge_and_the_split_corner():
    for img in (CHAINED_T, DIAMOND):  # open ends with no pixel beyond; split corners of diagonal links
        splines = splines_of(img)
        cells = splines.cells
        w = cells.shape[1]
        slots = np.arange(splines.curve_nodes.size).reshape(-1, 1)
        got = protected_points(splines, slots)
        assert got.shape == (slots.shape[0], 1, 3, 2)
        assert np.array_equal(got[:, 0], protected_points(splines))
        for slot, row in zip(slots[:, 0], got[:, 0]):
            edge = splines.slot_edges[slot]
            for side in range(2):
                pixel = cells.edge_pixels[edge, side] if edge >= 0 else -1
                want = [FAR, FAR] if pixel < 0 else [pixel % w + 0.5, pixel // w + 0.5]
                assert row[side].tolist() == want
            node = cells.nodes[splines.curve_nodes[slot]]
            split = bool((np.abs(node - 4 * np.round(node / 4)) == 1).all())
            assert row[2].tolist() == (list(np.round(node / 4)) if split else [FAR, FAR])


# --- the fidelity guard of each move ------------------------------------------------------------

STEP = """
........
........
.....###
..######
########
"""


def step_case() -> tuple[SplineSet, int, Energy, np.ndarray, Group]:
    """A one-pixel step: its drawing, the slot of its inner node (5.25, 2.25), the energy
    model with no half left out, the control points and the one-member group of the slot."""
    splines = splines_of(art(STEP))
    slot = slot_at(splines, (5.25, 2.25))
    model = Energy(splines, np.zeros((splines.n_slots, 2), bool))
    ctrl = splines.controls_for(splines.positions)
    return splines, slot, model, ctrl, model.prepare(np.array([slot]))


def weighed(model: Energy, ctrl: np.ndarray, anchor: np.ndarray, group: Group, radius: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The one member's trials (T, 2), their energies and their clearances (T,)."""
    around = ctrl[group.around].transpose(0, 2, 1)[..., None]
    trial = trials(around, anchor[group.members].T[..., None], np.array([radius]))[:, 0].T
    return (trial, model.energy(ctrl, anchor, group, trial[None])[0],
            model.clearance(ctrl, group, trial[None], np.array([0]))[0])


def test_a_move_closer_to_a_pixel_centre_than_the_clearance_is_refused():
    splines, slot, model, ctrl, group = step_case()
    params = Params(radius=0.2)
    trial, energy, clearance = weighed(model, ctrl, ctrl, group, params.radius)
    unknown = np.full((1, 2), np.nan)  # staying's clearance, not measured yet
    free, gain = propose(model, ctrl, ctrl, group, np.array([params.radius]), unknown.copy(),
                         params.replace(centre_clearance=0.0))
    # the case: unguarded, the best trial comes within 0.2 px of a protected point, staying does not
    best = int(np.argmin(energy))
    assert gain[0] > 0 and np.array_equal(free[:, 0], trial[best]) and clearance[best] < 0.2 <= clearance[0]
    # guarded, it gives way to the best trial allowed, which is not staying here
    taken, gain = propose(model, ctrl, ctrl, group, np.array([params.radius]), unknown.copy(),
                          params.replace(centre_clearance=0.2))
    at = taken[:, 0]
    assert gain[0] > 0 and not np.allclose(at, trial[best]) and not np.array_equal(at, ctrl[slot])
    assert model.clearance(ctrl, group, at[None, None], np.array([0]))[0, 0] >= 0.2
    allowed = (clearance >= 0.2) & (np.hypot(*(trial - ctrl[slot]).T) <= params.max_offset)
    assert model.energy(ctrl, ctrl, group, at[None, None])[0, 0] == pytest.approx(energy[allowed].min())


def test_a_curve_closer_than_the_clearance_already_may_move_if_it_comes_no_closer():
    # the node pushed 0.28 px towards the pixel centre (5.5, 2.5): its curve is 0.1 px from
    # it, under a clearance of 0.25; a trial drawing it back, still under the clearance but
    # farther than staying, is taken; trials closer than staying are not
    splines, slot, model, anchor, group = step_case()
    ctrl = anchor.copy()
    ctrl[slot] += 0.2
    params = Params(radius=0.2, centre_clearance=0.25)
    trial, energy, clearance = weighed(model, ctrl, anchor, group, params.radius)
    assert clearance[0] < 0.25 and (clearance < clearance[0]).any() and (energy < energy[0]).any()
    taken, gain = propose(model, ctrl, anchor, group, np.array([params.radius]), np.full((1, 2), np.nan), params)
    at = taken[:, 0][None, None]
    assert gain[0] > 0
    assert clearance[0] <= model.clearance(ctrl, group, at, np.array([0]))[0, 0] < 0.25
    allowed = clearance >= clearance[0]
    assert model.energy(ctrl, anchor, group, at)[0, 0] <= energy[allowed].min() + 1e-12


def test_a_move_long_enough_to_carry_the_curve_across_a_pixel_centre_is_refused():
    # a curve at distance d from its nearest protected point can cross it only by a move of at
    # least d plus the distance it keeps after, at least min(d, clearance) for an allowed
    # trial (either side: the member's own spans, the spans of curves ending on them): longer
    # trials are refused, shorter ones not, whichever way they point
    splines, slot, model, ctrl, group = step_case()
    here = ctrl[slot].reshape(2, 1, 1)
    for near, bound in (((0.1, np.inf), 0.2), ((0.3, 1.0), 0.45), ((1.0, 0.1), 0.2), ((np.inf, np.inf), np.inf)):
        steps = np.array([0.0, 0.05, 0.19, 0.21, 0.44, 0.46, 2.0])
        angle = np.linspace(0.3, 5.0, steps.size)
        trial = here + (steps * np.stack([np.cos(angle), np.sin(angle)]))[:, None]
        guard = relax_module._Guard(model, ctrl, np.zeros((2, 4, 1, 1)), group, trial, 0.15)
        guard.near[0] = near  # of the own spans, of the spans of curves ending on them
        guard.step[0] = np.hypot(*(trial - here)[:, 0])
        assert guard.across()[0].tolist() == (steps > bound).tolist()


def _blob_cut_at_its_corners() -> tuple[SplineSet, np.ndarray, np.ndarray]:
    """BLOB's curves cut at their detected corners, with no corner node held and no half excluded."""
    splines = split_at(*(lambda s: (s, detect_corners(s, Params()).nodes))(splines_of(art(BLOB))))
    return splines, np.zeros(len(splines.positions), bool), np.zeros((splines.n_slots, 2), bool)


def test_the_clearance_of_the_trials_weighed_in_batches_moves_the_same(monkeypatch):
    # the trials of members whose best trial was refused checked one per call instead of
    # CLEARANCE_PAIRS at a time: more calls, the same moves (each trial's clearance is its own)
    splines, corners, excluded = _blob_cut_at_its_corners()
    calls: list[int] = []
    clearance_of = Energy.clearance_of
    monkeypatch.setattr(Energy, "clearance_of", lambda self, *a: calls.append(1) or clearance_of(self, *a))
    params = Params(centre_clearance=0.3)  # many refused moves
    whole = relax(splines, splines.positions, corners, excluded, params)
    batched = len(calls)
    monkeypatch.setattr(relax_module, "CLEARANCE_PAIRS", 1)
    single = relax(splines, splines.positions, corners, excluded, params)
    assert len(calls) - batched > batched  # (7 trials a slot: 14 calls batched, 24 one pair at a time)
    assert np.array_equal(single.ctrl, whole.ctrl) and single.energy_after == whole.energy_after


def test_the_clearance_is_the_distance_of_the_three_spans_points_to_the_protected_points():
    # Energy.clearance against the spans drawn by bspline.span with the trial in place, their
    # points at t = 0, 1/4, ..., 1 and the protected points of the four edges around with the
    # split corners of their five nodes (interior members: the spans before and after are
    # ordinary spans); a call after a larger one (its distances buffer grown) gives what a
    # fresh model gives
    splines, corners, excluded = _blob_cut_at_its_corners()
    model = Energy(splines, excluded)
    prev, nxt = splines.neighbours()
    end = splines.is_end()
    members = np.flatnonzero(~end & ~end[np.maximum(prev, 0)] & ~end[np.maximum(nxt, 0)])
    group, ctrl = model.prepare(members), splines.controls_for(splines.positions)
    rng = np.random.default_rng(3)
    trial = ctrl[members][:, None] + rng.uniform(-0.4, 0.4, (members.size, 5, 2))  # (R, K, 2)
    got = model.clearance(ctrl, group, trial, np.arange(members.size))
    t = np.arange(5) / 4
    for m, slot in enumerate(members):
        around = np.array([prev[prev[slot]], prev[slot], slot, nxt[slot], nxt[nxt[slot]]])
        points = protected_points(splines, around)
        protected = np.concatenate([points[:4].reshape(-1, 2), points[4, 2:]])
        for k in range(trial.shape[1]):
            moved = ctrl.copy()
            moved[slot] = trial[m, k]
            spans = [(moved[prev[s]], moved[s], moved[nxt[s]]) for s in (prev[slot], slot, nxt[slot])]
            spans = [((a + c) / 2 if not end[prev[s]] else a, c, (c + b) / 2 if not end[nxt[s]] else b)
                     for s, (a, c, b) in zip((prev[slot], slot, nxt[slot]), spans)]
            points = np.concatenate([evaluate(*(p[None] for p in bez), t[:, None]) for bez in spans])
            want = np.sqrt(((points[:, None] - protected[None]) ** 2).sum(axis=-1)).min()
            assert got[m, k] == pytest.approx(want, rel=1e-12, abs=1e-12)
    few = np.array([3, 1])
    assert np.array_equal(model.clearance(ctrl, group, trial[few, :2], few),
                          Energy(splines, excluded).clearance(ctrl, group, trial[few, :2], few))


def test_a_small_drawing_is_prepared_once_and_moves_as_when_prepared_in_parts(monkeypatch):
    # up to PREPARE_ONCE movable slots, one Energy.prepare of them all, its protected points
    # in float64; above, one a part of PREPARE_ONCE (float32 above PREPARE_ONCE members): the
    # same moves either way (each member's numbers are its own)
    splines, corners, excluded = _blob_cut_at_its_corners()
    calls: list[int] = []
    prepare = Energy.prepare
    monkeypatch.setattr(Energy, "prepare", lambda self, m: calls.append(m.size) or prepare(self, m))
    once = relax(splines, splines.positions, corners, excluded)
    assert len(calls) == 1 and calls[0] == once.movable.sum()
    calls.clear()
    for module in (relax_module, energy_module):
        monkeypatch.setattr(module, "PREPARE_ONCE", int(once.movable.sum()) - 1)
    by_class = relax(splines, splines.positions, corners, excluded)
    assert len(calls) == 2 and sum(calls) == once.movable.sum()
    assert np.array_equal(by_class.ctrl, once.ctrl) and by_class.energy_after == once.energy_after
    for module in (relax_module, energy_module):
        monkeypatch.setattr(module, "PREPARE_ONCE", 1)
    compact = relax(splines, splines.positions, corners, excluded)
    assert np.array_equal(compact.ctrl, once.ctrl) and compact.energy_after == once.energy_after


def test_the_chords_of_half_counted_spans_are_the_same_from_the_members_that_have_them(monkeypatch):
    # a large step writes the spans' end points of only the members with a half-counted span
    # (next to a corner), a small one of all of them: the same energies, so the same moves
    optimized = depixelize(art(BLOB)).optimized
    splines, corners = optimized.splines, optimized.corners
    excluded, start = excluded_halves(splines, corners.nodes), corners.place(splines)
    span_tips = energy_module._span_tips
    results, written = {}, {}
    for path, few in (("all", 1 << 10), ("some", 0)):
        sizes: list[int] = []  # members whose end points are written, call by call
        monkeypatch.setattr(energy_module, "SPANS_OF_FEW", few)
        monkeypatch.setattr(energy_module, "_span_tips", lambda *a, sizes=sizes: sizes.append(a[-1].shape[1])
                            or span_tips(*a))
        results[path], written[path] = relax(splines, start, corners.nodes, excluded), sum(sizes)
    assert 0 < written["some"] < written["all"]
    assert np.array_equal(results["some"].ctrl, results["all"].ctrl)
    assert results["some"].energy_after == results["all"].energy_after


# --- the energy of a slot ---------------------------------------------------------------------------

def test_a_slots_energy_changes_as_the_total_energy_does_whichever_halves_count():
    # E_s of a span whose halves both count is weighed as one turn (d0 to d1), of a span with
    # one half counted as that half, of a span with none as zero: between two trials of a
    # slot, its energy changes by what the whole drawing's energy (half by half) changes by
    splines = depixelize(art(STEP)).optimized.splines
    rng = np.random.default_rng(5)
    excluded = rng.uniform(size=(splines.n_slots, 2)) < 0.4
    model = Energy(splines, excluded)
    anchor = splines.controls_for(splines.positions)
    ctrl = anchor.copy()
    movable = np.flatnonzero(~splines.is_end())
    ctrl[movable] += rng.uniform(-0.2, 0.2, (movable.size, 2))
    group = model.prepare(movable)
    counted = group.keep.sum(axis=0)[..., 0]  # (3, M): halves counted of the spans before, own, after
    assert {0.0, 1.0, 2.0} <= set(counted.ravel().tolist())
    offsets = rng.uniform(-0.2, 0.2, (movable.size, 4, 2))
    energy = model.energy(ctrl, anchor, group, ctrl[movable][:, None] + offsets)
    for i, slot in enumerate(movable):
        total = []
        for offset in offsets[i]:
            moved = ctrl.copy()
            moved[slot] += offset
            total.append(model.total(moved, anchor))
        assert energy[i] - energy[i, 0] == pytest.approx(np.array(total) - total[0], abs=1e-9)


# --- the rounds: what every slot tries, who moves, how far ----------------------------------------

BLOB = """
..........
...####...
..######..
.########.
.#######..
..#####...
...###....
..........
"""


def test_the_pattern_of_trials_is_its_own_image_under_the_symmetries_of_the_square():
    # mirrored in x, in y, or turned a quarter, the four offsets are the same four, exactly
    offsets = {tuple(p) for p in PATTERN.T.tolist()}
    assert len(offsets) == 4 and all(np.hypot(*p) == pytest.approx(1.0) for p in offsets)
    for image in ({(-x, y) for x, y in offsets}, {(x, -y) for x, y in offsets}, {(-y, x) for x, y in offsets}):
        assert image == offsets
    assert TRIALS == 1 + 4 + 2 * CANDIDATES == 7


def test_the_candidates_lie_on_the_neighbours_chord():
    # a member at (1, 1) between a = (0, 0) and b = (2, 0), home at (1.5, 0.5): home projected
    # onto the chord; beyond its ends, its ends; the same numbers with a and b swapped
    around = np.zeros((7, 2, 1, 1))
    around[A_ROW, :, 0, 0], around[MEMBER_ROW, :, 0, 0], around[B_ROW, :, 0, 0] = (0.0, 0.0), (1.0, 1.0), (2.0, 0.0)
    home = np.array([1.5, 0.5]).reshape(2, 1, 1)
    assert candidates(around, home, np.empty((2, 1, CANDIDATES)))[:, 0].T.tolist() == [[1.5, 0.0]]
    far = np.array([-3.0, 2.0]).reshape(2, 1, 1)
    around[MEMBER_ROW, :, 0, 0] = (5.0, 1.0)
    assert candidates(around, far, np.empty((2, 1, CANDIDATES)))[:, 0].T.tolist() == [[0.0, 0.0]]
    rng = np.random.default_rng(4)
    around = rng.uniform(-3, 3, (7, 2, 50, 1))
    home = rng.uniform(-3, 3, (2, 50, 1))
    swapped = around.copy()
    swapped[[A_ROW, B_ROW]] = around[[B_ROW, A_ROW]]
    assert np.array_equal(candidates(around, home, np.empty((2, 50, CANDIDATES))),
                          candidates(swapped, home, np.empty((2, 50, CANDIDATES))))
    # every trial of a member: staying, the pattern at its radius, the candidates and half-way to them
    every = trials(around[:, :, :1], home[:, :1], np.array([0.25]))[:, 0].T
    here = around[MEMBER_ROW, :, 0, 0]
    assert every[0].tolist() == here.tolist() and np.hypot(*(every[1:5] - here).T) == pytest.approx(0.25)
    assert every[5 + CANDIDATES:] == pytest.approx((every[5:5 + CANDIDATES] + here) / 2)


def test_each_slot_moves_its_share_of_the_way():
    # one open curve of nine slots (ends 0 and 8): a slot alone in its neighbourhood moves all
    # the way, three in a row of equal gains a third each, two a half; the shares of any three
    # consecutive slots add up to at most 1; the curve read the other way gives the same shares
    prev, nxt = np.arange(-1, 8), np.append(np.arange(1, 9), -1)
    gains = np.array([0.0, 3.0, 0.0, 0.0, 0.0, 2.0, 2.0, 2.0, 0.0])
    share = shares(gains, prev, nxt)
    assert share.tolist() == pytest.approx([0, 1, 0, 0, 0, 1 / 3, 1 / 3, 1 / 3, 0])
    gains = np.array([0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 4.0, 1.0, 0.0])
    share = shares(gains, prev, nxt)
    assert share[1] == share[2] == 0.5 and share[6] == pytest.approx(0.8) and share[7] == pytest.approx(0.2)
    for g in np.random.default_rng(1).uniform(0, 1, (20, 9)) * (np.random.default_rng(2).uniform(size=(20, 9)) < 0.6):
        share = shares(g, prev, nxt)
        assert (share[:-2] + share[1:-1] + share[2:] <= 1 + 1e-12).all() and ((share > 0) == (g > 0)).all()
        assert np.array_equal(shares(g[::-1].copy(), prev, nxt)[::-1], share)
    # around a closed curve too (slot 0 follows slot 8)
    closed = shares(np.array([1.0, 0, 0, 0, 0, 0, 0, 0, 1.0]), np.roll(np.arange(9), 1), np.roll(np.arange(9), -1))
    assert closed[0] == closed[8] == 0.5


def test_a_slot_on_a_mirror_axis_stays_on_it():
    # a symmetric bump: the slot at its top is tied between mirror-image trials; it takes their
    # mean (or stays), so it never leaves the axis x = 4, and the drawing stays symmetric
    img = art("""
    ........
    ...##...
    ..####..
    .######.
    ########
    """)
    opt = depixelize(img).optimized
    q = opt.splines.cells.nodes / 4.0
    mirror = {tuple(p): i for i, p in enumerate(q.tolist())}
    on_axis = np.flatnonzero(q[:, 0] == 4.0)
    assert np.abs(opt.positions[on_axis, 0] - 4.0).max() < 1e-9
    moved = np.flatnonzero(np.abs(opt.positions - opt.initial).max(axis=1) > 1e-6)
    assert moved.size
    for i in moved:
        j = mirror[(8.0 - q[i, 0], q[i, 1])]
        assert opt.positions[j] == pytest.approx([8.0 - opt.positions[i, 0], opt.positions[i, 1]], abs=1e-9)


def ghost_case() -> tuple[SplineSet, np.ndarray, np.ndarray, np.ndarray]:
    """The ghost fixture's curves cut at their corners, its corner nodes, the halves left out
    and the start (no T-junction: no end moves with a slot)."""
    optimized = depixelize(load_image(FIXTURES / "ghost.png")).optimized
    splines, corners = optimized.splines, optimized.corners
    assert splines.snap_pairs()[0].size == 0
    return splines, corners.nodes, excluded_halves(splines, corners.nodes), optimized.initial


def test_only_slots_whose_trials_changed_are_weighed_again(monkeypatch):
    # every round is recorded (its members, their radius and whether each moved): after the
    # first, the slots weighed are exactly the movable ones within two slots along their curve
    # of a slot that moved, and those whose radius shrank because they stayed; a slot that
    # stays halves its radius down to MIN_RADIUS; the rounds stop when none is left to weigh
    splines, corners, excluded, start = ghost_case()
    rounds: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    best = relax_module._best

    def spy(model, ctrl, anchor, group, radius, near, params):
        target, gain = best(model, ctrl, anchor, group, radius, near, params)
        rounds.append((group.members.copy(), radius.copy(), gain > 0))
        return target, gain

    monkeypatch.setattr(relax_module, "_best", spy)
    result = relax(splines, start, corners, excluded, Params(iterations=100))
    prev, nxt = splines.neighbours()

    def within_two(slots: set[int]) -> set[int]:
        near = set(slots)
        for _ in range(2):
            near |= {int(n) for s in near for n in (prev[s], nxt[s]) if n >= 0}
        return near

    movable = set(np.flatnonzero(result.movable).tolist())
    assert set(rounds[0][0].tolist()) == movable and (rounds[0][1] == Params().radius).all()
    radius = dict.fromkeys(movable, Params().radius)
    for (members, size, went), (after, _, _) in zip(rounds, rounds[1:]):
        assert [radius[m] for m in members.tolist()] == size.tolist()
        shrunk = set()
        for m, moved in zip(members.tolist(), went.tolist()):
            if not moved and radius[m] > relax_module.MIN_RADIUS:
                radius[m] = max(radius[m] / 2, relax_module.MIN_RADIUS)
                shrunk.add(m)
        assert set(after.tolist()) == (within_two(set(members[went].tolist())) & movable) | shrunk
    assert 3 < len(rounds) < 100 and len(result.rounds) <= len(rounds)


def test_each_rounds_moves_are_recorded_to_walk_them_back():
    # Relaxed.rounds holds, round by round, the nodes that moved and their places before: undone
    # from the last round to the first, they give the start again
    splines, corners, excluded, start = ghost_case()
    result = relax(splines, start, corners, excluded)
    positions = start.copy()
    positions[splines.curve_nodes[result.movable]] = result.ctrl[result.movable]
    assert len(result.rounds) >= 3
    for moves in reversed(result.rounds):
        assert not np.array_equal(positions[moves.nodes], moves.before)
        positions[moves.nodes] = moves.before
    assert np.array_equal(positions, start)


def test_the_revert_walks_a_bad_cells_nodes_back_one_round_at_a_time():
    # a node pushed past a pixel centre in a recorded round, and a node far away nudged in a
    # later one: the revert puts the pushed node back where it was before its push (passing
    # over the later round, in which it did not move), not at its start; the centre is inside
    # its cell again and the far node keeps its nudge
    splines, corners, excluded, start = ghost_case()
    result = relax(splines, start, corners, excluded)
    positions = start.copy()
    positions[splines.curve_nodes[result.movable]] = result.ctrl[result.movable]
    slot = int(np.flatnonzero(result.movable)[3])
    node = int(splines.curve_nodes[slot])
    cells = splines.cells
    pixel = cells.edge_pixels[splines.slot_edges[slot]]
    pixel = int(pixel[pixel >= 0][0])
    centre = np.array([pixel % cells.shape[1] + 0.5, pixel // cells.shape[1] + 0.5])
    pushed = positions.copy()
    pushed[node] = 2 * centre - positions[node]  # past the centre: its curve crosses it
    wanted = np.arange(cells.shape[0] * cells.shape[1]) == pixel
    assert centre_clearance(splines.vector_image(pushed), pixels=wanted)[pixel] < 0
    curve = splines.curve_nodes[result.movable]
    far = int(curve[np.argmax(np.abs(pushed[curve] - centre).max(axis=1))])
    pushed[far] += [0.01, 0.0]
    moves = [*result.rounds, relax_module.Moves(np.array([node]), positions[[node]]),
             relax_module.Moves(np.array([far]), positions[[far]])]
    back, _ = keep_centres_inside(splines, start, pushed, 0.075, 12, moves=moves)
    assert np.array_equal(back[node], positions[node])
    assert np.array_equal(back[far], pushed[far])
    assert centre_clearance(splines.vector_image(back), pixels=wanted)[pixel] > 0.075
    # with no rounds recorded the nodes around the cell go back to their start
    back, _ = keep_centres_inside(splines, start, pushed, 0.075, 12)
    assert np.array_equal(back[node], start[node])


# --- switches, end to end -------------------------------------------------------------------------

def test_without_corner_patterns_the_square_is_rounded():
    img = np.full((12, 12, 4), 255, np.uint8)
    img[2:10, 2:10, :3] = 0
    result = depixelize(img, Params(corner_patterns=False))
    opt = result.optimized
    assert not opt.corners.nodes.any()
    assert opt.splines is result.splines  # nothing to cut
    rendered = render_rgba(to_svg(result.vector), width=96, height=96)
    assert (rendered[int(2.15 * 8), int(2.15 * 8), :3] > 128).all(), "the corner should be cut"
    with_corners = render_rgba(to_svg(depixelize(img).vector), width=96, height=96)
    assert (with_corners[int(2.15 * 8), int(2.15 * 8), :3] < 32).all()


def test_without_tie_break_a_tied_crossing_loses_both_diagonals():
    # the block [. r / r .] at the top right: the curve vote favours the white diagonal
    # (+1), the sparse vote the red one (-1): a tie. Red is the rarer colour around it.
    img = art("""
    ..r
    #r.
    ###
    """)
    red = [2, 4]  # flat pixel indices of the two red pixels
    for tie_break, joined in ((True, True), (False, False)):
        result = depixelize(img, Params(tie_break=tie_break))
        res = result.resolution
        assert res.ambiguous[0, 1] and res.curve_vote[0, 1] + res.sparse_vote[0, 1] == 0
        assert res.graph.diag_anti[0, 1] == joined and not res.graph.diag_main[0, 1]
        labels = faces(result.cells)
        assert (labels[red[0]] == labels[red[1]]) == joined
        assert centre_clearance(result.vector).min() > 0  # the whole pipeline ran and holds


def test_bezier_evaluate_matches_the_bernstein_form():
    # the shared evaluator (bspline.evaluate), against an independent de Casteljau
    p = np.random.default_rng(1).uniform(-3, 3, (5, 3, 2))
    t = np.linspace(0, 1, 7)[:, None, None]
    a, b = p[:, 0] + t * (p[:, 1] - p[:, 0]), p[:, 1] + t * (p[:, 2] - p[:, 1])
    assert np.allclose(evaluate(p[:, 0], p[:, 1], p[:, 2], t), a + t * (b - a), atol=1e-12)
