"""Every image mode and every awkward shape converts to a sensible SVG (docs/colour.md,
"Input modes"): the loaded RGBA is what the mode means, the SVG parses, and every pixel
centre renders in its colour."""
from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image
from robust import assert_centres_kept, convert, fills, parse, png_bytes, png_chunk, visible_colours

from depixel.prepare.image import as_rgba, load_image

# a small sprite drawn with four indices; each mode below gives the four values in its own
# terms and the RGBA they mean
INDEX = np.array([
    [0, 0, 1, 1, 0, 0],
    [0, 1, 2, 2, 1, 0],
    [1, 2, 3, 3, 2, 1],
    [0, 1, 2, 2, 1, 0],
    [0, 0, 1, 1, 0, 0],
])


def grey(*values):
    return [(v, v, v, 255) for v in values]


# mode: (native values of indices 0-3, expected RGBA, tolerance)
MODES = {
    "1": ([0, 255, 0, 255], grey(0, 255, 0, 255), 0),
    "L": ([0, 90, 180, 255], grey(0, 90, 180, 255), 0),
    "LA": ([(0, 0), (90, 255), (180, 128), (255, 255)],
           [(0, 0, 0, 0), (90, 90, 90, 255), (180, 180, 180, 128), (255, 255, 255, 255)], 0),
    "RGB": ([(0, 0, 0), (200, 30, 30), (30, 200, 30), (30, 30, 200)],
            [(0, 0, 0, 255), (200, 30, 30, 255), (30, 200, 30, 255), (30, 30, 200, 255)], 0),
    "RGBA": ([(0, 0, 0, 0), (200, 30, 30, 255), (30, 200, 30, 100), (30, 30, 200, 255)],
             [(0, 0, 0, 0), (200, 30, 30, 255), (30, 200, 30, 100), (30, 30, 200, 255)], 0),
    "RGBX": ([(0, 0, 0, 0), (200, 30, 30, 7), (30, 200, 30, 0), (30, 30, 200, 0)],
             [(0, 0, 0, 255), (200, 30, 30, 255), (30, 200, 30, 255), (30, 30, 200, 255)], 0),
    "RGBa": ([(0, 0, 0, 0), (200, 30, 30, 255), (100, 15, 15, 128), (30, 30, 200, 255)],
             [(0, 0, 0, 0), (200, 30, 30, 255), (200, 30, 30, 128), (30, 30, 200, 255)], 2),
    "La": ([(0, 0), (90, 255), (45, 128), (255, 255)],
           [(0, 0, 0, 0), (90, 90, 90, 255), (90, 90, 90, 128), (255, 255, 255, 255)], 2),
    "I;16": ([0, 90 * 257, 180 * 257, 65535], grey(0, 90, 180, 255), 0),
    "I;16B": ([0, 90 * 257, 180 * 257, 65535], grey(0, 90, 180, 255), 0),
    "I;16L": ([0, 90 * 257, 180 * 257, 65535], grey(0, 90, 180, 255), 0),
    "I;16N": ([0, 90 * 257, 180 * 257, 65535], grey(0, 90, 180, 255), 0),
    # 32-bit integers: 0-255 data is taken as 8-bit, anything larger as 16-bit
    "I": ([0, 1000, 40000, 65535], grey(0, 4, 156, 255), 0),
    "F": ([0.0, 0.25, 0.5, 1.0], grey(0, 64, 128, 255), 0),
    "CMYK": ([(0, 0, 0, 0), (0, 0, 0, 255), (255, 0, 0, 0), (0, 255, 255, 0)],
             [(255, 255, 255, 255), (0, 0, 0, 255), (0, 255, 255, 255), (255, 0, 0, 255)], 0),
    "YCbCr": ([(0, 128, 128), (255, 128, 128), (128, 128, 128), (90, 128, 128)],
              grey(0, 255, 128, 90), 1),
    "HSV": ([(0, 255, 255), (85, 255, 255), (170, 255, 255), (0, 0, 255)],
            [(255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255, 255, 255, 255)], 0),
    "LAB": ([(0, 128, 128), (255, 128, 128), (0, 128, 128), (255, 128, 128)], grey(0, 255, 0, 255), 2),
}


def build(mode: str) -> tuple[Image.Image, np.ndarray, int]:
    """The sprite as a Pillow image of ``mode``, its expected RGBA and the tolerance."""
    values, rgba, tol = MODES[mode]
    h, w = INDEX.shape
    img = Image.new(mode, (w, h))
    for (r, c), i in np.ndenumerate(INDEX):
        img.putpixel((c, r), values[i])
    return img, np.array(rgba, np.uint8)[INDEX], tol


def assert_rgba(got: np.ndarray, want: np.ndarray, tol: int) -> None:
    assert got.shape == want.shape and got.dtype == np.uint8
    diff = np.abs(got.astype(int) - want.astype(int))
    diff[..., :3][want[..., 3] == 0] = 0  # hidden colour of a fully transparent pixel
    assert diff.max() <= tol, f"max difference {diff.max()} at {np.unravel_index(diff.argmax(), diff.shape)}"


