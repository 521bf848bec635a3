"""The SVG's smooth shading (paper §3.5, issue 32): the bands of a shaded region inside one
filtered group by default, the same shapes and path data as ``--shading flat``; smooth in a
renderer with filters, crisp at the contours, no colour carried across a contour."""
from __future__ import annotations

import io
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, art, fixture_pngs, needs_corpus
from robust import SVG_NS, parse

from depixel import Params, depixelize, load_image
from depixel.svg.outlines import outline_shapes
from depixel.svg.smoothgroups import CONTOUR_EDGES
from depixel.svg.stacking import FaceTopology
from depixel.svg.writer import DEFAULT_SIMPLIFY, SIGMA_RATIO, to_svg

resvg_py = pytest.importorskip("resvg_py")

LAYOUTS = ("stacked", "cutout")
INK_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
#: a tone chain: dark ~ middle ~ light (|ΔY| = 45 each), dark and light not similar (90)
CHAIN = {"D": (60, 60, 60, 255), "M": (105, 105, 105, 255), "L": (150, 150, 150, 255)}
#: the dark and the light side touch along a contour (rows 3 | 4); the middle grey links
#: them at its left end, so all three are one region
CHAIN_ART = """
DDDDDDDDDD
DDDDDDDDDD
DDDDDDDDDD
MDDDDDDDDD
LLLLLLLLLL
LLLLLLLLLL
LLLLLLLLLL
"""


def render(svg: str, width: int, height: int) -> np.ndarray:
    png = resvg_py.svg_to_bytes(svg_string=svg, width=width, height=height)
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(bytes(png))).convert("RGBA")).astype(np.int64)


