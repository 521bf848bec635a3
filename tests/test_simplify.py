"""The SVG writer's simplification (depixel/svg/simplify.py, depixel/svg/breaks.py): what it keeps
true of the exact spline — straight runs, thin lines' width, the square's symmetries, the
curves away from an edit."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, art, needs_corpus
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from depixel import depixelize, load_image
from depixel.curves.bspline import elevate
from depixel.svg.boundaries import CUBIC, LINE, QUAD
from depixel.svg.outlines import OutlineShapes, build_outlines

T = np.linspace(0.0, 1.0, 9)


def _pieces(rgba: np.ndarray, tolerance: float, grid: float | None = None, stage: str = "splines"):
    return OutlineShapes(depixelize(rgba, stage=stage).vector, "stacked", grid, tolerance).pieces


def _cubics(start, kind, ctrl, ctrl2, end) -> np.ndarray:
    """(K, 4, 2) every segment as a cubic's control points."""
    q1, q2 = elevate(start, np.nan_to_num(ctrl), end)
    c1 = np.where((kind == QUAD)[:, None], q1, np.where((kind == CUBIC)[:, None], ctrl, start + (end - start) / 3))
    c2 = np.where((kind == QUAD)[:, None], q2, np.where((kind == CUBIC)[:, None], ctrl2, end - (end - start) / 3))
    return np.stack([start, c1, c2, end], axis=1)


def _starts(pieces) -> np.ndarray:
    start = np.roll(pieces.end, 1, axis=0)
    first = pieces.ptr[:-1][np.diff(pieces.ptr) > 0]
    start[first] = pieces.start[np.diff(pieces.ptr) > 0]
    return start


def _curve_points(pieces) -> np.ndarray:
    """(K, 9, 2) points along every segment of the pieces."""
    k = _cubics(_starts(pieces), pieces.kind, pieces.ctrl, pieces.ctrl2, pieces.end)
    s = 1 - T[:, None]
    t = T[:, None]
    return (s**3 * k[:, None, 0] + 3 * s * s * t * k[:, None, 1] + 3 * s * t * t * k[:, None, 2]
            + t**3 * k[:, None, 3])


