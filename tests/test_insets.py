"""No threads where stacked shapes meet (depixel/svg/insets.py).

A shape that lies under a face drawn above it must not draw that face's edge against a face
drawn below it: renderers anti-alias every shape on its own, so the lower shape's colour
would show through the upper face's anti-aliased edge as a thin thread. Measured here as the
shared judge measures ``conflation_px``: the anti-aliased render against the exact coverage
(the same SVG drawn crisp, 8 times finer, averaged), inside the opaque art.
"""
from __future__ import annotations

import io
import re

import cairosvg
import numpy as np
import pytest
from conftest import CORPUS, art, needs_corpus
from PIL import Image

from depixel import depixelize, load_image, to_svg
from depixel.svg import insets
from depixel.svg.outlines import build_outlines

#: a red block and a white one rounded on its right side by a staircase, side by side on
#: black: the red block, drawn first (same depth, larger), lies under the white one, whose
#: top, right and bottom edges border the black drawn below both (its right side a curve,
#: whose anti-aliased pixels show a thread where the red shape runs along it)
ABUTTING = """
###########
#rrrrr..###
#rrrrr...##
#rrrrr....#
#rrrrr....#
#rrrrr...##
#rrrrr..###
###########
"""
S = 8  # render pixels per art pixel, as the judge


def _render(svg: str, width: int, height: int, crisp: bool = False) -> np.ndarray:
    if crisp:
        svg = re.sub(r"<svg\b", '<svg shape-rendering="crispEdges"', svg, count=1)
    png = cairosvg.svg2png(bytestring=svg.encode(), output_width=width, output_height=height)
    rgba = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"), dtype=np.float64)
    rgba[..., :3] *= rgba[..., 3:] / 255  # premultiplied, as coverage adds up
    return rgba


def threads(image: np.ndarray, svg: str, k: int = 8, threshold: float = 32) -> int:
    """Render pixels (S per art pixel) inside the art, away from its border, whose
    anti-aliased colour departs by more than ``threshold`` levels from the exact coverage."""
    h, w = image.shape[:2]
    aa = _render(svg, w * S, h * S)
    exact = _render(svg, w * S * k, h * S * k, crisp=True).reshape(h * S, k, w * S, k, 4).mean(axis=(1, 3))
    inner = np.zeros((h, w), bool)
    inner[1:-1, 1:-1] = True
    mask = np.kron(inner, np.ones((S, S), bool))
    return int(((np.abs(aa[..., :3] - exact[..., :3]).max(axis=-1) > threshold) & mask).sum())


def _no_insets(monkeypatch) -> None:
    """The behaviour broken on purpose: every run left where it is."""
    monkeypatch.setattr(insets.InsetGuide, "__init__", _zero_margins(insets.InsetGuide.__init__))


def _zero_margins(init):
    def wrapped(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.margin = np.zeros_like(self.margin)
    return wrapped


def test_two_abutting_shapes_over_a_third_colour_leave_no_thread():
    image = art(ABUTTING)
    svg = to_svg(depixelize(image).vector)
    assert threads(image, svg) == 0


def test_without_insets_the_lower_shape_shows_as_a_thread(monkeypatch):
    """The measure sees the thread that the insets remove (the test above, red)."""
    _no_insets(monkeypatch)
    image = art(ABUTTING)
    assert threads(image, to_svg(depixelize(image).vector)) > 20


def _alone(outlines, s: int, h: int, w: int) -> np.ndarray:
    """Coverage (0..1) of shape ``s`` drawn alone at S per art pixel."""
    from depixel.svg.writer import path_data

    d = path_data(outlines.shapes(s, s + 1), 2)[0]
    svg = (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w} {h}" width="{w}" height="{h}">'
           f'<path d="{d}"/></svg>')
    return _render(svg, w * S, h * S)[..., 3] / 255