def centres(svg: str, shape: tuple[int, int], scale: int = 9) -> np.ndarray:
    """(H, W, 4) the rendered colour at every pixel centre (odd scale: a render pixel on it)."""
    h, w = shape
    return render(svg, w * scale, h * scale)[scale // 2 :: scale, scale // 2 :: scale]


def flat_markup(svg: str) -> str:
    """The smooth document less its filter and its smooth groups' markup: the ``<defs>`` of
    the filters and masks (and the xlink namespace of the masks' references), each smooth
    ``<g>`` of its own and each masked ``<g>`` with their ``</g>``, and on a region's ``<g>``
    that is a smooth group the filter and the "smooth" of its label."""
    svg = re.sub(r"<defs>\n<filter .*?</defs>\n", "", svg, flags=re.DOTALL)
    svg = svg.replace(' xmlns:xlink="http://www.w3.org/1999/xlink"', "")
    lines, depth, drop = [], 0, []
    for line in svg.splitlines(keepends=True):
        if line.startswith("<g "):
            depth += 1
            if 'id="smooth-' in line or line.startswith("<g mask="):
                drop.append(depth)
                continue
            line = line.replace('inkscape:label="smooth shading #', 'inkscape:label="shading #')
            line = line.replace(' filter="url(#smooth)"', "")
        elif line.startswith("</g>"):
            depth -= 1
            if drop and drop[-1] == depth + 1:
                drop.pop()
                continue
        lines.append(line)
    return "".join(lines)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_shaded_fixture_has_the_filter_and_flat_has_none(layout):
    """The orb's six tones are one group of bands under the shared filter (blur, alpha set
    to 1, then kept to the bands' own area: SourceAlpha, the clip without new geometry);
    ``shading="flat"`` writes no filter at all."""
    vector = depixelize(load_image(FIXTURES / "orb.png")).vector
    root = parse(to_svg(vector, layout=layout))
    (blur,) = root.iter(SVG_NS + "feGaussianBlur")
    assert float(blur.get("stdDeviation")) == pytest.approx(SIGMA_RATIO * Params().shading_sigma)
    filt = {f.get("id"): f for f in root.iter(SVG_NS + "filter")}["smooth"]
    assert filt.get("color-interpolation-filters") == "sRGB"
    steps = [local for local in (e.tag.replace(SVG_NS, "") for e in filt)]
    assert steps == ["feGaussianBlur", "feComponentTransfer", "feComposite"]
    (alpha,) = filt.iter(SVG_NS + "feFuncA")
    assert alpha.get("type") == "table" and alpha.get("tableValues") == "1 1"
    (clip,) = filt.iter(SVG_NS + "feComposite")
    assert clip.get("in2") == "SourceAlpha" and clip.get("operator") == "in"
    groups = [g for g in root.iter(SVG_NS + "g") if g.get("filter") == "url(#smooth)"]
    assert len(groups) == 1
    assert groups[0].get(INK_LABEL).startswith("smooth shading #")
    fills = {p.get("fill") for p in groups[0].iter(SVG_NS + "path")}
    assert fills == {"#%02x%02x%02x" % (30 + 22 * k, 60 + 22 * k, 75 + 22 * k) for k in range(6)}
    flat = parse(to_svg(vector, layout=layout, shading="flat"))
    assert not list(flat.iter(SVG_NS + "filter"))
    assert not [e for e in flat.iter() if e.get("filter") or e.get("clip-path")]


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("path", fixture_pngs(), ids=lambda p: p.name)
def test_flat_differs_from_smooth_only_by_the_filter_and_the_groups(path, layout):
    """Removing the filter and the smooth groups' markup from the default document gives
    the flat document byte for byte: the same shapes, ids, labels and path data, in the
    same order."""
    vector = depixelize(load_image(path)).vector
    smooth, flat = to_svg(vector, layout=layout), to_svg(vector, layout=layout, shading="flat")
    assert flat_markup(smooth) == flat
    assert "filter" not in flat
    if path.name == "orb.png":  # (the shaded fixture: the test compares something; the chip's
        # dotted pins blended with its backdrop before the backdrop was kept out, issue 46)
        assert smooth != flat


def shaded_interior(rgba: np.ndarray, colours: list[tuple[int, ...]], scale: int) -> np.ndarray:
    """Render pixels (``scale`` per pixel) whose pixel and its 8 neighbours all have one of
    ``colours``: inside the shaded region, a pixel away from its contours."""
    inside = np.zeros(rgba.shape[:2], bool)
    for c in colours:
        inside |= (rgba == c).all(axis=2)
    padded = np.pad(inside, 1)
    deep = np.ones_like(inside)
    for dy in range(3):
        for dx in range(3):
            deep &= padded[dy : dy + inside.shape[0], dx : dx + inside.shape[1]]
    return np.kron(deep, np.ones((scale, scale), bool)).astype(bool)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_smooth_render_has_no_steps_inside_the_region_and_keeps_pixel_centres(layout):
    """resvg draws the orb's shading without a step of 6 levels or more between neighbouring
    render pixels inside the region (the flat bands have hundreds), and every pixel centre
    within 16 levels of the pixel's colour."""
    rgba = load_image(FIXTURES / "orb.png")
    h, w = rgba.shape[:2]
    vector = depixelize(rgba).vector
    tones = [(30 + 22 * k, 60 + 22 * k, 75 + 22 * k, 255) for k in range(6)]
    inside = shaded_interior(rgba, tones, 8)
    pairs = inside[:, 1:] & inside[:, :-1]
    steps = {}
    for shading in ("smooth", "flat"):
        svg = to_svg(vector, layout=layout, shading=shading)
        luma = render(svg, w * 8, h * 8)[..., :3].mean(axis=2)
        steps[shading] = int((np.abs(np.diff(luma, axis=1))[pairs] >= 6).sum())
    assert steps["smooth"] == 0 and steps["flat"] > 100, steps
    got = centres(to_svg(vector, layout=layout), (h, w))
    opaque = rgba[..., 3] == 255
    assert np.abs(got - rgba)[opaque].max() <= 16
    assert (got[~opaque, 3] == 0).all()


@pytest.mark.parametrize("layout", LAYOUTS)
def test_colour_does_not_cross_a_contour_in_the_svg(layout):
    """The dark and the light grey are one region through the middle grey, but a contour
    lies between them: they are smoothed in different groups, so no blur spans the contour.
    Along it the pixel centres keep their colours and the step across it stays whole."""
    rgba = art(CHAIN_ART, CHAIN)
    h, w = rgba.shape[:2]
    vector = depixelize(rgba).vector
    shapes = outline_shapes(vector, layout)
    group = dict(zip((tuple(c) for c in shapes.rgba.tolist()), shapes.group.tolist()))
    assert group[CHAIN["D"]] != group[CHAIN["L"]]
    got = centres(to_svg(vector, layout=layout), (h, w))
    dark, light = got[3, 2:, :3], got[4, 2:, :3]  # the pixels along the contour, away from the middle grey
    assert np.abs(dark - 60).max() <= 16 and np.abs(light - 150).max() <= 16
    assert (light - dark).min() >= 72  # (of 90: the contour is not smoothed)


#: the tone chain of CHAIN, its dark and light greys touching at one pixel side alone (row 3,
#: columns 4 | 5), the middle grey (two faces) linking them all round, as
#: gaxe2_axbattler_02's #a06040 ~ #c08060 ~ #e0a080 do
CORNER_ART = """
DDDDDMMMMMM
DDDDDMMMMMM
DDDDDMMMMMM
DDDDDLLLLLL
MMMMMLLLLLL
MMMMMLLLLLL
MMMMMLLLLLL
"""


def test_a_contact_of_one_pixel_side_does_not_split_the_region():
    """Where the two dissimilar tones of a chain touch at a single pixel side, the region
    stays one smooth group (the paper's lines of sight are blocked along that side alone), so
    the similar pairs around it blend in the SVG as in the PNG renderer: no stepped render
    pixel away from the contact in either. Split there (two groups), the middle grey kept a
    crisp edge against each side: dozens of steps."""
    from depixel.render.shading import render_smooth

    rgba = art(CORNER_ART, CHAIN)
    h, w = rgba.shape[:2]
    vector = depixelize(rgba).vector
    topo = FaceTopology(vector)
    assert topo.n_faces == 4 and len(set(topo.group.tolist())) == 1 and topo.group[0] >= 0
    scale = 8
    far = np.ones((h * scale, w * scale - 1), bool)
    far[(3 - 2) * scale : (4 + 2) * scale, (5 - 2) * scale : (5 + 2) * scale] = False  # the contact
    for rendered in (render(to_svg(vector), w * scale, h * scale), render_smooth(vector, scale)):
        steps = stepped_pairs(rendered)
        assert not far[steps[:, 0], steps[:, 1]].any(), steps


def test_a_single_pixel_at_a_one_side_contact_stays_apart():
    """A single light pixel touching the dark grey at one side, the middle grey all round it
    (one region): it is kept out of the dark grey's group, so the blur does not pull its
    whole colour towards its dissimilar neighbour (gaxe_skeleton's dithered bones haloed):
    its pixel centre keeps its colour. In the dark grey's group its centre went 53 levels
    darker."""
    rgba = art("""
      DDDDDD
      DDDDDD
      MMMLMM
      MMMMMM
    """, CHAIN)
    vector = depixelize(rgba).vector
    topo = FaceTopology(vector)
    single = topo.labels[2 * 6 + 3]
    assert topo.area[single] == 1 and topo.group[single] != topo.group[topo.labels[0]]
    got = centres(to_svg(vector), rgba.shape[:2])
    assert np.abs(got[2, 3, :3] - 150).max() <= 16


def test_smooth_groups_split_a_region_at_a_contour_and_keep_a_gradient_whole():
    """A group never holds two faces with a contour between them: a visible boundary of two
    pixel sides or more (``CONTOUR_EDGES``), or any with a single pixel; the orb's six tones,
    each similar to the next, are one group."""
    for rgba in (art(CHAIN_ART, CHAIN), load_image(FIXTURES / "orb.png")):
        topo = FaceTopology(depixelize(rgba).vector)
        left, right = topo.cells.edge_pixels.T
        inner = (left >= 0) & (right >= 0)
        a, b = topo.labels[left[inner]], topo.labels[right[inner]]
        from depixel.vector import linked_edges

        visible = ~linked_edges(topo.cells)[inner]
        ga, gb = topo.group[a], topo.group[b]
        both = (ga >= 0) & (ga == gb) & visible & (a != b)
        pair, sides = np.unique(np.minimum(a, b)[both] * topo.n_faces + np.maximum(a, b)[both], return_counts=True)
        assert (sides < CONTOUR_EDGES).all()
        assert (topo.area[pair // topo.n_faces] > 1).all() and (topo.area[pair % topo.n_faces] > 1).all()
    orb = FaceTopology(depixelize(load_image(FIXTURES / "orb.png")).vector)
    tones = [(30 + 22 * k, 60 + 22 * k, 75 + 22 * k, 255) for k in range(6)]
    in_tones = np.array([tuple(c) in tones for c in orb.face_rgba.tolist()])
    assert len(set(orb.group[in_tones].tolist())) == 1 and (orb.group[in_tones] >= 0).all()
    assert (orb.group[~in_tones] == -1).all()


def test_a_translucent_group_keeps_its_opacity():
    """Two similar translucent tones are blended and keep alpha 128 (the filter restores
    each point's own alpha), not drawn opaque."""
    glass = {"a": (200, 200, 230, 128), "b": (230, 230, 255, 128), " ": (0, 0, 0, 0)}
    rgba = art("""
      aaaaaaaa
      aaaabbbb
      aaaabbbb
      aaaaaaaa
    """, glass)
    vector = depixelize(rgba).vector
    svg = to_svg(vector)
    assert 'filter="url(#smooth)"' in svg
    got = centres(svg, rgba.shape[:2])
    assert np.abs(got[..., 3] - 128).max() <= 2
    assert np.abs(got[..., :3] - rgba[..., :3]).max() <= 16


def test_layers_panel_names_the_smooth_group():
    """What Inkscape's Objects panel shows: the group's label says it is a smooth-shaded
    region, its bands keep their labels and fills."""
    root = ET.fromstring(to_svg(depixelize(load_image(FIXTURES / "orb.png")).vector))
    (group,) = [g for g in root.iter(SVG_NS + "g") if g.get("filter") == "url(#smooth)"]
    assert re.fullmatch(r"smooth shading #[0-9a-f]{6} \(6 tones\)", group.get(INK_LABEL))
    for path in group.iter(SVG_NS + "path"):
        role, colour = path.get(INK_LABEL).split(" ")
        assert colour == path.get("fill")


def stepped_pairs(rendered: np.ndarray) -> np.ndarray:
    """(K, 2) row and column of the left pixel of every stepped pair, as
    ``shape_checks.py steps`` counts them: horizontal neighbours, opaque, away from contours
    (7×7 luminance range ≤ 60), whose luminance differs by 6 levels or more."""
    from scipy.ndimage import maximum_filter, minimum_filter

    luma = rendered[..., :3].astype(float).mean(axis=2)
    calm = (rendered[..., 3] == 255) & ((maximum_filter(luma, 7) - minimum_filter(luma, 7)) <= 60)
    pair = calm[:, 1:] & calm[:, :-1] & (np.abs(np.diff(luma, axis=1)) >= 6)
    return np.argwhere(pair)


@needs_corpus
def test_toads_steps_are_shading_edges_the_paper_keeps_crisp():
    """docs/svg.md, "Why Toad keeps its steps": in sma_toad's default SVG (resvg, 8×) every
    stepped pixel lies by cells of two regions, at a visible edge (a shading edge or a
    contour, which §3.5's influence does not cross), none inside a region, as in the PNG
    renderer; the flat bands have steps inside its three shaded regions."""
    from depixel.render.shading import _cell_labels, _flatten, _pieces_per_curve, _Segments, render_smooth
    from depixel.vector import regions

    vector = depixelize(load_image(CORPUS / "sma_toad.png")).vector
    h, w = vector.shape
    segments = _Segments(vector, _flatten(vector, _pieces_per_curve(vector, 0.1 / 8)))
    region = regions(vector.cells)[_cell_labels(segments, 0, h * 8, 8, 8, w * 8)]  # under each render pixel

    def inside_a_region(rendered: np.ndarray, margin: int) -> tuple[int, int]:
        steps = stepped_pairs(rendered)
        inside = sum(np.unique(region[max(0, y - margin) : y + 1 + margin, max(0, x - margin) : x + 2 + margin]).size
                     == 1 for y, x in steps.tolist())
        return len(steps), inside

    # the labels are the exact curves'; the SVG's lie within the simplification's tolerance of them
    svg_margin = math.ceil(DEFAULT_SIMPLIFY * 8)
    smooth, flat = (inside_a_region(render(to_svg(vector, shading=s), w * 8, h * 8), svg_margin)
                    for s in ("smooth", "flat"))
    paper = inside_a_region(render_smooth(vector, 8), 1)
    assert smooth[1] == 0 and paper[1] == 0, (smooth, paper)
    assert flat[1] > 50, flat
    assert smooth[0] > 300 and abs(smooth[0] - paper[0]) <= 0.1 * paper[0], (smooth, paper)  # the shading edges
