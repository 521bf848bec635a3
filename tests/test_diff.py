"""The perceptual diff: YIQ distance, anti-aliasing detection, sizes, and ``depixel diff`` end to end."""
from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import FIXTURES, art
from PIL import Image

from depixel.diff.compare import (
    MAX_YIQ_DELTA,
    compare,
    luma,
    pick_background,
    yiq_distance,
)
from depixel.diff.pairs import diff_files
from depixel.diff.sources import SizeMismatchError, read, too_coarse_for_antialiasing
from depixel_cli.main import main
from depixel_cli.options import Exit


def opaque(rgb_rows) -> np.ndarray:
    rgb = np.asarray(rgb_rows, dtype=np.uint8)
    return np.concatenate([rgb, np.full(rgb.shape[:2] + (1,), 255, np.uint8)], axis=2)


def test_cyan_and_red_are_the_largest_distance():
    assert yiq_distance(np.array([0, 255, 255]), np.array([255, 0, 0])) == pytest.approx(MAX_YIQ_DELTA, rel=1e-4)
    assert yiq_distance(np.zeros(3), np.full(3, 255)) == pytest.approx(0.5053 * 255**2)  # luma only
    rng = np.random.default_rng(0)
    a, b = rng.integers(0, 256, (2, 1000, 3))
    d = yiq_distance(a, b)
    assert np.all(d >= 0) and np.all(d <= MAX_YIQ_DELTA * 1.0001)
    assert np.allclose(d, yiq_distance(b, a))


def test_identical_images_do_not_differ():
    img = art("#.r\n.g.\nbyb")
    result = compare(img, img.copy())
    assert result.different_pixels == 0 and result.ratio == 0.0


def test_small_change_below_threshold_is_equal_and_large_is_not():
    base = np.full((6, 6, 4), 255, np.uint8)
    base[..., :3] = 100
    near, far = base.copy(), base.copy()
    near[2, 3, :3] = 104  # a barely visible step
    far[2, 3, :3] = 180
    assert compare(base, near).different_pixels == 0
    result = compare(base, far)
    assert result.different_pixels == 1 and result.different[2, 3]
    # the threshold is the knob: zero counts every change
    assert compare(base, near, threshold=0.0).different_pixels == 1


def test_a_blend_the_other_image_has_beside_it_is_antialiasing_but_a_blob_is_not():
    """A ramp of blends drawn a pixel further: the blend beside the flat black area is
    anti-aliasing (the other image has its colour next to it); the pixels that became a
    flat area's colour (white) or whose neighbours are no flat area are changes."""
    black, white = (0, 0, 0), (255, 255, 255)
    a = opaque([[black, black, (64,) * 3, (128,) * 3, (192,) * 3, white, white, white]] * 6)
    b = opaque([[black, black, (128,) * 3, (192,) * 3, white, white, white, white]] * 6)
    result = compare(a, b)
    assert result.antialiased[:, 2].all() and not result.different[:, 2].any()
    assert result.different[:, 3:5].all() and result.different_pixels == 12
    assert compare(a, b, include_antialiasing=True).different_pixels == 18
    c = a.copy()
    c[3, 0, :3] = 128  # grey inside the black area: every neighbour is darker, a real change
    assert compare(a, c).different_pixels == 1


def test_a_blend_the_other_image_has_nowhere_near_is_a_change():
    """Rule 3: pixelmatch calls this pixel anti-aliasing (between a darker and a brighter flat
    neighbour); but the other image has no such colour next to it: something was drawn."""
    black, white = (0, 0, 0), (255, 255, 255)
    a = opaque([[black, black, (64,) * 3, (128,) * 3, (192,) * 3, white, white, white]] * 6)
    b = a.copy()
    b[:, 2, :3] = 100  # another blend, between the same flat black and the same 128
    result = compare(a, b)
    assert result.different[:, 2].all() and result.different_pixels == 6
    assert compare(a, a.copy()).different_pixels == 0