def test_the_lower_shape_continues_under_the_upper_one_and_stops_short_of_its_other_edges():
    image = art(ABUTTING)
    h, w = image.shape[:2]
    outlines = build_outlines(depixelize(image).vector, grid=0.01)
    red = [s for s in range(len(outlines)) if tuple(outlines.rgba[s][:3]) == (220, 30, 30)]
    white = [s for s in range(len(outlines)) if tuple(outlines.rgba[s][:3]) == (255, 255, 255)]
    assert len(white) == 1 and len(red) == 1 and red[0] < white[0]
    cover = _alone(outlines, red[0], h, w)
    inside = max(int(insets.MARGIN * S) - 1, 1)  # render pixels within the margin (the fringe and more)
    # under the shared edge (x = 6) and past it, well beyond the fringe: fully covered
    assert cover[2 * S:6 * S, 5 * S:int(6.5 * S)].min() == 1.0
    # along the white block's top and bottom edges against the black, away from the corner
    # where the three colours meet: nothing within the margin
    assert cover[1 * S:1 * S + inside, 6 * S + S // 2:7 * S].max() == 0.0
    assert cover[7 * S - inside:7 * S, 6 * S + S // 2:7 * S].max() == 0.0
    # and the white block's interior is still covered (hiding the white shape shows the
    # red one there, not a hole)
    assert cover[2 * S:6 * S, 6 * S:8 * S].min() == 1.0


@pytest.mark.parametrize("mirror", [False, True])
def test_insets_turn_with_the_image(mirror):
    """The same geometry mirrored: the pulled-back outline is computed from the geometry
    alone, so a mirrored sprite gives the mirrored render (up to anti-aliasing: no render
    pixel more than 64 levels off, as shape_checks.py equivariance counts)."""
    image = art(ABUTTING)
    flipped = image[:, ::-1] if mirror else image[::-1]
    a = _render(to_svg(depixelize(image).vector), image.shape[1] * S, image.shape[0] * S)
    b = _render(to_svg(depixelize(flipped).vector), image.shape[1] * S, image.shape[0] * S)
    b = b[:, ::-1] if mirror else b[::-1]
    assert (np.abs(a - b).max(axis=-1) > 64).sum() == 0


#: four colours round one lattice point (3, 4): the red bar (drawn first: larger) lies under
#: the green and blue faces drawn above it, which meet the black backdrop (drawn below the
#: red) on either side of that point, the red face itself touching it between them
FOUR_WAY = """
#######
###r###
###r###
#ggr###
###bb##
#######
"""


def _own_face_uncovered(image: np.ndarray) -> dict[tuple[int, ...], int]:
    """Per stacked shape (its place and colour): the render pixels its own face covers
    wholly (the cutout layout's shape of that face) of which the shape covers less than
    half (rounding costs a level or two)."""
    h, w = image.shape[:2]
    vector = depixelize(image).vector
    stacked, cutout = build_outlines(vector, grid=0.01), build_outlines(vector, layout="cutout", grid=0.01)
    found = {}
    for s in range(len(stacked)):
        c = int((cutout.face == stacked.face[s]).nonzero()[0][0])
        own, shape = _alone(cutout, c, h, w), _alone(stacked, s, h, w)
        found[(s, *(int(v) for v in stacked.rgba[s][:3]))] = int(((own == 1) & (shape < 0.5)).sum())
    return found


@pytest.mark.parametrize("turn", range(4))
def test_a_shape_covers_its_own_face_where_two_pulled_back_runs_meet_round_it(turn):
    """At a point where the outline passes from a run pulled back into one upper face to a
    run pulled back into another, with the shape's own face touching the point between
    them, the outline goes back to the point: a joint of the two insets would cut the
    corner of the shape's own face (seen red: 3 render pixels of the red face uncovered,
    black showing through; on the corpus a conflation pixel each on smw_cape_mario_yoshi,
    vikings_olaf and vikings_eric)."""
    uncovered = _own_face_uncovered(np.rot90(art(FOUR_WAY), turn))
    assert set(uncovered.values()) == {0}, uncovered


@needs_corpus
def test_corpus_shapes_cover_their_own_faces():
    """smw_cape_mario_yoshi's brown outline lost a corner of its own face so (seen red)."""
    uncovered = _own_face_uncovered(load_image(CORPUS / "smw_cape_mario_yoshi.png"))
    assert set(uncovered.values()) == {0}, {k: v for k, v in uncovered.items() if v}


def _sharp_wedge(margin: float) -> tuple[np.ndarray, np.ndarray]:
    """A thin triangle (apex at the origin, 5.7°, legs of ~2 px), every side pulled back by
    ``margin``, as :func:`insets.inset_runs` draws it: its three corners moved, and the legs'
    length."""
    from depixel.svg.boundaries import LINE

    corners = np.array([[2.0, -0.1], [2.0, 0.1], [0.0, 0.0]])  # each segment ends at its corner
    nan = np.full((3, 2), np.nan)
    segments = insets.Segments(np.full(3, LINE, np.uint8), nan, nan, corners, np.array([0, 3]))
    moved, _, _ = insets.inset_runs(segments, insets.RunMarks(np.full(3, margin), nan, nan), None)
    return moved.end, np.hypot(2.0, 0.1)


def test_a_sharp_convex_corner_turns_as_far_in_as_its_legs_allow():
    """sbm4_01's grey face makes a ~12° corner over two black shapes; the black beneath is
    pulled back along both of its edges, and the nearer its joint lies to the node, the more
    black shows under the grey's anti-aliased tip (a conflation pixel, seen at 33 levels with
    a third of the leg). The bisector's point at the margin lies 2.5 px out here, past the
    legs, so the joint stops at half the leg: the most for which the joints at a line's two
    ends never cross (red with a third)."""
    moved, leg = _sharp_wedge(0.25)
    apex = moved[2]
    direction = np.array([2.0, -0.1]) / leg
    assert apex[1] == pytest.approx(0.0, abs=1e-12)  # on the bisector
    assert float(apex @ direction) == pytest.approx(leg / 2, rel=1e-9)
    depth = direction[0] * apex[1] - direction[1] * apex[0]  # from the edge, into the wedge
    assert 0 < depth < 0.25  # inside, as far from both edges as the legs allow (not the margin)