@pytest.mark.parametrize("mode", sorted(MODES))
def test_every_pillow_mode_means_what_it_says(mode):
    img, want, tol = build(mode)
    assert img.mode == mode
    rgba = as_rgba(img)
    assert_rgba(rgba, want, tol)
    assert_centres_kept(rgba, convert(rgba))


def test_every_pillow_mode_is_covered():
    assert set(MODES) >= set(Image.MODES) - {"P", "PA"}  # P, PA: palette tests below


@pytest.mark.parametrize("mode, fmt", [
    ("1", "PNG"), ("L", "PNG"), ("LA", "PNG"), ("RGB", "PNG"), ("RGBA", "PNG"), ("I;16", "PNG"),
    ("I;16", "TIFF"), ("I;16B", "TIFF"), ("I", "TIFF"), ("F", "TIFF"), ("CMYK", "TIFF"),
    ("CMYK", "JPEG"), ("LAB", "TIFF"), ("YCbCr", "TIFF"), ("LA", "TGA"), ("1", "BMP"),
    ("RGB", "BMP"), ("RGBA", "WEBP"),
])
def test_modes_survive_a_file_round_trip(mode, fmt):
    img, want, tol = build(mode)
    buf = io.BytesIO()
    img.save(buf, fmt, **({"lossless": True} if fmt == "WEBP" else {"quality": 100} if fmt == "JPEG" else {}))
    if fmt == "JPEG":
        tol = 8  # lossy
    rgba = load_image(buf.getvalue())
    assert_rgba(rgba, want, tol)
    assert_centres_kept(rgba, convert(rgba))


PALETTE = [(0, 0, 0), (200, 30, 30), (30, 200, 30), (30, 30, 200)]


def palette_image(mode: str = "P") -> Image.Image:
    img = Image.fromarray(INDEX.astype(np.uint8), "P")
    img.putpalette([v for rgb in PALETTE for v in rgb])
    return img


def test_palette_with_trns_chunk_per_entry():
    buf = io.BytesIO()
    palette_image().save(buf, "PNG", transparency=bytes([0, 255, 128, 255]))
    rgba = load_image(buf.getvalue())
    want = np.array([(0, 0, 0, 0), (200, 30, 30, 255), (30, 200, 30, 128), (30, 30, 200, 255)], np.uint8)
    assert_rgba(rgba, want[INDEX], 0)
    assert_centres_kept(rgba, convert(rgba))


@pytest.mark.parametrize("fmt", ["PNG", "GIF"])
def test_palette_with_one_transparent_index(fmt):
    buf = io.BytesIO()
    palette_image().save(buf, fmt, transparency=2)
    rgba = load_image(buf.getvalue())
    want = np.array([(0, 0, 0, 255), (200, 30, 30, 255), (0, 0, 0, 0), (30, 30, 200, 255)], np.uint8)
    assert_rgba(rgba, want[INDEX], 0)


def test_palette_with_alpha_channel_pa():
    img = palette_image().convert("PA")
    img.putpixel((0, 0), (0, 77))
    rgba = as_rgba(img)
    want = np.array([(0, 0, 0, 255), (200, 30, 30, 255), (30, 200, 30, 255), (30, 30, 200, 255)], np.uint8)[INDEX]
    want[0, 0, 3] = 77
    assert_rgba(rgba, want, 0)


@pytest.mark.parametrize("mode, key", [("L", 90), ("RGB", (30, 200, 30)), ("1", 0)])
def test_colour_key_transparency(mode, key):
    img, want, _ = build(mode)
    buf = io.BytesIO()
    img.save(buf, "PNG", transparency=key)
    rgba = load_image(buf.getvalue())
    keyed = np.array([v == key for v in MODES[mode][0]])[INDEX]
    want = want.copy()
    want[keyed, 3] = 0
    assert keyed.any()
    assert_rgba(rgba, want, 0)


def grey16_rows(values: np.ndarray) -> bytes:
    return values.astype(">u2").tobytes()


def test_16_bit_grey_png_is_scaled_not_clipped():
    values = np.array([[0, 257, 32896], [40000, 65534, 65535]])
    rgba = load_image(png_bytes(3, 2, 16, 0, grey16_rows(values)))
    assert rgba[..., 0].tolist() == np.round(values / 65535 * 255).astype(int).tolist()
    assert (rgba[..., 3] == 255).all()


def test_16_bit_grey_png_with_trns_key():
    values = np.array([[0, 1000, 1000], [1001, 65535, 1000]])
    data = png_bytes(3, 2, 16, 0, grey16_rows(values), extra=png_chunk(b"tRNS", (1000).to_bytes(2, "big")))
    rgba = load_image(data)
    assert (rgba[..., 3] == 0).tolist() == (values == 1000).tolist()
    assert_centres_kept(rgba, convert(rgba))