def test_a_pixel_taking_a_flat_neighbours_colour_is_a_change():
    """Rule 2: a pixel that took the colour of a flat area beside it is that area grown by a
    pixel (a sprite pixel changed, drawn at 1x), not an edge blend, even though the other
    image has the colour next to it and pixelmatch's test passes."""
    dark, mid, light = (20, 20, 20), (120, 40, 40), (240, 240, 240)
    a = opaque([[dark] * 3 + [mid] + [light] * 3] * 7)
    b = a.copy()
    b[3, 3, :3] = dark  # a one-pixel notch of the dark area
    result = compare(a, b)
    assert result.different[3, 3] and result.different_pixels == 1


def _reference_antialiased(img: np.ndarray, other: np.ndarray, x: int, y: int, limit: float) -> bool:
    """Slow, loop-by-loop statement of the anti-aliasing rule (scan order: x outer, y inner)."""
    h, w = img.shape[:2]
    ys = luma(img[..., :3])

    def on_border(px, py):
        return px in (0, w - 1) or py in (0, h - 1)

    def neighbours(px, py):
        return [(nx, ny) for nx in range(max(px - 1, 0), min(px + 1, w - 1) + 1)
                for ny in range(max(py - 1, 0), min(py + 1, h - 1) + 1) if (nx, ny) != (px, py)]

    def many_siblings(im, px, py):
        count = 1 if on_border(px, py) else 0
        count += sum(np.array_equal(im[py, px], im[ny, nx]) for nx, ny in neighbours(px, py))
        return count > 2

    def close(c1, c2):
        return yiq_distance(c1[:3], c2[:3]) <= limit

    zeroes = 1 if on_border(x, y) else 0
    low = high = 0.0
    low_at = high_at = None
    for nx, ny in neighbours(x, y):
        delta = ys[y, x] - ys[ny, nx]
        if delta == 0:
            zeroes += 1
        elif delta < low:
            low, low_at = delta, (nx, ny)
        elif delta > high:
            high, high_at = delta, (nx, ny)
    if zeroes > 2 or low == 0 or high == 0:
        return False
    if not any(many_siblings(img, *p) and many_siblings(other, *p) for p in (low_at, high_at)):
        return False  # pixelmatch's test
    for im in (img, other):  # rule 2: a flat neighbour's colour in either image, not a blend
        if any(many_siblings(im, nx, ny) and close(im[y, x], im[ny, nx]) for nx, ny in neighbours(x, y)):
            return False
    return any(close(img[y, x], other[ny, nx]) for nx, ny in neighbours(x, y))  # rule 3


def test_vectorized_comparison_matches_the_reference_on_random_images():
    rng = np.random.default_rng(7)
    palette = np.array([[0, 0, 0], [255, 255, 255], [128, 128, 128], [200, 30, 30], [60, 60, 60]], np.uint8)
    for _ in range(20):
        h, w = rng.integers(1, 9, 2)
        a = opaque(palette[rng.integers(0, 5, (h, w))])
        b = opaque(palette[rng.integers(0, 5, (h, w))])
        same = rng.random((h, w)) < 0.6  # shared areas give flat neighbourhoods
        b[same] = a[same]
        result = compare(a, b)
        over = yiq_distance(a[..., :3], b[..., :3]) > MAX_YIQ_DELTA * 0.01
        for y in range(h):
            for x in range(w):
                limit = MAX_YIQ_DELTA * 0.01
                aa = over[y, x] and (_reference_antialiased(a, b, x, y, limit) or
                                     _reference_antialiased(b, a, x, y, limit))
                assert result.antialiased[y, x] == aa
                assert result.different[y, x] == (over[y, x] and not aa)


def test_background_avoids_colours_in_the_images():
    plain = art("#.\n.#")
    assert pick_background([plain]) == (255, 0, 255)
    magenta = art("m.\n.#", {"m": (255, 0, 255, 255)})
    assert pick_background([plain, magenta]) == (0, 255, 255)
    hidden = art("m.\n.#", {"m": (255, 0, 255, 0)})  # fully transparent: not a visible colour
    assert pick_background([hidden]) == (255, 0, 255)


