"""Thin lenses are drawn below the contrasting face they border (depixel/svg/lenses.py).

A grey pixel at the cut corner of a red ring on white comes out of the relaxation as a lens
a quarter of a pixel wide. Drawn after the red (white, red, grey), the red lies under it and
cannot stop short of its edge with the white near its tips, where the red shows through the
lens's anti-aliased edge; drawn before the red (white, grey, red), the red anti-aliases its
own edge and the error scales with grey against white, under the judge's threshold.
"""
from __future__ import annotations

import numpy as np
from conftest import art
from test_insets import threads

from depixel import depixelize, to_svg
from depixel.svg import lenses
from depixel.svg.outlines import build_outlines
from depixel.svg.stacking import FaceTopology

#: a red ring round orange on white, its four corners grey pixels cut off by the ring's
#: diagonal links (sbm4_01's shoulder, four times)
RING = """
    wwwwwwwwwww
    wwwgrrrgwww
    wwwrooorwww
    wwwrooorwww
    wwwrooorwww
    wwwgrrrgwww
    wwwwwwwwwww
"""
RING_COLOURS = {"w": (248, 248, 248, 255), "g": (168, 184, 168, 255), "r": (224, 0, 0, 255),
                "o": (248, 200, 112, 255)}
GREY, RED = (168, 184, 168), (224, 0, 0)


def _ring() -> np.ndarray:
    return art(RING, RING_COLOURS)


def test_the_grey_corners_are_thin_lenses_and_nothing_else_is():
    vector = depixelize(_ring()).vector
    topo = FaceTopology(vector)
    thin = lenses.thin_lenses(vector, topo.entry_ptr, topo.entry_from, topo.entry_to, topo.entry_edge)
    colours = {tuple(c) for c in topo.face_rgba[thin, :3].tolist()}
    assert thin.sum() == 4 and colours == {GREY}


def test_a_thin_lens_is_drawn_below_the_contrasting_face_and_shows_no_thread():
    image = _ring()
    vector = depixelize(image).vector
    outlines = build_outlines(vector)
    order = [tuple(c) for c in outlines.rgba[:, :3].tolist()]
    assert max(i for i, c in enumerate(order) if c == GREY) < order.index(RED), order
    assert threads(image, to_svg(vector)) == 0


def test_without_the_lens_rule_the_red_shows_through_the_lenses(monkeypatch):
    """The behaviour broken on purpose (no face is a lens): the red is drawn first and shows
    at the lenses' tips (8 render pixels at 8x)."""
    monkeypatch.setattr(lenses, "THIN", -1.0)
    image = _ring()
    vector = depixelize(image).vector
    order = [tuple(c) for c in build_outlines(vector).rgba[:, :3].tolist()]
    assert order.index(RED) < order.index(GREY)
    assert threads(image, to_svg(vector)) > 4


def _pairs(edges: list[tuple[int, int]]) -> np.ndarray:
    return np.array(edges + [(b, a) for a, b in edges], np.int32)


def test_a_lens_moves_just_before_its_second_neighbour_only_when_it_helps():
    """Faces 0 X (white), 1 S (black), 2 Q (grey lens between them), 3 another face after S:
    Q goes between X and S. Not when Q is no nearer X in colour, S is too large, or S's
    colour is too near X's."""
    order = np.array([0, 1, 3, 2])
    pairs = _pairs([(2, 0), (2, 1), (0, 1), (1, 3)])
    lens = np.array([False, False, True, False])
    group = np.full(4, -1)
    rgb = np.array([[255, 255, 255], [0, 0, 0], [190, 190, 190], [40, 90, 200]])
    opaque = np.ones(4, bool)
    area = np.array([100, 10, 1, 5])
    assert lenses.lenses_before(order, pairs, lens, group, rgb, opaque, area).tolist() == [0, 2, 1, 3]
    dark = rgb.copy()
    dark[2] = (60, 60, 60)  # nearer S than X
    assert lenses.lenses_before(order, pairs, lens, group, dark, opaque, area).tolist() == [0, 1, 3, 2]
    big = area.copy()
    big[1] = lenses.SMALL + 1
    assert lenses.lenses_before(order, pairs, lens, group, rgb, opaque, big).tolist() == [0, 1, 3, 2]
    soft = rgb.copy()
    soft[1] = (255 - lenses.CONTRAST + 1,) * 3
    assert lenses.lenses_before(order, pairs, lens, group, soft, opaque, area).tolist() == [0, 1, 3, 2]


def test_a_lens_goes_before_the_whole_smooth_group_of_its_face():
    """S (1) shares a smooth group with face 3, drawn just before it: Q goes before both, so
    the group stays together; if X is in that group too, Q stays."""
    order = np.array([0, 3, 1, 2])
    pairs = _pairs([(2, 0), (2, 1), (0, 1), (1, 3)])
    lens = np.array([False, False, True, False])
    rgb = np.array([[255, 255, 255], [0, 0, 0], [190, 190, 190], [20, 20, 20]])
    opaque, area = np.ones(4, bool), np.array([100, 10, 1, 5])
    group = np.array([-1, 0, -1, 0])
    assert lenses.lenses_before(order, pairs, lens, group, rgb, opaque, area).tolist() == [0, 2, 3, 1]
    group = np.array([0, 0, -1, 0])
    assert lenses.lenses_before(order, pairs, lens, group, rgb, opaque, area).tolist() == [0, 3, 1, 2]