@pytest.mark.parametrize("colour_type, samples, want", [
    (2, [65535, 32768, 0], (255, 128, 0, 255)),  # RGB 16-bit
    (4, [32768, 16384], (128, 128, 128, 64)),  # grey + alpha 16-bit
    (6, [65535, 32768, 0, 32768], (255, 128, 0, 128)),  # RGBA 16-bit
])
def test_16_bit_colour_pngs(colour_type, samples, want):
    pixels = np.array([samples] * 4).astype(">u2").tobytes()
    rgba = load_image(png_bytes(2, 2, 16, colour_type, pixels))
    assert rgba.shape == (2, 2, 4)
    assert (np.abs(rgba.astype(int) - np.array(want)) <= 1).all(), rgba[0, 0]


@pytest.mark.parametrize("depth", [1, 2, 4])
def test_low_bit_depth_grey_and_palette(depth):
    top = 2**depth - 1
    row = [0, top, 0, top, 0, top, 0, top]
    packed = np.packbits(np.unpackbits(np.array(row, np.uint8)[:, None], axis=1)[:, 8 - depth:].ravel()).tobytes()
    rgba = load_image(png_bytes(8, 2, depth, 0, packed * 2))
    assert rgba[0, :, 0].tolist() == [0, 255] * 4
    plte = png_chunk(b"PLTE", bytes([10, 20, 30] + [200, 100, 50] * top))
    rgba = load_image(png_bytes(8, 2, depth, 3, packed * 2, extra=plte))
    assert rgba[1, :2, :3].tolist() == [[10, 20, 30], [200, 100, 50]]


def test_animated_gif_frames():
    first = load_image(FIXTURES / "heart_beat.gif")
    second = load_image(FIXTURES / "heart_beat.gif", frame=1)
    assert first.shape == second.shape and (np.roll(first, 1, axis=0) == second).all()


def test_wrong_extension_is_fine_when_the_content_is_an_image(tmp_path):
    path = tmp_path / "sprite.gif"  # a PNG in disguise
    path.write_bytes((FIXTURES / "heart_trns.png").read_bytes())
    assert (load_image(path) == load_image(FIXTURES / "heart_trns.png")).all()


@pytest.mark.parametrize("dtype, values, want", [
    (np.uint8, [0, 90, 255], [0, 90, 255]),
    (np.uint16, [0, 90 * 257, 65535], [0, 90, 255]),
    (np.int64, [-5, 90, 300], [0, 90, 255]),
    (np.float32, [0.0, 0.5, 1.0], [0, 128, 255]),
    (np.float64, [-3.0, 90.4, 1e9], [0, 90, 255]),  # (NaN and infinities are refused: test_streams_and_bounds)
    (np.bool_, [False, True, True], [0, 255, 255]),
])
def test_arrays_of_any_numeric_dtype(dtype, values, want):
    rgba = as_rgba(np.array([values], dtype=dtype))
    assert rgba[0, :, 0].tolist() == want and (rgba[..., 3] == 255).all()


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (7, 1), (1, 300), (300, 1)])
def test_thin_shapes(shape):
    rng = np.random.default_rng(sum(shape))
    palette = np.array([(0, 0, 0, 255), (250, 250, 250, 255), (200, 30, 30, 255), (0, 0, 0, 0)], np.uint8)
    rgba = palette[rng.integers(0, 4, size=shape)]
    svg = convert(rgba)
    parse(svg)
    assert_centres_kept(rgba, svg)


def test_single_colour():
    rgba = np.full((9, 13, 4), (40, 120, 200, 255), np.uint8)
    svg = convert(rgba)
    assert fills(parse(svg)) == {("#2878c8", 1.0)}
    assert_centres_kept(rgba, svg)


@pytest.mark.parametrize("colours", [
    [(0, 0, 0, 255), (255, 255, 255, 255)],
    [(220, 30, 30, 255), (0, 0, 0, 0)],
    [(30, 60, 220, 255), (30, 60, 220, 128)],
])
def test_full_image_checkerboard(colours):
    yy, xx = np.mgrid[:16, :16]
    rgba = np.array(colours, np.uint8)[(yy + xx) % 2]
    svg = convert(rgba)
    parse(svg)
    assert_centres_kept(rgba, svg)


def test_every_pixel_a_different_colour():
    rng = np.random.default_rng(7)
    codes = rng.choice(2**24, size=16 * 16, replace=False)
    rgb = np.stack([(codes >> 16) & 255, (codes >> 8) & 255, codes & 255], axis=1).astype(np.uint8)
    rgba = np.concatenate([rgb, np.full((256, 1), 255, np.uint8)], axis=1).reshape(16, 16, 4)
    svg = convert(rgba)
    assert fills(parse(svg)) == visible_colours(rgba)  # no colour lost or merged
    assert_centres_kept(rgba, svg)


def test_fixtures_of_every_kind_load_and_convert():
    for path in sorted(FIXTURES.glob("*.png")) + sorted(FIXTURES.glob("*.gif")):
        rgba = load_image(path)
        assert_centres_kept(rgba, convert(rgba, title=path.name))
