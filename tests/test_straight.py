"""Straight runs of the outline stay straight (depixel/optimize/straight.py, issue 46): the
boundaries of constant-slope pixel stripes are straight lines, and a one-pixel line whose
sides are straight runs keeps its width."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import art

from depixel.curves.bspline import flatten_edges
from depixel.optimize.straight import place_staircases, straight_runs
from depixel.params import Params
from depixel.pipeline import depixelize

#: stripe colours, dissimilar in pairs (contour edges)
PALETTE = np.array([[40, 60, 160, 255], [240, 200, 60, 255], [200, 40, 40, 255]], np.uint8)


def stripes(dy: int, dx: int, width: int, colours: int, size: int = 28) -> tuple[np.ndarray, np.ndarray]:
    """Stripes whose boundaries run dx pixels across for every dy down, ``width`` pixels thick
    along the axis across them: the RGBA image and every pixel's stripe."""
    y, x = np.mgrid[:size, :size]
    index = np.floor_divide(dy * x - dx * y, width * max(dx, dy))
    return PALETTE[np.mod(index, colours)], index


def drawn_boundaries(image: np.ndarray, index: np.ndarray, params: Params, margin: float = 5.0
                     ) -> list[np.ndarray]:
    """Points of the optimized curves (8 a curved edge, the straight edges' ends) between each
    two neighbouring stripes, ``margin`` pixels or more inside the image: one (K, 2) array
    per boundary."""
    vector = depixelize(image, params).vector
    cells = vector.cells
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    curve = flatten_edges(vector.points[u], vector.controls, vector.points[v], 4)  # (E, 9, 2)
    straight = np.stack([vector.points[u], vector.points[v]], axis=1)
    pixels = cells.edge_pixels
    inside = (pixels >= 0).all(axis=1)
    left, right = index.ravel()[np.maximum(pixels, 0)].T
    between = inside & (np.abs(left - right) == 1)
    size = image.shape[0]
    out = []
    for k in np.unique(np.maximum(left, right)[between]):
        edges = (between & (np.maximum(left, right) == k)).nonzero()[0]
        points = np.concatenate([curve[e] if vector.curved[e] else straight[e] for e in edges])
        keep = ((points >= margin) & (points <= size - margin)).all(axis=1)
        if keep.sum() >= 16:
            out.append(points[keep])
    return out


def departure(points: np.ndarray) -> float:
    """The largest distance of ``points`` (K, 2) from the line fitted to them (total least squares)."""
    centred = points - points.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][1]
    return float(np.abs(centred @ normal).max())


@pytest.mark.parametrize("dy, dx", [(2, 3), (3, 2), (1, 2), (3, 1), (1, 1)])
@pytest.mark.parametrize("width, colours", [(2, 2), (3, 3), (4, 3)])
def test_constant_slope_stripes_are_drawn_straight(dy, dx, width, colours):
    image, index = stripes(dy, dx, width, colours)
    boundaries = drawn_boundaries(image, index, Params())
    assert boundaries
    worst = max(departure(points) for points in boundaries)
    assert worst <= 0.15, f"a {dy}:{dx} stripe boundary departs {worst:.3f} px from its line"


def test_without_the_straight_runs_a_two_by_three_stripe_wobbles():
    """The bound of the test above is tight: the relaxation alone leaves the 2:3 staircase's
    waves (0.2 px; it cannot straighten a 45° run one node at a time)."""
    image, index = stripes(2, 3, 3, 3)
    worst = max(departure(points) for points in drawn_boundaries(image, index, Params(straight_runs=False)))
    assert worst > 0.15


def test_a_staircase_goes_onto_the_middle_of_its_steps():
    """The nodes of a 2:3 staircase go onto one line of slope 2/3, half-way between the pixel
    centres on its two sides (each 1/(2·√13) px from it), wherever the window starts."""
    image, index = stripes(2, 3, 3, 3)
    result = depixelize(image)
    splines = result.optimized.splines
    start = result.optimized.corners.place(splines)
    placed = place_staircases(splines, start)
    moved = (placed != start).any(axis=1).nonzero()[0]
    assert moved.size > 50
    # every moved node lies on a line 2x - 3y = c half-way between the centres on its two sides
    c = 2 * placed[moved, 0] - 3 * placed[moved, 1]
    centres = 2 * (np.arange(28)[:, None] + 0.5) - 3 * (np.arange(28)[None, :] + 0.5)  # 2x - 3y at centres
    gap = np.abs(c[:, None] - np.unique(centres)[None, :]).min(axis=1)
    assert np.allclose(gap, 0.5, atol=1e-9)  # (the centres' 2x - 3y are integers less ½)
    assert np.array_equal(place_staircases(splines, start, Params(straight_runs=False)), start)


def test_a_wavy_line_is_no_staircase():
    """A one-pixel zigzag repeats as regularly as a staircase but goes back in y: it keeps its waves."""
    image = art("""
        ..........
        .#.#.#.#..
        #.#.#.#.#.
        ..........
    """)
    result = depixelize(image)
    splines = result.optimized.splines
    start = result.optimized.corners.place(splines)
    assert np.array_equal(place_staircases(splines, start), start)


#: a one-pixel dark line (column 3) between a light one (column 2) and a black one (column 4),
#: bent diagonally onto a dark row at its top; the black line's side is one straight run
#: between two corners that diagonal links cut (at the top, the dark line's own link)
THIN = {"L": (192, 192, 192, 255), "D": (128, 128, 128, 255), "B": (0, 0, 255, 255)}
THIN_LINE = """
    ..........
    .#LLLLLLLL
    .#LLDDDDDD
    .#LD######
    .#LD#BBBBB
    .#LD#BBBBB
    .#LD#BBBBB
    .#LD#BBBBB
    .#LD#BBBBB
    .#######BB
    .......#BB
"""


