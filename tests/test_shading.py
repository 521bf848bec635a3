"""Stage 7: the smooth renderer of paper §3.5 — shading within regions, sharp contours."""
from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, art, fixture_pngs, needs_corpus

from depixel.colour import rgb_to_yuv
from depixel.graph.similarity import similar
from depixel.params import Params
from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render import shading
from depixel.render.shading import cell_centroids, render_smooth
from depixel.render.visibility import Occluders
from depixel.vector import regions

STAGES = ("cells", "optimized")


def vector(rgba: np.ndarray, stage: str = "optimized"):
    return depixelize(rgba, stage=stage).vector


@cache
def fixture_vector(name: str, stage: str):
    return vector(load_image(FIXTURES / name), stage)


def grey(*levels: int) -> dict:
    """Colour keys "0", "1", … for opaque greys."""
    return {str(k): (g, g, g, 255) for k, g in enumerate(levels)}


def within_thresholds(rendered: np.ndarray, reference: np.ndarray, slack: float = 1.0) -> np.ndarray:
    """The paper's similarity test (plus ``slack`` for rounding to uint8), per pixel."""
    p = Params()
    loose = p.replace(threshold_y=p.threshold_y + slack, threshold_u=p.threshold_u + slack,
                      threshold_v=p.threshold_v + slack, threshold_alpha=p.threshold_alpha + slack)
    return similar(rgb_to_yuv(rendered), rendered[..., 3], rgb_to_yuv(reference), reference[..., 3], loose)


# --- a slow, obviously correct reference of the scanline rasterizer ------------------------


def cell_at(image, points: np.ndarray) -> np.ndarray:
    """Cell containing each ``(P, 2)`` point by the even-odd rule (-1 if none)."""
    h, w = image.shape
    a, b, edge = shading._flatten(image, 16)
    cells = image.cells
    found = np.full(len(points), -1)
    x, y = points[:, :1], points[:, 1:]
    for pixel in range(h * w):
        mine = np.isin(edge, cells.cell_edges[cells.cell_ptr[pixel] : cells.cell_ptr[pixel + 1]])
        x0, y0, x1, y1 = a[mine, 0], a[mine, 1], b[mine, 0], b[mine, 1]
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        found[(crosses & (x < xi)).sum(axis=1) % 2 == 1] = pixel
    return found


def distance_to_outlines(image, points: np.ndarray) -> np.ndarray:
    a, b, _ = shading._flatten(image, 16)
    d = b - a
    t = np.clip(((points[:, None] - a[None]) * d[None]).sum(-1) / np.maximum((d * d).sum(-1), 1e-12), 0, 1)
    return np.linalg.norm(points[:, None] - (a[None] + t[..., None] * d[None]), axis=-1).min(axis=1)


@pytest.mark.parametrize("stage", STAGES)
def test_scanline_labels_match_point_in_polygon(stage):
    rng = np.random.default_rng(7)
    palette = np.array([[255, 255, 255, 255], [0, 0, 0, 255], [220, 30, 30, 255], [230, 230, 230, 255]], np.uint8)
    image = vector(palette[rng.integers(0, 4, size=(7, 8))], stage)
    h, w = image.shape
    fy, fx = 13 / 3, 11 / 2  # samples per input pixel, deliberately off the quarter grid
    seg = shading._Segments(image, shading._flatten(image, 16))
    labels = shading._cell_labels(seg, 0, round(h * fy), fy, fx, round(w * fx))
    k, j = np.mgrid[0 : labels.shape[0], 0 : labels.shape[1]]
    points = np.stack([(j.ravel() + 0.5) / fx, (k.ravel() + 0.5) / fy], axis=1)
    expected = cell_at(image, points)
    wrong = labels.ravel() != expected
    # a sample lying on an outline belongs to either side; no other may disagree
    assert (distance_to_outlines(image, points[wrong]) < 1e-9).all()
    assert wrong.mean() < 0.01


