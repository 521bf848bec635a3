"""Undoing chroma subsampling on lossy 1× pixel art (depixel/prepare/chroma.py, chroma_unmix.py): the decoder's model,
its detection from the pixels, and the joint labelling."""
from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import FIXTURES, corpus_pngs, needs_corpus
from PIL import Image

from depixel import load_image
from depixel.colour import rgb_to_yuv
from depixel.prepare.chroma import ChromaGrid, chroma_grid, yuv_to_rgb
from depixel.prepare.chroma_unmix import unmix
from depixel.prepare.inputs import prepare

GRIDS = [ChromaGrid((2, 2)), ChromaGrid((2, 2), smooth=False), ChromaGrid((1, 2)), ChromaGrid((1, 2), smooth=False)]
#: saturated colours; red, green and blue of one luma (97): only chroma tells them apart, the hard
#: case for subsampled chroma
PALETTE = np.array([[255, 255, 255], [0, 0, 0], [230, 40, 40], [10, 150, 50], [70, 80, 255], [250, 200, 40]],
                   dtype=np.float64)


def jpeg_pixels(rgb: np.ndarray, quality: int, subsampling: int) -> np.ndarray:
    """Pillow's JPEG (subsampling 0: 4:4:4, 1: 4:2:2, 2: 4:2:0) of an RGB image, decoded."""
    buffer = io.BytesIO()
    Image.fromarray(rgb[..., :3].astype(np.uint8), "RGB").save(buffer, "JPEG", quality=quality,
                                                               subsampling=subsampling)
    return np.asarray(Image.open(buffer).convert("RGBA"))