def side_points(image: np.ndarray, params: Params, pixels_a: np.ndarray, pixels_b: np.ndarray) -> np.ndarray:
    """(K, 2) points of the optimized curves (9 a curved edge, the straight edges' ends) on
    the cell edges between a pixel of ``pixels_a`` and one of ``pixels_b`` (flat indices)."""
    vector = depixelize(image, params).vector
    cells = vector.cells
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    curve = flatten_edges(vector.points[u], vector.controls, vector.points[v], 8)
    straight = np.stack([vector.points[u], vector.points[v]], axis=1)
    pixels = cells.edge_pixels
    edges = (np.isin(pixels, pixels_a).any(axis=1) & np.isin(pixels, pixels_b).any(axis=1)).nonzero()[0]
    return np.concatenate([curve[e] if vector.curved[e] else straight[e] for e in edges])


def line_width(params: Params) -> np.ndarray:
    """The drawn width of the dark line of :data:`THIN_LINE` at its inner rows 4–7: the mean x of
    its right side's curve points in each row less that of its left side."""
    image = art(THIN_LINE, THIN)
    w = image.shape[1]
    dark = w * np.arange(11) + 3
    sides = [side_points(image, params, dark, w * np.arange(11) + column) for column in (2, 4)]  # left, right
    width = []
    for row in range(4, 8):
        xs = [side[(side[:, 1] > row + 0.1) & (side[:, 1] < row + 0.9), 0].mean() for side in sides]
        width.append(xs[1] - xs[0])
    return np.array(width)


def test_a_one_pixel_line_between_straight_runs_keeps_its_width():
    width = line_width(Params())
    assert np.abs(width - 1.0).max() <= 0.1, width


def test_without_the_straight_runs_the_one_pixel_line_tapers():
    """The relaxation alone tilts the black line's straight side between its two cut corners
    (0.87 to 1.13 px)."""
    width = line_width(Params(straight_runs=False))
    assert width.max() - width.min() > 0.2, width


def test_a_node_stays_inside_a_straight_run_that_goes_on_or_reaches_its_curve_end():
    """On a rounded blob, only the middle of its 8 px top and bottom edges has 4 px of the run
    each way: the rest of the outline is relaxed. The black line's side in :data:`THIN_LINE`
    is one run to both its curve's ends (two cut corners): kept."""
    image = art("""
        ....................
        ......##########....
        ....##############..
        ...################.
        ...################.
        ....##############..
        ......##########....
        ....................
    """)
    splines = depixelize(image).optimized.splines
    q = splines.cells.nodes / 4.0
    assert sorted(map(tuple, q[straight_runs(splines)].tolist())) == [(11.0, 1.0), (11.0, 7.0)]
    assert not straight_runs(splines, Params(straight_runs=False)).any()
    splines = depixelize(art(THIN_LINE, THIN)).optimized.splines
    q = splines.cells.nodes / 4.0
    side = (q[:, 0] == 4.0) & (q[:, 1] >= 4.0) & (q[:, 1] <= 8.0)  # the black line's left side
    assert straight_runs(splines)[side].all()


#: a one-pixel light line (row 3) under a black one (row 2) that bends up diagonally at
#: column 12 onto dark pixels, where the light line's top side goes on against dark grey: a
#: T-junction at (12, 3) on a straight side (win31_setup's box, cut down)
JUNCTION = {"a": (192, 192, 192, 255), "b": (255, 255, 255, 255), "c": (128, 128, 128, 255), "d": (0, 0, 0, 255)}
JUNCTION_LINE = """
    aabbbbbbbaaccdddcc
    ccaaaaaaaaacdccacc
    ddddddddddddccacca
    ccaaaaaaaaaaaaccca
    aabbbbbbbbbbbccccc
    ccaaaaaaaaaaaccccc
"""


def light_line_top(params: Params) -> np.ndarray:
    """The highest point (least y) of the light line's top side in each of its columns 2–11."""
    image = art(JUNCTION_LINE, JUNCTION)
    w = image.shape[1]
    points = side_points(image, params, 3 * w + np.arange(2, 14), 2 * w + np.arange(w))
    return np.array([points[(points[:, 0] > x) & (points[:, 0] < x + 1), 1].min() for x in range(2, 12)])


def test_a_straight_side_stays_straight_up_to_a_t_junction_where_a_curve_bends_off_it():
    """The black line's bottom side bends up at (12, 3) while the light line's top side goes
    on straight past it: the junction node is kept, so the light line keeps its width up to
    it. Without that (red: ``_junction_slots`` returning nothing) the relaxation rounded the
    bend from (12, 3) back over the last column, 0.19 px up."""
    top = light_line_top(Params())
    assert np.abs(top - 3.0).max() <= 0.1, top
    splines = depixelize(art(JUNCTION_LINE, JUNCTION)).optimized.splines
    q = splines.cells.nodes / 4.0
    assert straight_runs(splines)[(q[:, 0] == 12.0) & (q[:, 1] == 3.0)].all()


def test_without_the_junction_rule_the_side_bends_before_the_junction(monkeypatch):
    from depixel.optimize import straight

    monkeypatch.setattr(straight, "_junction_slots", lambda w, branch, params: w.slots[:0])
    top = light_line_top(Params())
    assert np.abs(top - 3.0).max() > 0.15, top
