"""Stage 4 — paper §3.3 — spline extraction: curves along the visible edges, T-junctions,
the exact Bézier form of the B-splines, end snapping, shape counts, determinism."""
from __future__ import annotations

import re
from functools import cache

import numpy as np
import pytest
import svgpath
from conftest import FIXTURES, art, corpus_pngs, needs_corpus
from scipy.interpolate import BSpline

from depixel.colour import rgb_to_yuv
from depixel.curves.bspline import between_curve_points, joint, midpoint, split_half
from depixel.curves.splines import SplineSet
from depixel.graph.similarity import similar
from depixel.optimize.fidelity import centre_clearance
from depixel.params import Params
from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.svg.writer import to_svg

# The same 6×6 T: block A top-left, block B top-right, C across the bottom. The junction is
# the image centre, lattice point (3, 3) = (12, 12) in quarter pixels, whatever symmetry
# of the square is applied; its visible edges go up (A|B), left (A|C) and right (B|C).
T_JUNCTION = """
AAABBB
AAABBB
AAABBB
CCCCCC
CCCCCC
CCCCCC
"""
RED = (200, 40, 40, 255)
PINK = (255, 110, 110, 255)  # visibly different from RED (ΔY ≈ 59 > 48) but YUV distance ≈ 66 ≤ 100
WHITE = (255, 255, 255, 255)
BLUE = (30, 60, 220, 255)
GREEN = (40, 200, 60, 255)


def symmetries(rgba: np.ndarray) -> list[np.ndarray]:
    """The 8 images of the square's symmetry group."""
    out = []
    for k in range(4):
        turned = np.rot90(rgba, k)
        out += [np.ascontiguousarray(turned), np.ascontiguousarray(turned.transpose(1, 0, 2))]
    return out


def node_at(splines: SplineSet, quarter_xy: tuple[int, int]) -> int:
    found = np.flatnonzero((splines.cells.nodes == quarter_xy).all(axis=1))
    assert found.size == 1, f"no single node at {quarter_xy}"
    return int(found[0])


def curve_slice(splines: SplineSet, c: int) -> slice:
    return slice(int(splines.curve_ptr[c]), int(splines.curve_ptr[c + 1]))


def curve_pixels(splines: SplineSet, c: int) -> np.ndarray:
    """(K, 2) the pixels on the (left, right) of each edge of curve c."""
    edges = splines.slot_edges[curve_slice(splines, c)]
    return splines.cells.edge_pixels[edges[edges >= 0]]


def colour_distance(a, b) -> tuple[float, bool]:
    """YUV distance and hqx similarity of two RGBA colours."""
    ya, yb = rgb_to_yuv(np.array([a], np.uint8)), rgb_to_yuv(np.array([b], np.uint8))
    alpha = np.array([a[3]], np.uint8)
    return float(np.linalg.norm(ya - yb)), bool(similar(ya, alpha, yb, alpha, Params())[0])


# --- independent evaluation of the curves ---------------------------------------------------

def bspline(ctrl: np.ndarray, closed: bool) -> tuple[BSpline, np.ndarray]:
    """The uniform quadratic B-spline of control points ``ctrl`` (K, 2), periodic when closed
    and clamped (end points interpolated) when open, built by scipy from its knot vector —
    and the parameter u of the curve point belonging to each control point (S_j)."""
    k = len(ctrl)
    if closed:
        extended = np.concatenate([ctrl[-1:], ctrl, ctrl[:2]])  # wraps: segment j uses j-1, j, j+1
        knots = np.arange(k + 6, dtype=np.float64)
        u = np.arange(k + 1) + 2.5  # middle of segment j (one more: back at the start)
        return BSpline(knots, extended, 2), u
    knots = np.r_[0.0, 0.0, np.arange(k - 1, dtype=np.float64), k - 2.0, k - 2.0]
    u = np.r_[0.0, np.arange(1, k - 1) - 0.5, k - 2.0]
    return BSpline(knots, ctrl, 2), u


