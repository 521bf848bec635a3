"""Issue 46, items 2 and 3: the smooth shading draws only colours the art shows there.

* No halo: a shaded region's bands continue under a shape drawn on top (the stacked layout),
  and the SVG's blur must not pull that hidden colour out around the shape.
* No glow: the backdrop (the corners' colour joined to the border) never blends with the
  art, in the SVG's filter nor in the PNG renderer, however similar their colours."""
from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import art

from depixel import depixelize
from depixel.prepare.backdrop import backdrop_mask
from depixel.render.shading import render_smooth
from depixel.svg.outlines import outline_shapes
from depixel.svg.writer import to_svg

resvg_py = pytest.importorskip("resvg_py")

SCALE = 8
#: a black outline with a dark grey band (|ΔY| = 48: similar, one smooth group), a pink
#: shape on top; the grey band lies under the whole shape, black around most of it
SHOE = {"K": (0, 0, 0, 255), "G": (48, 48, 48, 255), "P": (248, 48, 200, 255)}
SHOE_ART = """
KKKKKKKKKKKKKK
KKKKKKKKKKKKKK
KKKKPPPPKKKKKK
KKKPPPPPPKKKKK
KKKPPPPPPKKKKK
KKKPPPPPPGGGGG
KKKKPPPPGGGGGG
KKKKKKKKKGGGGG
KKKKKKKKKGGGGG
KKKKKKKKKGGGGG
"""
#: a dark grey art on a similar grey-blue backdrop (|ΔY| = 30: one region), white inside it
BACKDROP = {"B": (90, 99, 109, 255), "S": (60, 69, 79, 255), "W": (255, 255, 255, 255)}
BACKDROP_ART = """
BBBBBBBBBBBB
BBBBBBBBBBBB
BBBBBBBBBBBB
BBBSSSSSSBBB
BBBSSWWSSBBB
BBBSSWWSSBBB
BBBSSSSSSBBB
BBBBBBBBBBBB
BBBBBBBBBBBB
BBBBBBBBBBBB
"""


def resvg(svg: str) -> np.ndarray:
    from PIL import Image

    png = bytes(resvg_py.svg_to_bytes(svg_string=svg, zoom=SCALE))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(np.int64)


def test_no_ring_of_the_hidden_band_around_a_shape_on_top():
    """The grey band continues under the pink shape, but the black around the shape stays
    black in resvg (no grey ring pulled out by the blur) up to the shape's anti-aliased
    edge, which lies on the group's own colour (no thread of what is beneath the group)."""
    rgba = art(SHOE_ART, SHOE)
    vector = depixelize(rgba).vector
    shapes = outline_shapes(vector, "stacked")
    colours = [tuple(c) for c in shapes.rgba.tolist()]
    group = dict(zip(colours, shapes.group.tolist()))
    assert group[SHOE["K"]] == group[SHOE["G"]] >= 0 and group[SHOE["P"]] == -1
    assert colours.index(SHOE["G"]) < colours.index(SHOE["P"])  # the band lies beneath the shape
    svg = to_svg(vector)
    got, flat = resvg(svg), resvg(to_svg(vector, shading="flat"))
    from scipy.ndimage import binary_dilation

    left = np.zeros(got.shape[:2], bool)
    left[:, : 6 * SCALE] = True  # three pixels or more from the grey band
    black = (flat == (0, 0, 0, 255)).all(axis=2) & left
    some_pink = (flat[..., 0] > 0) & left
    ring = black & binary_dilation(some_pink, np.ones((7, 7), bool))
    assert ring.sum() > 200
    assert got[ring][:, :3].max() <= 8, got[ring][:, :3].max()  # black (a grey ring: 10-20 levels)
    # on the shape's anti-aliased edge the colours are pink over black and opaque (nothing
    # beneath the group shows through)
    edge = some_pink & (flat[..., 0] < 240)
    assert edge.sum() > 20
    assert got[edge][:, 3].min() == 255
    mix = got[edge][:, :3].astype(float)
    t = mix[:, 0] / 248.0  # the share of pink, by the red channel
    assert np.abs(mix - t[:, None] * np.array(SHOE["P"][:3])).max() <= 6
    assert "<mask " in svg and 'xlink:href="#shape-f830c8"' in svg


def test_backdrop_mask_is_the_border_connected_corner_colour():
    """What --transparent auto would remove: the backdrop joined to the border, not a pixel
    of its colour enclosed by the art, and nothing when the corners differ."""
    rgba = art(BACKDROP_ART.replace("WW\n", "BW\n", 1), BACKDROP)
    mask = backdrop_mask(rgba)
    assert mask[0, 0] and mask[-1, -1] and not mask[3:7, 3:9].any()
    art_box = np.pad(np.ones((4, 6), bool), ((3, 3), (3, 3)))
    assert (mask == (rgba[..., :3] == BACKDROP["B"][:3]).all(axis=2) & ~art_box).all()
    corner = rgba.copy()
    corner[0, 0] = BACKDROP["W"]
    assert not backdrop_mask(corner).any()


def test_art_does_not_glow_into_a_similar_backdrop():
    """The dark grey and the backdrop are similar (one region), yet neither renderer blends
    them: two render pixels away from the art the backdrop keeps its colour exactly, in the
    SVG (resvg) and in the PNG renderer, and the art's pixel centres keep theirs."""
    rgba = art(BACKDROP_ART, BACKDROP)
    vector = depixelize(rgba).vector
    backdrop = (rgba[..., :3] == BACKDROP["B"][:3]).all(axis=2)
    from scipy.ndimage import binary_erosion

    clear = binary_erosion(np.kron(backdrop, np.ones((SCALE, SCALE), bool)), np.ones((5, 5), bool))
    dark = (rgba[..., :3] == BACKDROP["S"][:3]).all(axis=2)
    for name, got in (("svg", resvg(to_svg(vector))), ("png", render_smooth(vector, SCALE).astype(np.int64))):
        departs = np.abs(got[..., :3] - np.array(BACKDROP["B"][:3])).max(axis=2)
        assert departs[clear].max() <= 2, (name, departs[clear].max())
        centre = got[SCALE // 2 :: SCALE, SCALE // 2 :: SCALE][..., :3]
        assert np.abs(centre[dark] - np.array(BACKDROP["S"][:3])).max() <= 2, name


#: the shoe with a white buckle inside it: the buckle borders the pink alone, so the pink
#: shape covers it whole, and the mask needs the pink's ``<use>`` alone
BUCKLE = dict(SHOE, W=(255, 255, 255, 255))
BUCKLE_ART = SHOE_ART.replace("KKKPPPPPPKKKKK\nKKKPPPPPPGGGGG", "KKKPPWWPPKKKKK\nKKKPPPPPPGGGGG", 1)


def test_a_mask_leaves_out_a_shape_inside_another_it_lists():
    """The buckle would be a second ``<use>`` (seen red when every covering shape is listed),
    and the render is the same: still no ring."""
    assert "PPWWPP" in BUCKLE_ART
    vector = depixelize(art(BUCKLE_ART, BUCKLE)).vector
    svg = to_svg(vector)
    masks = svg[svg.index("<mask "):svg.rindex("</mask>")]
    assert '-f830c8"' in masks and 'xlink:href="#shape-ffffff"' not in masks  # (the pink: an outline now)
    assert 'id="shape-ffffff"' in svg
    got, flat = resvg(svg), resvg(to_svg(vector, shading="flat"))
    black = (flat == (0, 0, 0, 255)).all(axis=2)
    black[:, 6 * SCALE:] = False
    assert got[black][:, :3].max() <= 8