def test_centroids_of_straight_cells_are_polygon_centroids():
    image = vector(art("""
        .#..
        #.#.
        .##.
    """), "cells")
    centroids = cell_centroids(image)
    for pixel in range(12):
        poly = image.cells.cell_polygon(pixel) / 4.0
        x, y = poly[:, 0], poly[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        area = cross.sum() / 2
        expected = [((x + xn) * cross).sum() / (6 * area), ((y + yn) * cross).sum() / (6 * area)]
        np.testing.assert_allclose(centroids[pixel], expected, atol=1e-12)


# --- the acceptance properties of issue 8 --------------------------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_two_grey_gradient_renders_as_a_smooth_ramp(stage):
    # 100 and 140 are similar (|ΔY| = 40 ≤ 48): one region, shaded across the seam
    image = vector(art("\n".join(["000000111111"] * 6), grey(100, 140)), stage)
    out = render_smooth(image, 8)
    ramp = out[:, :, 0].astype(int)
    assert (out[..., :3] == out[..., :1]).all()  # stays grey
    steps = np.diff(ramp, axis=1)
    assert (steps >= 0).all()  # monotone along the ramp
    assert steps.max() <= (140 - 100) / 8  # no step above an eighth of the colour difference
    assert ramp.min() == 100 and ramp.max() == 140
    assert np.ptp(ramp, axis=0).max() <= 1  # constant across it (up to rounding)
    assert ((ramp > 100) & (ramp < 140)).any(axis=0).sum() >= 16  # spread over ≥ 2 input pixels


def test_contour_between_dissimilar_colours_is_one_pixel_wide():
    image = vector(art("\n".join(["###....."] * 6)), "cells")
    out = render_smooth(image, 7.5)  # the contour at x = 3 falls in the middle of output column 22
    between = (out[..., 0] > 0) & (out[..., 0] < 255)
    assert between.sum(axis=1).tolist() == [1] * out.shape[0]
    assert (np.flatnonzero(between.any(axis=0)) == [22]).all()
    assert set(np.unique(out[..., 0])) <= {0, 255, int(out[0, 22, 0])}


def test_curved_contour_stays_sharp():
    # a black disc on white: every grey pixel is within one output pixel of the curve
    image = vector(art("""
        ..........
        ...####...
        ..######..
        .########.
        .########.
        .########.
        .########.
        ..######..
        ...####...
        ..........
    """))
    assert image.curved.any()
    scale = 8
    out = render_smooth(image, scale)
    between = np.argwhere((out[..., 0] > 0) & (out[..., 0] < 255))
    assert len(between) > 0
    centres = (between[:, ::-1] + 0.5) / scale
    assert distance_to_outlines(image, centres).max() <= 1.0 / scale
    # a line through the middle crosses the contour twice, each time within two pixels
    for line in (out[40, :, 0], out[:, 40, 0]):
        assert ((line > 0) & (line < 255)).sum() <= 2 + 2


@pytest.mark.parametrize("stage", STAGES)
def test_single_pixel_eye_keeps_its_exact_colour(stage):
    # a one-pixel red eye and a one-pixel black eye on a shaded grey face
    rgba = art("""
        0011223
        0r11223
        0011#23
        0011223
    """, grey(150, 165, 180, 195))
    out = render_smooth(vector(rgba, stage), 8)
    assert out[1 * 8 + 4, 1 * 8 + 4].tolist() == [220, 30, 30, 255]
    assert out[2 * 8 + 4, 4 * 8 + 4].tolist() == [0, 0, 0, 255]
    # the face around them is shaded but never tinted: colour only within a pixel of the red eye
    tinted = np.ptp(out[..., :3].astype(int), axis=-1) > 0
    assert not tinted[24:].any() and not tinted[:, 24:].any()
    assert len(np.unique(out[24:, 24:, 0])) > 4 * 2  # shaded: many greys beyond the four


@pytest.mark.parametrize("path", fixture_pngs(), ids=lambda p: p.name)
def test_every_pixel_centre_is_similar_to_its_own_colour(path):
    rgba = load_image(path)
    out = render_smooth(fixture_vector(path.name, "cells"), 9)  # odd scale: output pixel (9r+4, 9c+4) is centred on pixel (r, c)
    assert within_thresholds(out[4::9, 4::9], rgba).all()


@pytest.mark.parametrize("path", fixture_pngs(), ids=lambda p: p.name)
def test_shading_is_similar_to_the_cell_under_each_point(path):
    # at the optimized stage, where contours may cut a pixel centre off its own cell:
    # every output pixel (no anti-aliasing) against the cell its centre was rasterized into
    # (the rasterizer itself is checked against point-in-polygon above)
    rgba = load_image(path)
    image = fixture_vector(path.name, "optimized")
    h, w = image.shape
    out = render_smooth(image, 3, supersample=1)
    segments = shading._Segments(image, shading._flatten(image, shading._pieces_per_curve(image, shading.FLATTEN_TOLERANCE / 3)))
    under = shading._cell_labels(segments, 0, 3 * h, 3, 3, 3 * w)
    assert within_thresholds(out, rgba.reshape(-1, 4)[under]).all()


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("stage", STAGES)
def test_random_shaded_images_stay_similar_to_the_cell_under_each_point(seed, stage):
    # greys 30 apart chain into long regions that drift; a blue and transparency break them
    palette = np.array([[g, g, g, 255] for g in range(40, 221, 30)] + [[30, 60, 220, 255], [0, 0, 0, 0]], np.uint8)
    rgba = palette[np.random.default_rng(seed).integers(0, len(palette), size=(9, 10))]
    image = vector(rgba, stage)
    out = render_smooth(image, 2, supersample=1)
    segments = shading._Segments(image, shading._flatten(image, shading._pieces_per_curve(image, shading.FLATTEN_TOLERANCE / 2)))
    under = shading._cell_labels(segments, 0, 18, 2, 2, 20)
    assert within_thresholds(out, rgba.reshape(-1, 4)[under]).all()


@pytest.mark.parametrize("stage", STAGES)
def test_region_chained_through_a_middle_grey_blends_only_similar_colours(stage):
    # 150 and 60 are dissimilar (|ΔY| = 90) yet one region, chained by the diagonal 105:
    # a plain average over the region would pull the 150 pixel's centre about 66 towards 60
    rgba = art("""
        00000
        02000
        00100
        00000
    """, grey(60, 105, 150))
    out = render_smooth(vector(rgba, stage), 9)
    assert within_thresholds(out[4::9, 4::9], rgba).all()
    assert out[1 * 9 + 4, 1 * 9 + 4, 0] < 150  # still shaded, not flat


#: a tone chain: 60 ~ 105 ~ 150 (|ΔY| = 45 each), 60 and 150 not similar: one region
#: through the middle grey at the left end of the contour between the dark and the light side
CHAIN = """
    0000000000
    0000000000
    0000000000
    1000000000
    2222222222
    2222222222
    2222222222
"""


@pytest.mark.parametrize("stage", STAGES)
def test_colour_does_not_travel_along_a_tone_chain_past_a_contour(stage, monkeypatch):
    """§3.5: a cell's influence stops at the region visible from its centroid. The light
    side's centroids see the dark pixels along the contour only across it, so those keep
    their colour exactly; by the region alone (the check at the end) the light grey would
    reach them around the contour's end."""
    rgba = art(CHAIN, grey(60, 105, 150))
    image = vector(rgba, stage)
    out = render_smooth(image, 9)[4::9, 4::9].astype(int)
    assert (np.abs(out[3, 2:, :3] - 60) <= 1).all() and (np.abs(out[4, 2:, :3] - 150) <= 1).all()
    assert out[3, 1, 0] > 61  # the dark pixel beside the middle grey sees it: shaded
    monkeypatch.setattr(Occluders, "hidden", lambda self, pixel, *rest: np.zeros(pixel.size, bool))
    regions_only = render_smooth(image, 9)[4::9, 4::9].astype(int)
    assert (regions_only[3, 2:, 0] - 60).max() > 20


def brute_force_hidden(image, centroid: np.ndarray, cell: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Every visible edge (flattened as the renderer does for visibility), every segment
    tested against every piece."""
    from depixel.vector import linked_edges

    a, b, edge = shading._flatten(image, shading._pieces_per_curve(image, shading.VISIBILITY_TOLERANCE))
    cells = image.cells
    visible = ~linked_edges(cells) & (cells.edge_pixels >= 0).all(axis=1)
    a, b = a[visible[edge]], b[visible[edge]]
    p, q = centroid[cell], np.stack([x, y], axis=1)

    def side(u, v, r):
        return (v[..., 0] - u[..., 0]) * (r[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (r[..., 0] - u[..., 0]) > 0

    pp, qq = p[:, None], q[:, None]
    crosses = (side(pp, qq, a[None]) != side(pp, qq, b[None])) & (side(a[None], b[None], pp) != side(a[None], b[None], qq))
    return crosses.any(axis=1)


@pytest.mark.parametrize("seed", range(3))
def test_occluders_agree_with_testing_every_visible_edge(seed):
    """The pieces kept per (pixel, offset) are all that can hide a cell of a region of several
    colours from a point of the pixel within the influence radius (elsewhere the cells a
    point sees have its colour anyway): the same answer as testing every visible edge."""
    rng = np.random.default_rng(seed)
    levels = grey(60, 100, 140, 180)
    rgba = np.array([[levels[str(k)] for k in row] for row in rng.integers(0, 4, size=(8, 9))], np.uint8)
    image = vector(rgba)
    field = shading._ShadingField(image, shading._flatten(image, 16), Params())
    h, w = image.shape
    colour = rgba.reshape(-1, 4)[:, 0]
    tones = {r: set() for r in field.region.tolist()}
    for r, c in zip(field.region.tolist(), colour.tolist()):
        tones[r].add(c)
    shaded = np.array([len(tones[r]) > 1 for r in field.region.tolist()])
    assert shaded.any() and not shaded.all()
    n = 4000
    x, y = rng.uniform(0, w, n), rng.uniform(0, h, n)
    pixel = np.floor(y).astype(int) * w + np.floor(x).astype(int)
    for o, (dy, dx) in enumerate(field.offsets.tolist()):
        row, col = np.floor(y).astype(int) + dy, np.floor(x).astype(int) + dx
        inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
        cell = (row * w + col)[inside]
        got = field.occluders.hidden(pixel[inside], o, cell, x[inside], y[inside])
        near = np.hypot(*(field.centroid[cell] - np.stack([x[inside], y[inside]], axis=1)).T) < field.radius
        near &= shaded[cell]
        want = brute_force_hidden(image, field.centroid, cell, x[inside], y[inside])
        assert np.array_equal(got[near], want[near])


@pytest.mark.parametrize("name", ["ghost_rgba.png", "heart_trns.png", "potion_rgba.png"])
@pytest.mark.parametrize("stage", STAGES)
def test_transparent_background_stays_transparent(name, stage):
    rgba = load_image(FIXTURES / name)
    h, w = rgba.shape[:2]
    scale = 4
    out = render_smooth(fixture_vector(name, stage), scale)
    clear = rgba[..., 3] == 0
    padded = np.pad(clear, 1, constant_values=True)
    # transparent pixels with transparent 8-neighbours: their whole footprint is clear
    deep = np.ones_like(clear)
    for dy in range(3):
        for dx in range(3):
            deep &= padded[dy : dy + h, dx : dx + w]
    footprint = np.kron(deep, np.ones((scale, scale), bool))
    assert deep.any()
    assert (out[..., 3][footprint] == 0).all()
    assert (out[..., :3][out[..., 3] == 0] == 0).all()  # nothing hides in clear pixels
    # opaque interiors stay opaque, anti-aliased edges are partly transparent
    solid = np.kron(np.pad(rgba[..., 3] == 255, 1, constant_values=False)[1:-1, 1:-1], np.ones((scale, scale), bool))
    assert np.median(out[..., 3][solid]) == 255
    assert ((out[..., 3] > 0) & (out[..., 3] < 255)).any()


# --- implementation invariants -------------------------------------------------------------


def test_tiles_and_the_flat_shortcut_do_not_change_the_result(monkeypatch):
    rng = np.random.default_rng(3)
    levels = np.array([[90, 90, 90, 255], [120, 120, 120, 255], [150, 140, 140, 255], [20, 20, 200, 255]], np.uint8)
    image = vector(levels[rng.integers(0, 4, size=(9, 11))])
    whole = render_smooth(image, 5)
    monkeypatch.setattr(shading, "TILE_SAMPLES", 700)  # a few output rows per tile
    assert np.array_equal(render_smooth(image, 5), whole)
    monkeypatch.setattr(shading._ShadingField, "_flat_cells", lambda self, radius: np.zeros(self.region.size, bool))
    assert np.abs(render_smooth(image, 5).astype(int) - whole).max() <= 1


def test_output_size_and_bad_arguments():
    image = vector(art("#.\n.#"), "cells")
    assert render_smooth(image, 2.5).shape == (5, 5, 4)
    assert render_smooth(image, 0.3).shape == (1, 1, 4)
    with pytest.raises(ValueError):
        render_smooth(image, 0)
    with pytest.raises(ValueError):
        render_smooth(image, 2, supersample=0)


def test_ramp_across_a_two_tone_band_follows_the_papers_truncated_gaussian():
    # §3.5: a Gaussian of σ = 1 pixel, truncated at 2 pixels (lowered by its value there,
    # docs/rendering.md), at every cell centroid; here the cells are the pixels, so the
    # colour at a point is the weighted average of the pixel colours around it. The
    # constants are the paper's, written here: a change of Params' σ or radius is caught.
    sigma, radius, scale = 1.0, 2.0, 8
    columns = np.array([100] * 6 + [140] * 6, dtype=float)
    image = vector(art("\n".join(["000000111111"] * 7), grey(100, 140)), "cells")
    out = render_smooth(image, scale, supersample=1)[3 * scale + scale // 2, :, 0].astype(float)  # middle row
    xs = (np.arange(out.size) + 0.5) / scale
    centres_x, centres_y = np.meshgrid(np.arange(12) + 0.5, np.arange(7) + 0.5)
    d2 = (centres_x.ravel()[None, :] - xs[:, None]) ** 2 + (centres_y.ravel()[None, :] - 3.5) ** 2
    weight = np.where(d2 < radius**2, np.exp(-d2 / (2 * sigma**2)) - np.exp(-radius**2 / (2 * sigma**2)), 0.0)
    expected = weight @ np.tile(columns, 7) / weight.sum(axis=1)
    near_seam = np.abs(xs - 6) < 2.5  # where the two tones blend
    assert np.abs(out - expected).max() <= 1.0, np.abs(out - expected).max()
    assert np.ptp(expected[near_seam]) > 30  # the profile the test pins is a real ramp


@needs_corpus
def test_the_centres_that_move_over_16_levels_sit_by_a_tone_at_the_similarity_limit():
    """docs/rendering.md, "Pixel centres": sbm4_02 is one of the six sprites whose smooth
    render keeps under 97 % of its pixel centres within 16 levels at the paper's σ = 1. Every
    such centre is a pixel with a pixel of its own region beside it (8-neighbourhood) whose
    luminance differs by exactly 48, hqx's limit of similar: what §3.5 blends. A centre moved
    anywhere else would be colour from across a contour or a wrong weight."""
    rgba = load_image(CORPUS / "sbm4_02.png")
    image = vector(rgba)
    h, w = image.shape
    got = render_smooth(image, 9).astype(int)[4::9, 4::9]
    moved = np.abs(got[..., :3] - rgba[..., :3].astype(int)).max(axis=2) > 16
    assert 0.03 < moved.mean() < 0.06  # (0.051 at 2026-12-05; the table in docs/rendering.md)
    region = regions(image.cells).reshape(h, w)
    luma = rgb_to_yuv(rgba[..., :3])[..., 0]
    for y, x in np.argwhere(moved).tolist():
        around = (slice(max(0, y - 1), y + 2), slice(max(0, x - 1), x + 2))
        same = region[around] == region[y, x]
        assert (np.abs(np.abs(luma[around] - luma[y, x]) - 48) < 0.5)[same].any(), (y, x)