def test_transparent_hole_shows_against_the_background(tmp_path):
    a = art("rr\nrr")
    b = a.copy()
    b[0, 0, 3] = 0  # an alpha leak
    for name, img in (("a.png", a), ("b.png", b)):
        Image.fromarray(img, "RGBA").save(tmp_path / name)
    result, background = diff_files(tmp_path / "a.png", tmp_path / "b.png")
    assert background == (255, 0, 255)
    assert result.different[0, 0] and result.different_pixels == 1


def test_size_mismatch_is_an_error_unless_allowed(tmp_path):
    Image.fromarray(art("rr\nrr"), "RGBA").save(tmp_path / "small.png")
    Image.fromarray(art("rrr\nrrr"), "RGBA").save(tmp_path / "wide.png")
    with pytest.raises(SizeMismatchError):
        diff_files(tmp_path / "small.png", tmp_path / "wide.png")
    result, _ = diff_files(tmp_path / "small.png", tmp_path / "wide.png", allow_size_mismatch=True)
    assert result.different.shape == (2, 3)
    assert result.different[:, 2].all() and not result.different[:, :2].any()


# --- depixel diff, end to end ---------------------------------------------------------------

@pytest.fixture(scope="module")
def heart_svg(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diff")
    svg = folder / "heart.svg"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(svg), "--scale", "4"]) == Exit.OK
    return svg


def test_cli_svg_against_its_own_render_is_same(heart_svg, tmp_path, capsys):
    png = tmp_path / "heart.png"
    assert main(["render", str(heart_svg), "-o", str(png)]) == Exit.OK
    report_path = tmp_path / "diff.png"
    code = main(["diff", str(heart_svg), str(png), "--diff-out", str(report_path), "--json"])
    assert code == Exit.OK
    report = json.loads(capsys.readouterr().out)
    assert report["same"] is True and report["different_pixels"] == 0
    assert (report["width"], report["height"]) == (40, 40)
    with Image.open(report_path) as img:
        assert img.size == (40, 40)


def test_cli_changed_colour_is_different(heart_svg, tmp_path, capsys):
    text = heart_svg.read_text()
    fills = sorted(set(part.split('"')[0] for part in text.split('fill="#')[1:]))
    changed = tmp_path / "changed.svg"
    changed.write_text(text.replace(f'fill="#{fills[0]}"', 'fill="#00ff00"'))
    diff_png = tmp_path / "diff.png"
    code = main(["diff", str(heart_svg), str(changed), "--diff-out", str(diff_png), "--json"])
    assert code == Exit.FAILED
    report = json.loads(capsys.readouterr().out)
    assert report["same"] is False and report["different_pixels"] > 0
    with Image.open(diff_png) as img:
        red = np.all(np.asarray(img.convert("RGB")) == (255, 0, 0), axis=2).sum()
    assert red == report["different_pixels"]
    # tolerances: enough absolute or relative slack makes it pass
    n, ratio = report["different_pixels"], report["ratio"]
    assert main(["diff", str(heart_svg), str(changed), "--max-pixels-diff", str(n), "--max-ratio", "1"]) == Exit.OK
    assert main(["diff", str(heart_svg), str(changed), "--max-ratio", str(ratio / 2)]) == Exit.FAILED


def test_cli_errors_exit_2(heart_svg, tmp_path, capsys):
    assert main(["diff", str(heart_svg), str(tmp_path / "missing.svg")]) == Exit.USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.svg: no such file" in err
    big = tmp_path / "big.svg"
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(big), "--scale", "5"]) == Exit.OK
    assert main(["diff", str(heart_svg), str(big)]) == Exit.USAGE  # 40×40 vs 50×50
    assert "40x40" in capsys.readouterr().err
    assert main(["diff", str(heart_svg), str(big), "--allow-size-mismatch"]) == Exit.FAILED
    # the same SVG at a common scale compares equal
    assert main(["diff", str(heart_svg), str(heart_svg), "--scale", "3"]) == Exit.OK



# --- no missed change, no comparison that cannot see the art -------------------------------