def quad(p0, p1, p2, t: np.ndarray) -> np.ndarray:
    t = t[:, None]
    return (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t**2 * p2


T9 = np.linspace(0.0, 1.0, 9)


def drawn_edge(vector, e: int) -> np.ndarray:
    """(17, 2) points of curved edge e as drawn: points[u] Q c0 c1 Q c2 points[v]."""
    u, v = vector.cells.edges[e]
    c0, c1, c2 = vector.controls[e]
    return np.concatenate([quad(vector.points[u], c0, c1, T9), quad(c1, c2, vector.points[v], T9)[1:]])


def chain_errors(splines: SplineSet, positions: np.ndarray, vector) -> tuple[float, int]:
    """Largest distance between every curved edge as drawn and the B-spline of its curve
    (scipy, from ``controls_for``) sampled at the same parameters; and the number of edges
    checked. An edge from S_j to S_{j+1} is drawn as two Béziers whose parameter maps
    linearly onto [u_j, u_{j+1}] (the de Casteljau halves)."""
    ctrl = splines.controls_for(positions)
    worst, checked = 0.0, 0
    for c in range(splines.n_curves):
        part = curve_slice(splines, c)
        k = part.stop - part.start
        edges, forward = splines.slot_edges[part], splines.slot_forward[part]
        if k == 2 and not splines.curve_closed[c]:  # one edge between two end points: straight
            assert not vector.curved[edges[0]]
            continue
        curve, u = bspline(ctrl[part], bool(splines.curve_closed[c]))
        for j in range(k if splines.curve_closed[c] else k - 1):
            e = edges[j]
            assert vector.curved[e], f"edge {e} of curve {c} is not drawn curved"
            expected = curve(np.linspace(u[j], u[j + 1], 17))
            got = drawn_edge(vector, e)
            got = got if forward[j] else got[::-1]
            worst = max(worst, float(np.abs(got - expected).max()))
            checked += 1
    return worst, checked


@cache
def fixture_result(name: str, stage: str):
    return depixelize(load_image(FIXTURES / name), stage=stage)


# --- curves along visible edges ---------------------------------------------------------------

def test_single_dark_pixel_gives_one_closed_curve_around_it():
    img = art("""
    .....
    .....
    ..#..
    .....
    .....
    """)
    result = depixelize(img, stage="splines")
    splines = result.splines
    assert splines.n_curves == 1 and splines.curve_closed[0]
    around = curve_pixels(splines, 0)
    dark = 2 * 5 + 2
    # every edge of the curve has the dark pixel on exactly one side
    assert ((around == dark).sum(axis=1) == 1).all()
    assert not splines.is_end().any()
    clearance = centre_clearance(result.vector)
    assert clearance[dark] > 0, f"the dark pixel's centre is outside its drawn cell ({clearance[dark]})"
    assert (clearance > 0).all()


def test_diagonal_line_gives_one_continuous_curve_on_each_side():
    img = art("""
    #.....
    .#....
    ..#...
    ...#..
    ....#.
    .....#
    """)
    n = 6
    splines = depixelize(img, stage="splines").splines
    line = {i * n + i for i in range(n)}
    touching = [c for c in range(splines.n_curves) if line & set(curve_pixels(splines, c).ravel().tolist())]
    assert len(touching) == 2, f"{len(touching)} curves along the line"
    sides = set()
    for c in touching:
        pixels = curve_pixels(splines, c)
        on_line = np.isin(pixels, list(line))
        assert (on_line.sum(axis=1) == 1).all(), "a curve edge not between the line and the background"
        # full length: the curve passes every pixel of the line, from image border to border
        assert set(pixels[on_line].tolist()) == line
        assert not splines.curve_closed[c]
        ends = splines.cells.nodes[splines.curve_nodes[[curve_slice(splines, c).start, curve_slice(splines, c).stop - 1]]]
        on_border = (ends == 0) | (ends == 4 * n)
        assert on_border.any(axis=1).all(), f"curve {c} stops inside the image at {ends.tolist()}"
        # one side only: all background pixels of this curve are above, or all below, the line
        rows, cols = np.divmod(pixels[~on_line], n)
        assert len(set(np.sign(rows - cols).tolist())) == 1
        sides.add(int(np.sign(rows[0] - cols[0])))
    assert sides == {-1, 1}


def through_and_ending(splines: SplineSet, node: int) -> tuple[int, int]:
    """At a T-junction node: the slot where a curve passes through, and where one ends."""
    at = np.flatnonzero(splines.curve_nodes == node)
    end = splines.is_end()[at]
    assert splines.through_nodes()[node]
    assert at.size == 2 and end.sum() == 1, f"node {node}: slots {at.tolist()}, ends {end.tolist()}"
    return int(at[~end][0]), int(at[end][0])


@pytest.mark.parametrize("k", range(8))
def test_t_junction_joins_the_contour_edges_over_the_shading_edge(k):
    # A, C: two reds, visibly different but close (shading edge); B: white (contours)
    distance, alike = colour_distance(RED, PINK)
    assert distance <= Params().shading_distance and not alike
    assert min(colour_distance(WHITE, RED)[0], colour_distance(WHITE, PINK)[0]) > Params().shading_distance
    img = symmetries(art(T_JUNCTION, dict(A=RED, B=WHITE, C=PINK)))[k]
    splines = depixelize(img, stage="splines").splines
    node = node_at(splines, (12, 12))
    through, ending = through_and_ending(splines, node)
    prev, nxt = splines.neighbours()
    rgba = img.reshape(-1, 4)
    white = (rgba == WHITE).all(axis=1)
    # the curve through the junction turns there (up + right) and keeps white on one side of
    # both its edges at the node; the straightest pair (left + right) would not
    for edge in (splines.slot_edges[prev[through]], splines.slot_edges[through]):
        assert white[splines.cells.edge_pixels[edge]].sum() == 1
    d0 = splines.positions[splines.curve_nodes[prev[through]]] - splines.positions[node]
    d1 = splines.positions[splines.curve_nodes[nxt[through]]] - splines.positions[node]
    assert abs(np.dot(d0, d1)) < 1e-12, "through curve should turn by 90° at the junction"
    # the ending curve is the shading edge between the reds
    edge = splines.slot_edges[ending] if splines.slot_edges[ending] >= 0 else splines.slot_edges[prev[ending]]
    assert splines.shading[edge] and not white[splines.cells.edge_pixels[edge]].any()


@pytest.mark.parametrize("k", range(8))
def test_t_junction_of_three_contours_joins_the_straightest_pair(k):
    colours = dict(A=BLUE, B=WHITE, C=GREEN)
    for a, b in ((BLUE, WHITE), (BLUE, GREEN), (WHITE, GREEN)):
        assert colour_distance(a, b)[0] > Params().shading_distance
    img = symmetries(art(T_JUNCTION, colours))[k]
    splines = depixelize(img, stage="splines").splines
    assert not splines.shading.any()
    node = node_at(splines, (12, 12))
    through, ending = through_and_ending(splines, node)
    prev, nxt = splines.neighbours()
    here = splines.positions[node]
    d0 = splines.positions[splines.curve_nodes[prev[through]]] - here
    d1 = splines.positions[splines.curve_nodes[nxt[through]]] - here
    cosine = np.dot(d0, d1) / np.linalg.norm(d0) / np.linalg.norm(d1)
    assert cosine == pytest.approx(-1.0), "the through curve should go straight on"
    # and the curve that ends there is the A|B edge, at right angles to it
    other = splines.curve_nodes[nxt[ending]] if nxt[ending] >= 0 else splines.curve_nodes[prev[ending]]
    assert abs(np.dot(splines.positions[other] - here, d0)) < 1e-12


# --- geometry -----------------------------------------------------------------------------

CHAIN_CASES = {
    "dot": art("""
    .....
    ..#..
    .....
    """),
    "t_junction": art(T_JUNCTION, dict(A=RED, B=WHITE, C=PINK)),
    "staircase": art("""
    ......
    ...###
    .#####
    ######
    """),
}


@pytest.mark.parametrize("stage", ["splines", "optimized"])
@pytest.mark.parametrize("case", [*CHAIN_CASES, "heart.png", "mushroom.png"])
def test_bezier_chain_is_exactly_the_b_spline(case, stage):
    if case in CHAIN_CASES:
        result = depixelize(CHAIN_CASES[case], stage=stage)
    else:
        result = fixture_result(case, stage)
    if stage == "splines":
        splines, positions = result.splines, result.splines.positions
    else:
        splines, positions = result.optimized.splines, result.optimized.positions
    worst, checked = chain_errors(splines, positions, result.vector)
    assert checked > 0
    assert worst < 1e-9, f"drawn curve is {worst} px off the B-spline"


def test_svg_path_commands_follow_the_b_spline():
    """Every quadratic written to the SVG (exact spline, 9 decimals, read back with an
    independent SVG path parser, ``T`` included) is a span of the B-spline or half of one:
    its samples match scipy's B-spline at the corresponding parameters. The cutout layout
    (each face's own outline: every piece of boundary, as every layout writes it); the
    stacked layout adds the insets of depixel/svg/insets.py, offsets by design
    (tests/test_insets.py)."""
    result = fixture_result("heart.png", "splines")
    splines, vector = result.splines, result.vector
    ctrl = splines.controls_for(splines.positions)
    # every span of the spline (a polynomial piece between integer knots), and its halves,
    # keyed by their rounded end points: (start, end) → (9, 2) samples
    pieces = {}
    for c in range(splines.n_curves):
        part = curve_slice(splines, c)
        k = part.stop - part.start
        closed = bool(splines.curve_closed[c])
        if k == 2 and not closed:
            continue
        curve, u = bspline(ctrl[part], closed)
        first, last = (2, k + 2) if closed else (0, k - 2)
        for i in range(first, last):
            for lo, hi in ((i, i + 0.5), (i + 0.5, i + 1), (i, i + 1)):
                pts = curve(np.linspace(lo, hi, 9))
                for seq in (pts, pts[::-1]):
                    pieces[(tuple(np.round(seq[0], 6)), tuple(np.round(seq[-1], 6)))] = seq
    svg = to_svg(vector, precision=9, simplify=0, layout="cutout")
    checked, worst = 0, 0.0
    for d in re.findall(r' d="([^"]*)"', svg):
        for subpath in svgpath.parse(d):
            for segment in subpath:
                if segment[0] != "Q":
                    continue
                _, p0, c1, p1 = segment
                key = (tuple(np.round(p0, 6)), tuple(np.round(p1, 6)))
                assert key in pieces, f"Q from {p0} to {p1} is not a span of the B-spline (or half of one)"
                worst = max(worst, float(np.abs(quad(p0, c1, p1, T9) - pieces[key]).max()))
                checked += 1
    assert checked > 20
    assert worst < 1e-8


def test_t_junction_end_lies_exactly_on_the_through_curve():
    img = art(T_JUNCTION, dict(A=RED, B=WHITE, C=PINK))
    result = depixelize(img, stage="splines")
    splines = result.splines
    node = node_at(splines, (12, 12))
    through, ending = through_and_ending(splines, node)
    ctrl = splines.controls_for(splines.positions)
    c = int(splines.slot_curve()[through])
    part = curve_slice(splines, c)
    curve, u = bspline(ctrl[part], bool(splines.curve_closed[c]))
    on_curve = curve(u[through - part.start])
    # the through curve turns here, so its point is not the node itself: snapping matters
    assert np.linalg.norm(on_curve - splines.positions[node]) > 0.1
    assert np.abs(ctrl[ending] - on_curve).max() < 1e-12
    assert np.abs(result.vector.points[node] - on_curve).max() < 1e-12


@pytest.mark.parametrize("name", ["mushroom.png", "potion_rgba.png", "leaf.png"])
def test_t_junction_ends_stay_on_their_curves_after_optimization(name):
    opt = fixture_result(name, "optimized").optimized
    splines = opt.splines
    ctrl = splines.controls_for(opt.positions)
    end = splines.is_end()
    snapped = np.flatnonzero(end & splines.through_nodes()[splines.curve_nodes])
    assert snapped.size > 0, "fixture has no T-junction"
    curve_of = splines.slot_curve()
    for p in snapped:
        node = splines.curve_nodes[p]
        q = int(np.flatnonzero((splines.curve_nodes == node) & ~end)[0])
        c = int(curve_of[q])
        part = curve_slice(splines, c)
        curve, u = bspline(ctrl[part], bool(splines.curve_closed[c]))
        gap = np.linalg.norm(ctrl[p] - curve(u[q - part.start]))
        assert gap < 1e-6, f"end at node {node} is {gap} px off the curve it meets"


# --- output -------------------------------------------------------------------------------

@needs_corpus
def test_shapes_are_far_fewer_than_pixels_on_the_corpus():
    pngs = corpus_pngs()
    sample = pngs[:: max(1, len(pngs) // 10)][:10]
    ratios = []
    for path in sample:
        rgba = load_image(path)
        svg = to_svg(depixelize(rgba, stage="splines").vector)
        ratios.append(svg.count("<path ") / (rgba.shape[0] * rgba.shape[1]))
    median = float(np.median(ratios))
    print(f"median shapes/pixels over {len(sample)} corpus sprites: {median:.4f} "
          f"(min {min(ratios):.4f}, max {max(ratios):.4f})")
    assert median < 0.25


@pytest.mark.parametrize("case", ["t_junction", "mushroom.png"])
def test_splines_stage_svg_is_deterministic(case):
    rgba = CHAIN_CASES[case] if case in CHAIN_CASES else load_image(FIXTURES / case)
    first = to_svg(depixelize(rgba.copy(), stage="splines").vector)
    second = to_svg(depixelize(rgba.copy(), stage="splines").vector)
    assert re.search(r' d="[^"]*[QqTtCc]', first)  # curves
    assert first.encode() == second.encode()


# --- the drawing against its definition, to the bit -------------------------------------------
def test_between_curve_points_is_the_spans_halves_or_the_split_bezier_to_the_bit():
    rng = np.random.default_rng(11)
    c_a, c_b, s_a, s_b = (rng.random((3, 2)) * 10 for _ in range(4))
    a_end, b_end = np.array([False, True, False]), np.array([False, False, True])  # interior, C_a end, C_b end
    mid = joint(c_a, c_b)
    start, stop = np.where(a_end[:, None], c_a, s_a), np.where(b_end[:, None], c_b, s_b)
    near_a, near_b = np.where(b_end[:, None], s_a, c_a), np.where(a_end[:, None], s_b, c_b)
    split = (a_end | b_end)[:, None]
    got = between_curve_points(mid, near_a, near_b, start, stop, split)
    # interior: the second half of C_a's span and the first half of C_b's (they meet at mid)
    second_of_a = split_half(s_a[0], c_a[0], mid[0])[1]
    first_of_b = split_half(mid[0], c_b[0], s_b[0])[0]
    assert np.array_equal(got[0], [second_of_a.p1, mid[0], first_of_b.p1])
    for e in (1, 2):  # with an end: the one Bézier (start, mid, stop) split at t = 1/2
        first, second = split_half(start[e], mid[e], stop[e])
        assert np.array_equal(got[e], [first.p1, first.p2, second.p1])
    backwards = between_curve_points(mid, near_b, near_a, start, stop, split)  # the edge stored b → a
    assert np.array_equal(backwards, got[:, ::-1])


@pytest.mark.parametrize("case", ["heart.png", "mushroom.png"])
def test_drawing_is_the_spans_of_the_control_points_to_the_bit(case):
    splines = fixture_result(case, "splines").splines
    ctrl = splines.controls_for(splines.positions)
    spans = splines.spans(ctrl)
    end = splines.is_end()
    s = np.where(end[:, None], ctrl, midpoint(*spans))
    points, edges, controls, drawn = splines.drawing(splines.positions)
    assert np.array_equal(drawn, ctrl)
    inner = ~end
    expected_points = splines.positions.copy()
    expected_points[splines.curve_nodes[inner]] = s[inner]
    assert np.array_equal(points, expected_points)
    _, nxt = splines.neighbours()
    a = np.flatnonzero((nxt >= 0) & ~(end & end[np.maximum(nxt, 0)]))
    b = nxt[a]
    assert np.array_equal(edges, splines.slot_edges[a])
    for k, (i, j) in enumerate(zip(a, b)):
        if end[i] or end[j]:
            first, second = split_half(ctrl[i] if end[i] else s[i], joint(ctrl[i], ctrl[j]),
                                       ctrl[j] if end[j] else s[j])
            trio = [first.p1, first.p2, second.p1]
        else:
            trio = [split_half(*(part[i] for part in spans))[1].p1, joint(ctrl[i], ctrl[j]),
                    split_half(*(part[j] for part in spans))[0].p1]
        trio = np.array(trio) if splines.slot_forward[i] else np.array(trio)[::-1]
        assert np.array_equal(controls[k], trio), f"edge {splines.slot_edges[i]}"


@pytest.mark.parametrize("case", ["heart.png", "mushroom.png", "chip.png"])
def test_drawings_side_by_side_are_each_drawing_to_the_bit(case):
    """Several position sets drawn in one pass (``SplineSet.drawings``) give each set's own
    drawing exactly: display points, edges, controls and the snapped control points (the
    T-junction ends snapped until every set stops moving)."""
    splines = fixture_result(case, "optimized").optimized.splines
    rng = np.random.default_rng(5)
    sets = [splines.positions + rng.normal(0, scale, splines.positions.shape) for scale in (0.0, 0.05, 0.3)]
    assert splines.snap_pairs()[0].size  # T-junction ends to snap
    together = splines.drawings(*sets)
    for one, drawn in zip(sets, together):
        alone = splines.drawing(one)
        for name, a, b in zip(alone._fields, alone, drawn):
            assert a.shape == b.shape and np.array_equal(a, b), name
            assert b.flags.c_contiguous, name