def blobby_art(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """``(h, w)`` labels into PALETTE: 2×2 runs with a quarter of the pixels changed (one-pixel
    features everywhere, as in small sprites)."""
    labels = rng.integers(0, len(PALETTE), (h // 2 + 1, w // 2 + 1)).repeat(2, 0).repeat(2, 1)[:h, :w]
    return np.where(rng.random((h, w)) < 0.25, rng.integers(0, len(PALETTE), (h, w)), labels)


def decoded(art_rgb: np.ndarray, grid: ChromaGrid) -> np.ndarray:
    """What a decoder following ``grid`` gives back for ``art_rgb``: luma per pixel, chroma
    through the block means and the upsampling, rounded and clipped to 8-bit RGB."""
    yuv = rgb_to_yuv(art_rgb)
    yuv[..., 1:] = grid.up(grid.down(yuv[..., 1:]), art_rgb.shape[:2])
    rgb = np.clip(np.round(yuv_to_rgb(yuv)), 0, 255).astype(np.uint8)
    return np.concatenate([rgb, np.full(art_rgb.shape[:2] + (1,), 255, np.uint8)], axis=-1)


def dense_up(grid: ChromaGrid, shape: tuple[int, int]) -> np.ndarray:
    """Slow reference: the upsampling as an explicit (pixels × samples) matrix, from its
    definition (libjpeg's triangle filter, or repetition)."""
    per_axis = []
    for n, k in zip(shape, grid.block):
        if k == 1:
            per_axis.append(np.eye(n))
            continue
        m = (n + 1) // 2
        matrix = np.zeros((n, m))
        for p in range(n):
            own = p // 2
            if not grid.smooth:
                matrix[p, own] = 1.0
                continue
            other = min(max(own - 1 if p % 2 == 0 else own + 1, 0), m - 1)
            matrix[p, own] += 0.75
            matrix[p, other] += 0.25
        per_axis.append(matrix)
    return np.kron(per_axis[0], per_axis[1])


# --- the decoder's model --------------------------------------------------------------------------

@pytest.mark.parametrize("grid", GRIDS, ids=str)
@pytest.mark.parametrize("shape", [(6, 8), (7, 9), (5, 2)])
def test_up_down_and_the_adjoint_match_the_dense_definition(grid, shape):
    rng = np.random.default_rng(1)
    h, w = shape
    bh, bw = (h + grid.block[0] - 1) // grid.block[0], (w + grid.block[1] - 1) // grid.block[1]
    up = dense_up(grid, shape)
    samples = rng.random((bh, bw, 2))
    pixels = rng.random((h, w, 2))
    np.testing.assert_allclose(grid.up(samples, shape).reshape(-1, 2), up @ samples.reshape(-1, 2), atol=1e-12)
    np.testing.assert_allclose(grid.up_adjoint(pixels).reshape(-1, 2), up.T @ pixels.reshape(-1, 2), atol=1e-12)
    # down: the mean of each block, an odd edge row or column alone (JPEG repeats the edge pixel)
    ys, xs = np.indices((h, w))
    block = (ys // grid.block[0]) * bw + xs // grid.block[1]
    weight = np.ones((h, w))
    for axis, (n, k) in enumerate(zip(shape, grid.block)):
        if k == 2:
            along = np.where((np.arange(n) == n - 1) & (n % 2 == 1), 1.0, 0.5)
            weight = weight * (along[:, None] if axis == 0 else along[None, :])
    expected = np.zeros((bh * bw, 2))
    np.add.at(expected, block.ravel(), (pixels * weight[..., None]).reshape(-1, 2))
    np.testing.assert_allclose(grid.down(pixels).reshape(-1, 2), expected, atol=1e-12)
    # the gram matrix used by the labelling is upᵀup
    gram = np.eye(bh * bw)
    per_axis = grid.gram(shape)
    dense = up.T @ up
    for axis, diagonal, off in per_axis:
        matrix = np.diag(diagonal) + np.diag(off, 1) + np.diag(off, -1)
        other = np.eye(bw if axis == 0 else bh)
        gram = gram @ (np.kron(matrix, other) if axis == 0 else np.kron(other, matrix))
    np.testing.assert_allclose(gram, dense, atol=1e-12)


@pytest.mark.parametrize("subsampling, block", [(2, (2, 2)), (1, (1, 2))])
@pytest.mark.parametrize("shape", [(16, 16), (17, 23)])
def test_the_smooth_model_is_what_libjpeg_decodes(subsampling, block, shape):
    """Random pixels (every chroma sample differs) at quality 100: Pillow's decoder gives back
    the model's chroma to within JPEG's rounding (mean 0.4 measured, odd sizes included)."""
    rgb = np.random.default_rng(2).integers(0, 256, shape + (3,)).astype(np.float64)
    got = jpeg_pixels(rgb, 100, subsampling)
    inside = ((got[..., :3] > 3) & (got[..., :3] < 252)).all(axis=-1)  # not clipped by the decoder
    grid = ChromaGrid(block)
    model = grid.up(grid.down(rgb_to_yuv(rgb)[..., 1:]), shape)
    error = np.abs(model - rgb_to_yuv(got)[..., 1:])[inside]
    assert error.mean() < 0.6 and np.percentile(error, 99) < 2.0


# --- detection ------------------------------------------------------------------------------------

@pytest.mark.parametrize("quality", [70, 85, 95])
def test_pillow_jpegs_subsampling_is_found_from_the_pixels(quality):
    rgb = PALETTE[blobby_art(np.random.default_rng(quality), 40, 48)]
    assert chroma_grid(rgb_to_yuv(jpeg_pixels(rgb, quality, 2))) == ChromaGrid((2, 2))
    assert chroma_grid(rgb_to_yuv(jpeg_pixels(rgb, quality, 1))) == ChromaGrid((1, 2))
    assert chroma_grid(rgb_to_yuv(jpeg_pixels(rgb, quality, 0))) is None


@pytest.mark.parametrize("grid", GRIDS, ids=str)
def test_a_decoder_that_repeats_the_samples_is_told_apart(grid):
    rgb = PALETTE[blobby_art(np.random.default_rng(3), 30, 34)]
    assert chroma_grid(rgb_to_yuv(decoded(rgb, grid))) == grid


def test_no_subsampling_is_seen_in_lossless_noise_grey_or_flat_images():
    rng = np.random.default_rng(4)
    art = PALETTE[blobby_art(rng, 30, 34)]
    noisy = np.clip(art + rng.integers(-3, 4, art.shape), 0, 255)
    assert chroma_grid(rgb_to_yuv(art)) is None
    assert chroma_grid(rgb_to_yuv(noisy)) is None
    grey = np.repeat(rng.integers(0, 256, (30, 34, 1)), 3, axis=2)
    assert chroma_grid(rgb_to_yuv(grey)) is None  # no chroma at all: nothing to undo
    assert chroma_grid(rgb_to_yuv(np.full((3, 3, 3), 80.0))) is None  # too small to tell


# --- joint labelling ------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("grid", GRIDS[:3], ids=str)
def test_the_art_comes_back_from_its_decoded_pixels(seed, grid):
    """Decoded exactly by the model (chroma mixed in every block, clipped), the labels come
    back better than by the nearest palette colour (measured on these: 0.91-0.99 against
    0.85-0.93; by luma alone 0.69-0.83). Dense one-pixel features of three colours of one
    luma are ambiguous: one chroma sample for four pixels."""
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(12, 30, 2))
    truth = blobby_art(rng, h, w)
    pixels = decoded(PALETTE[truth], grid)
    labels, palette = unmix(pixels, PALETTE, grid)
    nearest = np.argmin(np.abs(rgb_to_yuv(pixels)[..., None, :] - rgb_to_yuv(PALETTE)).max(axis=-1), axis=-1)
    assert (labels == truth).mean() >= max(0.9, (nearest == truth).mean() + 0.01)
    assert (np.abs(palette[labels] - PALETTE[truth]).max(axis=-1) <= 16).mean() >= 0.9


def test_a_colour_seen_only_in_thin_strokes_is_grown_and_unmixed():
    """Dark red one-pixel strokes on a white panel over cyan (like smw_help's lettering): in
    the decoded pixels the strokes are a washed-out mix, far from red. Started without red,
    the labelling grows a colour for the pixels whose luma nothing explains, and the refit
    takes its chroma out of the mixed blocks: red comes back (measured: (123-127, 4-5, 4-5))."""
    colours = np.array([[118, 252, 252], [248, 248, 248], [136, 0, 0]], dtype=np.float64)
    rng = np.random.default_rng(0)
    truth = np.zeros((24, 32), dtype=int)
    truth[4:20, 3:29] = 1
    for _ in range(10):
        y, x = rng.integers(5, 19), rng.integers(4, 24)
        if rng.random() < 0.5:
            truth[y, x:x + 5] = 2
        else:
            truth[y:y + 4, x] = 2
    pixels = decoded(colours[truth], ChromaGrid((2, 2)))
    stroke = truth == 2
    assert np.abs(pixels[stroke][:, :3].mean(axis=0) - colours[2]).max() > 40  # not in the file as such
    labels, palette = unmix(pixels, colours[:2], ChromaGrid((2, 2)))
    assert len(palette) == 3 and np.abs(palette[2] - colours[2]).max() <= 16
    assert (np.abs(palette[labels] - colours[truth]).max(axis=-1) <= 16).all()


def test_transparent_pixels_take_no_label_and_keep_their_chroma():
    rng = np.random.default_rng(5)
    truth = blobby_art(rng, 20, 20)
    pixels = decoded(PALETTE[truth], ChromaGrid((2, 2)))
    pixels[:5, :, 3] = 0
    labels, palette = unmix(pixels, PALETTE, ChromaGrid((2, 2)))
    assert (labels[:5] == -1).all()
    assert (labels[5:] == truth[5:]).mean() >= 0.9


# --- through prepare -------------------------------------------------------------------------------

@pytest.mark.parametrize("quality", [85, 90, 95])
def test_a_4_2_0_jpeg_of_the_ghost_comes_back(quality):
    """Measured: every pixel within 16 of the truth at q85-95 (nearest colour: 0.79 to 0.85)."""
    ghost = load_image(FIXTURES / "ghost.png")
    prepared = prepare(jpeg_pixels(ghost, quality, 2), lossy="JPEG")
    assert prepared.subsampling == "4:2:0" and "4:2:0 chroma unmixed" in prepared.describe("g.jpg")
    assert prepared.palette == 3
    assert (np.abs(prepared.rgba[..., :3].astype(int) - ghost[..., :3]).max(axis=-1) <= 16).all()


def test_a_4_4_4_jpeg_keeps_the_nearest_colour():
    ghost = load_image(FIXTURES / "ghost.png")
    pixels = jpeg_pixels(ghost, 85, 0)
    prepared = prepare(pixels, lossy="JPEG")
    assert prepared.subsampling is None and prepared.summary()["subsampling"] is None
    from depixel.prepare.inputs import snap_colours  # noqa: PLC0415

    np.testing.assert_array_equal(prepared.rgba, snap_colours(pixels)[0])


@needs_corpus
def test_paper_sprites_as_4_2_0_jpegs_come_back_better_than_by_nearest_colour():
    """A sample of the paper sprites at q85: pixels within 16 of the truth (the judge's centre
    test). Measured on all 54: median 0.88 (nearest colour: 0.74), docs/inputs.md."""
    from depixel.prepare.inputs import snap_colours  # noqa: PLC0415

    joint, nearest = [], []
    for path in corpus_pngs()[::6]:
        clean = load_image(path)
        pixels = jpeg_pixels(clean, 85, 2)
        joint.append((np.abs(prepare(pixels, lossy="JPEG").rgba[..., :3].astype(int) - clean[..., :3]).max(-1)
                      <= 16).mean())
        nearest.append((np.abs(snap_colours(pixels)[0][..., :3].astype(int) - clean[..., :3]).max(-1) <= 16).mean())
    assert np.median(joint) >= np.median(nearest) + 0.05
    assert sum(j >= n - 0.01 for j, n in zip(joint, nearest)) >= 0.75 * len(joint)