def converted_mushroom_edit(folder, row_col: tuple[int, int], colour: tuple[int, int, int]):
    """mushroom.png and a copy with the pixel at ``row_col`` set to ``colour``, both
    converted to SVG at 1x in ``folder``: (old.svg, new.svg)."""
    edited = np.asarray(Image.open(FIXTURES / "mushroom.png").convert("RGB")).copy()
    edited[row_col] = colour
    Image.fromarray(edited).save(folder / "edited.png")
    for name, source in (("old", FIXTURES / "mushroom.png"), ("new", folder / "edited.png")):
        assert main(["convert", str(source), "-o", str(folder / f"{name}.svg")]) == Exit.OK
    return folder / "old.svg", folder / "new.svg"

@pytest.fixture(scope="module")
def mushrooms(tmp_path_factory):
    """mushroom.png and a copy with one red pixel of the cap made dark, both as SVG at 1x
    (a pixel whose cell stays large; ``mushroom_blob`` edits one drawn smaller than a pixel)."""
    return converted_mushroom_edit(tmp_path_factory.mktemp("mushrooms"), (5, 5), (24, 20, 37))


@pytest.mark.parametrize("scale", range(1, 9))
def test_a_one_pixel_edit_is_seen_at_every_scale(mushrooms, scale):
    """Issue 34: pixelmatch's anti-aliasing rule called all 14 changed pixels of this edit
    anti-aliasing at 2x ("same"); it must differ at every integer scale."""
    old, new = mushrooms
    result, _ = diff_files(old, new, scale=scale)
    assert result.different_pixels > 0
    assert diff_files(old, old, scale=scale)[0].different_pixels == 0


@pytest.fixture(scope="module")
def mushroom_blob(tmp_path_factory):
    """mushroom.png and a copy with the dark outline pixel (14, 7) made green, both as SVG at
    1x: the green cell is a blob smaller than a pixel, drawn at 2x as a blend of two pixels
    that the anti-aliasing rules alone excuse (benchmarks/diff_sensitivity.py)."""
    return converted_mushroom_edit(tmp_path_factory.mktemp("blob"), (7, 14), (0, 200, 0))


@pytest.mark.parametrize("scale", range(1, 9))
def test_an_edit_drawn_smaller_than_a_pixel_is_seen_at_every_scale(mushroom_blob, scale):
    """Below 3 pixels an art pixel every pixel over the threshold counts (the blob's two
    blended pixels at 2x); from 3x the anti-aliasing rules see it by themselves."""
    old, new = mushroom_blob
    assert diff_files(old, new, scale=scale)[0].different_pixels > 0
    assert diff_files(old, old, scale=scale)[0].different_pixels == 0


def test_anti_aliasing_is_judged_only_from_three_pixels_an_art_pixel(mushroom_blob):
    old, new = mushroom_blob
    source = read(old)
    assert source.art == (16, 14)
    assert too_coarse_for_antialiasing(source, 32, 28) and not too_coarse_for_antialiasing(source, 48, 42)
    assert not too_coarse_for_antialiasing(read(FIXTURES / "mushroom.png"), 16, 14)  # a raster's art is unknown
    assert not diff_files(old, new, scale=2)[0].antialiased.any()  # nothing excused at 2x


def test_a_scale_that_hides_the_art_is_refused(mushrooms, heart_svg, capsys):
    old, new = mushrooms
    assert main(["diff", str(old), str(new), "--scale", "0.01"]) == Exit.USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fewer pixels than its 16x14 of art" in err and "--scale 1 or more" in err
    # a raster is never shrunk; the SVG made at 4x may be drawn down to its pixel grid, no further
    assert main(["diff", str(FIXTURES / "heart.png"), str(FIXTURES / "heart.png"), "--scale", "0.5"]) == Exit.USAGE
    assert main(["diff", str(heart_svg), str(heart_svg), "--scale", "0.25"]) == Exit.OK  # 10x10: the art's size
    assert main(["diff", str(heart_svg), str(heart_svg), "--scale", "0.2"]) == Exit.USAGE