def _same_curves(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Whether two sets of segments (points along each, :func:`_curve_points`) are the same,
    each segment of one within ``tol`` of one of the other, in either direction."""
    if a.shape != b.shape:
        return False
    if not a.size:
        return True
    from scipy.spatial import cKDTree

    def nearest(these: np.ndarray, those: np.ndarray) -> np.ndarray:
        """Each segment of ``these``: the largest coordinate difference to the nearest
        segment of ``those``, either way along it (a k-d tree under the maximum norm)."""
        flat = these.reshape(len(these), -1)
        forward = cKDTree(those.reshape(len(those), -1)).query(flat, p=np.inf)[0]
        backward = cKDTree(those[:, ::-1].reshape(len(those), -1)).query(flat, p=np.inf)[0]
        return np.minimum(forward, backward)

    return bool((nearest(a, b) <= tol).all() and (nearest(b, a) <= tol).all())


# the square's symmetries: the image's, and the map of a point of the result back
SYMMETRIES = {
    "mirror_x": (lambda a: a[:, ::-1], lambda p, h, w: np.stack([w - p[..., 0], p[..., 1]], axis=-1)),
    "mirror_y": (lambda a: a[::-1], lambda p, h, w: np.stack([p[..., 0], h - p[..., 1]], axis=-1)),
    "turn": (np.rot90, lambda p, h, w: np.stack([w - p[..., 1], p[..., 0]], axis=-1)),
}


def _equivariant(rgba: np.ndarray, tolerance: float, grid: float | None = None, tol: float = 1e-6) -> dict:
    """For each symmetry, whether the pieces of the transformed image, mapped back, are the
    image's own (``None`` where the exact spline already differs: nothing to ask then)."""
    h, w = rgba.shape[:2]

    def curves(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The points along the exact and the simplified pieces of one conversion."""
        vector = depixelize(image, stage="splines").vector
        return tuple(_curve_points(OutlineShapes(vector, "stacked", grid, t).pieces)  # type: ignore[return-value]
                     for t in (0.0, tolerance))

    own = curves(rgba)
    out = {}
    for name, (transform, back) in SYMMETRIES.items():
        exact, simple = curves(np.ascontiguousarray(transform(rgba)))
        out[name] = _same_curves(own[1], back(simple, h, w), tol) if _same_curves(own[0], back(exact, h, w), tol) \
            else None
    return out


ASYMMETRIC = art("""
    ..........
    ..###.....
    .#####....
    .######...
    .##..###..
    .##...###.
    ..##..###.
    ...######.
    ....####..
    ..........
""")
BLOB = art("""
    ............
    ....####....
    ..########..
    .##########.
    .####..####.
    .##########.
    ..########..
    ....####....
    ............
""")


@pytest.mark.parametrize("image", [ASYMMETRIC, BLOB], ids=["asymmetric", "blob"])
@pytest.mark.parametrize("tolerance", [0.25, 1.0])
def test_simplification_commutes_with_mirrors_and_quarter_turns(image, tolerance):
    """Convert the mirrored or quarter-turned image and map the curves back: the same
    simplified curves, to 1e-6 px (the cuts depend neither on where a loop's numbering
    starts nor on its direction). The blob is its own mirror image in x and y: its
    simplified curves are symmetric."""
    result = _equivariant(image, tolerance)
    assert all(v is not None for v in result.values())  # the exact spline is equivariant here
    assert all(result.values()), result


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_random_patterns_simplify_equivariantly(seed):
    """Random three-colour patterns: wherever the exact spline is equivariant, so is the
    simplified one."""
    rng = np.random.default_rng(seed)
    palette = np.array([[255, 255, 255, 255], [0, 0, 0, 255], [220, 30, 30, 255]], np.uint8)
    image = palette[rng.integers(0, 3, (7, 8))].repeat(2, axis=0).repeat(2, axis=1)  # blocks: curves, not noise
    result = _equivariant(image, 0.25)
    asked = [v for v in result.values() if v is not None]
    assume(asked)
    assert all(asked), result


EQUIVARIANT_SPRITES = ["smw_boo", "sma_toad", "win31_386", "mana_rabite", "smw_yoshi", "invaders_01",
                       "win31_keyboard"]


@needs_corpus
@pytest.mark.parametrize("name", EQUIVARIANT_SPRITES)
def test_corpus_sprites_simplify_equivariantly(name):
    """Seven corpus sprites whose exact spline is equivariant: the simplified pieces of the
    mirrored and turned sprite, mapped back, are the sprite's own, at the SVG's grid (its
    rounding of a mirrored number may differ by one step)."""
    rgba = np.asarray(load_image(CORPUS / f"{name}.png"))
    result = _equivariant(rgba, 0.25, grid=0.01, tol=0.0101)
    assert all(v is not None for v in result.values())
    assert all(result.values()), result


ONE_PIXEL_LINES = art("""
    ............
    .########...
    ...........#
    .#.........#
    .#..######.#
    .#.........#
    .#.........#
    .#..........
    ............
""")


def _straight_runs(pieces) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The runs of collinear line segments of the pieces at least one pixel long, as (start, end)."""
    start = _starts(pieces)
    runs = []
    for p in range(len(pieces)):
        a, b = int(pieces.ptr[p]), int(pieces.ptr[p + 1])
        k = a
        while k < b:
            if pieces.kind[k] != LINE:
                k += 1
                continue
            d = pieces.end[k] - start[k]
            e = k + 1
            while e < b and pieces.kind[e] == LINE:
                d2 = pieces.end[e] - start[e]
                if abs(d[0] * d2[1] - d[1] * d2[0]) > 1e-9 or d @ d2 <= 0:
                    break
                e += 1
            if np.hypot(*(pieces.end[e - 1] - start[k])) >= 1 - 1e-9:
                runs.append((tuple(start[k]), tuple(pieces.end[e - 1])))
            k = e
    return runs


@pytest.mark.parametrize("image", [ONE_PIXEL_LINES, ASYMMETRIC], ids=["lines", "asymmetric"])
@pytest.mark.parametrize("tolerance", [0.25, 2.0])
def test_straight_runs_stay_lines(image, tolerance):
    """Every straight run of the exact spline a pixel long or more (a pixel edge of two
    pixels between the curves at its ends) is drawn as the same straight line."""
    exact = _straight_runs(_pieces(image, 0.0))
    assert len(exact) >= 4
    simple = _pieces(image, tolerance)
    start = _starts(simple)
    for a, b in exact:
        on = [k for k in range(simple.kind.size) if simple.kind[k] == LINE
              and _on_segment(start[k], a, b) and _on_segment(simple.end[k], a, b)]
        covered = sum(np.hypot(*(simple.end[k] - start[k])) for k in on)
        assert covered == pytest.approx(np.hypot(b[0] - a[0], b[1] - a[1]), abs=1e-9), (a, b)


#: a diamond: its four sides 45-degree staircases, which the optimizer draws as straight
#: runs of spans (their controls rounded to the grid a hundredth off the line), 4.2 px long
DIAMOND = art("""
..........
....##....
...####...
..######..
.########.
.########.
..######..
...####...
....##....
..........
""")
#: a smaller one: its sides' straight runs are 2.8 px long
SMALL_DIAMOND = art("""
........
...##...
..####..
.######.
.######.
..####..
...##...
........
""")


@pytest.mark.parametrize("tolerance", [0.25, 1.0])
@pytest.mark.parametrize("image", [DIAMOND, SMALL_DIAMOND], ids=["diamond", "small"])
def test_a_straight_run_of_the_spline_is_one_line(image, tolerance):
    """A 45-degree staircase drawn as a straight run of the spline's spans (each within the
    grid of its chord) two pixels long or more is written as one line, and so cuts the piece:
    a curve fitted over it and the bend beyond would redraw the whole side when an edit
    moves the bend (docs/design.md, Locality of the default --simplify). The small diamond's
    runs, under 3 px, pin the 2 px."""
    exact = _pieces(image, 0.0, grid=0.01, stage="optimized")
    start = _starts(exact)
    chord = exact.end - start
    flat = (exact.kind == QUAD) & (np.abs(np.abs(chord[:, 0]) - np.abs(chord[:, 1])) < 1e-9)
    assert flat.sum() >= 8  # the sides' spans, 45 degrees each
    simple = _pieces(image, tolerance, grid=0.01, stage="optimized")
    start = _starts(simple)
    chord = simple.end - start
    lines = (simple.kind == LINE) & (np.abs(np.abs(chord[:, 0]) - np.abs(chord[:, 1])) < 1e-9)
    lengths = np.hypot(chord[lines, 0], chord[lines, 1])
    assert lines.sum() == 4 and (lengths >= 2 - 1e-6).all(), lengths  # one line a side


def _on_segment(p, a, b) -> bool:
    a, b, p = np.asarray(a), np.asarray(b), np.asarray(p)
    d, q = b - a, p - a
    return abs(d[0] * q[1] - d[1] * q[0]) <= 1e-9 and -1e-9 <= q @ d <= d @ d + 1e-9


def _outline_polylines(image: np.ndarray, tolerance: float, colour) -> list[np.ndarray]:
    """The loops of the shapes of ``colour`` as polylines, 64 points a segment."""
    out = build_outlines(depixelize(image, stage="splines").vector, "stacked", None, tolerance)
    t = np.linspace(0, 1, 64)[:, None]
    lines = []
    loops = [loop for s in np.flatnonzero((out.rgba == colour).all(axis=1)) for loop in out.loops_of(int(s))]
    for start, kind, ctrl, ctrl2, end in loops:
        starts = np.roll(end, 1, axis=0)
        starts[0] = start
        k = _cubics(starts, kind, ctrl, ctrl2, end)
        pts = ((1 - t) ** 3 * k[:, None, 0] + 3 * (1 - t) ** 2 * t * k[:, None, 1] + 3 * (1 - t) * t * t * k[:, None, 2]
               + t**3 * k[:, None, 3])
        lines.append(pts.reshape(-1, 2))
    return lines


def _extent_at(lines: list[np.ndarray], x: float, axis: int) -> float:
    """The length of the cut through the loops along the line ``coordinate[axis] == x``
    (the crossings' outermost pair)."""
    hits = []
    for pts in lines:
        a, b = pts, np.roll(pts, -1, axis=0)
        cross = (a[:, axis] - x) * (b[:, axis] - x) < 0
        t = (x - a[cross, axis]) / (b[cross, axis] - a[cross, axis])
        hits += list(a[cross, 1 - axis] + t * (b[cross, 1 - axis] - a[cross, 1 - axis]))
    return max(hits) - min(hits)


@pytest.mark.parametrize("tolerance", [0.25, 1.0])
def test_one_pixel_lines_keep_their_width(tolerance):
    """Across every inner pixel of a one-pixel line (its two end pixels are rounded), the
    simplified line is 1 ± 0.1 px wide."""
    black = COLOUR_BLACK
    lines = _outline_polylines(ONE_PIXEL_LINES, tolerance, black)
    widths = []
    # the horizontal line of row 1, columns 1-8; the vertical one of column 11, rows 2-6
    for x in np.arange(2.0, 8.0, 0.125) + 0.0625:
        widths.append(_extent_at([lines[_loop_near(lines, (x, 1.5))]], x, 0))
    for y in np.arange(3.0, 6.0, 0.125) + 0.0625:
        widths.append(_extent_at([lines[_loop_near(lines, (11.5, y))]], y, 1))
    assert np.allclose(widths, 1.0, atol=0.1), np.round(widths, 3)


COLOUR_BLACK = (0, 0, 0, 255)


def _loop_near(lines: list[np.ndarray], point) -> int:
    return int(np.argmin([np.hypot(*(pts - point).T).min() for pts in lines]))


HIGHLIGHT = art("""
    ##############
    #............#
    #bbbbbbbbbbbb#
    #bbbbbbbbbbbb#
    ##############
""")


@pytest.mark.parametrize("tolerance", [0.25, 1.0])
def test_no_s_curve_on_a_straight_highlight(tolerance):
    """A one-pixel highlight along a key (the keyboard's spacebar): no simplified curve turns
    one way and then the other, and the highlight's long edges are straight lines."""
    pieces = _pieces(HIGHLIGHT, tolerance)
    start = _starts(pieces)
    cubic = pieces.kind == CUBIC
    legs = [pieces.ctrl[cubic] - start[cubic], pieces.ctrl2[cubic] - pieces.ctrl[cubic],
            pieces.end[cubic] - pieces.ctrl2[cubic]]
    turns = [a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] for a, b in zip(legs[:-1], legs[1:])]
    assert not (turns[0] * turns[1] < -1e-9).any()
    highlight = _outline_polylines(HIGHLIGHT, tolerance, (255, 255, 255, 255))
    assert _extent_at(highlight, 7.0, 0) == pytest.approx(1.0, abs=1e-9)
    exact = _pieces(HIGHLIGHT, 0.0)
    for y in (1.0, 2.0):  # the highlight's top and bottom edges: as long a line as the exact spline's
        longest = [max(abs(b[0] - a[0]) for a, b in _straight_runs(p) if a[1] == b[1] == y) for p in (exact, pieces)]
        assert longest[1] == longest[0] >= 9


KEYS = art("""
    ##############
    #............#
    #.##..##..##.#
    #.##..##..##.#
    #............#
    ##############
""")


def test_a_two_by_two_block_keeps_the_exact_outline():
    """The 2×2 keys of a rectilinear icon: their simplified outline stays within a twentieth
    of a pixel of the exact spline (a circle would be a tenth of a pixel off)."""
    for tolerance in (0.25, 2.0):
        exact = _outline_polylines(KEYS, 0.0, COLOUR_BLACK)
        simple = _outline_polylines(KEYS, tolerance, COLOUR_BLACK)
        for centre in ((3.0, 3.0), (7.0, 3.0), (11.0, 3.0)):
            e, s = exact[_loop_near(exact, centre)], simple[_loop_near(simple, centre)]
            d = np.hypot(*(s[:, None] - e[None]).transpose(2, 0, 1)).min(axis=1)
            assert d.max() <= 0.05, (centre, d.max())


WAVE = art("""
    ..............................
    ..##....##....##....##....##..
    .####..####..####..####..####.
    ##############################
    ##############################
""")


def test_an_edit_changes_the_curves_only_near_it():
    """One pixel changed at the left end of a long wavy boundary: the simplified segments
    farther than 6 px from it are those of the unedited image, to the bit."""
    edited = WAVE.copy()
    edited[1, 2] = WAVE[0, 0]  # the first bump loses a pixel
    far = []
    for image in (WAVE, edited):
        pieces = _pieces(image, 0.25, grid=0.01)
        points = _curve_points(pieces)
        away = np.hypot(points[..., 0] - 2.5, points[..., 1] - 1.5).min(axis=1) > 6
        far.append({tuple(np.round(p, 6).ravel()) for p in points[away]})
    assert len(far[0]) >= 10
    assert far[0] == far[1]


def _outlines_counting_passes(monkeypatch, vector, budget: int):
    """Stacked outlines of ``vector`` simplified at 0.25 px with ``budget`` segments fitted
    ahead, and the number of curvefit.fit passes they took."""
    import depixel.svg.simplify as simplify

    calls = []
    real_fit = simplify.fit
    monkeypatch.setattr(simplify, "SPECULATIVE_SEGMENTS", budget)
    monkeypatch.setattr(simplify, "fit", lambda *args: calls.append(1) or real_fit(*args))
    out = build_outlines(vector, "stacked", grid=0.01, simplify=0.25)
    monkeypatch.undo()
    return out, len(calls)


@pytest.mark.parametrize("name", ["ghost.png", "mushroom.png", "potion_rgba.png"])
def test_fitting_ahead_saves_passes_and_changes_no_curve(name, monkeypatch):
    """The ranges the cutting may ask for fitted in the first pass: fewer calls of
    curvefit.fit, the same curves as a pass per level (a fit depends on its range alone)."""
    vector = depixelize(load_image(FIXTURES / name)).vector
    (ahead, passes_ahead), (level, passes_level) = (_outlines_counting_passes(monkeypatch, vector, b)
                                                    for b in (1 << 30, 0))
    for x, y in zip((ahead.kind, ahead.ctrl, ahead.ctrl2, ahead.end), (level.kind, level.ctrl, level.ctrl2, level.end)):
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")
    assert passes_ahead < passes_level or passes_level == 1  # (potion: every stretch fits at once)