def test_an_svg_against_a_png_of_another_shape_is_a_size_mismatch(tmp_path, capsys):
    svg = tmp_path / "square.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="48" height="48"><rect width="48" height="48" '
                   'fill="#c33"/></svg>')
    Image.new("RGBA", (480, 48), (204, 51, 51, 255)).save(tmp_path / "wide.png")
    Image.new("RGBA", (96, 96), (204, 51, 51, 255)).save(tmp_path / "big.png")
    assert main(["diff", str(svg), str(tmp_path / "wide.png")]) == Exit.USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "aspect ratio" in err
    assert main(["diff", str(svg), str(tmp_path / "big.png")]) == Exit.OK  # same shape: drawn at 96x96
    capsys.readouterr()
    # allowed: the SVG keeps its shape, the area only the PNG covers counts as changed
    assert main(["diff", str(svg), str(tmp_path / "wide.png"), "--allow-size-mismatch", "--json"]) == Exit.FAILED
    report = json.loads(capsys.readouterr().out)
    assert (report["width"], report["height"]) == (480, 48) and report["different_pixels"] == 432 * 48


def test_masked_regions_are_not_compared(tmp_path, capsys):
    a = np.full((8, 10, 4), 255, np.uint8)
    b = a.copy()
    b[1:3, 2:4, :3] = 0  # a 2x2 change
    b[6, 9, :3] = 0  # a 1x1 change
    for name, img in (("a.png", a), ("b.png", b)):
        Image.fromarray(img, "RGBA").save(tmp_path / name)
    A, B = str(tmp_path / "a.png"), str(tmp_path / "b.png")
    assert main(["diff", A, B, "--json"]) == Exit.FAILED
    assert json.loads(capsys.readouterr().out)["different_pixels"] == 5
    assert main(["diff", A, B, "--mask", "2,1,2,2", "--json"]) == Exit.FAILED
    report = json.loads(capsys.readouterr().out)
    assert report["different_pixels"] == 1 and report["ignored_pixels"] == 4 and report["total_pixels"] == 76
    # rectangles are in the pixels at scale 1: the same mask at 4x
    assert main(["diff", A, B, "--mask", "2,1,2,2", "--mask", "9,6,1,1", "--scale", "4"]) == Exit.OK
    capsys.readouterr()
    # a mask image: light pixels are ignored; it is stretched to the comparison
    mask = np.zeros((4, 5), np.uint8)
    mask[0:2, 1:2] = 255
    mask[3, 4] = 255
    Image.fromarray(mask, "L").save(tmp_path / "mask.png")
    assert main(["diff", A, B, "--mask", str(tmp_path / "mask.png"), "--json"]) == Exit.OK
    assert json.loads(capsys.readouterr().out)["ignored_pixels"] == 12
    Image.fromarray(np.zeros((4, 4), np.uint8), "L").save(tmp_path / "square.png")
    assert main(["diff", A, B, "--mask", str(tmp_path / "square.png")]) == Exit.USAGE
    assert "does not have the shape" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["diff", A, B, "--mask", "1,2,0,3"])
    assert "width and height must be over 0" in capsys.readouterr().err


def test_diff_out_must_be_named_png(heart_svg, tmp_path, capsys):
    """Issue 35: --diff-out d.svg wrote PNG bytes into a .svg name."""
    for name in ("d.svg", "d.jpg", "d"):
        with pytest.raises(SystemExit) as exit_info:
            main(["diff", str(heart_svg), str(heart_svg), "--diff-out", str(tmp_path / name)])
        assert exit_info.value.code == Exit.USAGE
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "name it .png" in err
        assert not (tmp_path / name).exists()


def test_pdf_renders_compare_like_svgs(heart_svg, tmp_path, capsys):
    pytest.importorskip("pypdfium2", reason="PDF comparisons need pypdfium2 (pip install 'depixel[pdf]')")
    pdf = tmp_path / "heart.pdf"
    assert main(["render", str(heart_svg), "-o", str(pdf)]) == Exit.OK
    assert main(["diff", str(pdf), str(heart_svg), "--max-ratio", "0.01", "--json"]) == Exit.OK
    report = json.loads(capsys.readouterr().out)
    assert (report["width"], report["height"]) == (40, 40)
    assert main(["diff", str(pdf), str(FIXTURES / "ghost.png")]) == Exit.USAGE  # 40x40 against 18x16
