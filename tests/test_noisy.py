"""The hint for lossless inputs that look anti-aliased or noisy (depixel/prepare/noisy.py).

It must fire on pixel art that went through a smoothing filter or a JPEG before it was saved
as PNG, and never on clean pixel art (the fixtures, the corpus) nor on smooth gradients.
"""
from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, fixture_pngs, needs_corpus
from PIL import Image

from depixel import load_image
from depixel.prepare import noisy
from depixel.prepare.inputs import prepare
from depixel.prepare.noisy import noise_hint
from depixel_cli.main import main


def ghost() -> np.ndarray:
    return load_image(FIXTURES / "ghost.png")


def through_jpeg(rgba: np.ndarray, quality: int) -> np.ndarray:
    """The pixels of a JPEG of ``rgba``, as a PNG saved from it holds them (lossless from now on)."""
    buffer = io.BytesIO()
    Image.fromarray(rgba[..., :3], "RGB").save(buffer, "JPEG", quality=quality)
    return np.asarray(Image.open(io.BytesIO(buffer.getvalue())).convert("RGBA"))


def with_noise(rgba: np.ndarray, amplitude: int, seed: int = 1) -> np.ndarray:
    out = rgba.astype(np.int64)
    out[..., :3] += np.random.default_rng(seed).integers(-amplitude, amplitude + 1, size=out[..., :3].shape)
    return np.clip(out, 0, 255).astype(np.uint8)


def anti_aliased(rgba: np.ndarray, factor: int = 8, down: int = 4) -> np.ndarray:
    """The art drawn ``factor``× larger, slightly rotated (edges no longer on the grid), then
    reduced to ``factor / down``× with a box filter: every edge pixel a blend."""
    big = Image.fromarray(rgba, "RGBA").resize((rgba.shape[1] * factor, rgba.shape[0] * factor), Image.NEAREST)
    big = big.rotate(7, resample=Image.BICUBIC, fillcolor=tuple(int(v) for v in rgba[0, 0]))
    small = big.resize((big.width // down, big.height // down), Image.BOX)
    return np.asarray(small.convert("RGBA"))


def gradient_icon() -> np.ndarray:
    """An icon of horizontal gradient bars (like the corpus's icon_disk): many colours, each a
    step of a few levels from the next, all running one way."""
    h, w = 24, 32
    out = np.full((h, w, 4), 255, np.uint8)
    ramp = np.linspace(0.0, 1.0, w)[:, None]
    for i, row in enumerate(range(2, h - 2, 3)):
        start, end = np.array([150 + 10 * i, 190, 250]), np.array([20 + 5 * i, 70, 200 - 8 * i])
        out[row, :, :3] = np.round(start + (end - start) * ramp).astype(np.uint8)
        out[row + 1, :, :3] = np.round((start + (end - start) * ramp) * 0.92).astype(np.uint8)
    return out


@pytest.mark.parametrize("make, why", [
    (lambda: through_jpeg(ghost(), 90), "off their neighbours"),
    (lambda: through_jpeg(ghost(), 75), "off their neighbours"),
    (lambda: with_noise(ghost(), 4), "off their neighbours"),
    (lambda: anti_aliased(ghost()), "blends along edges (anti-aliased?)"),
], ids=["jpeg-q90", "jpeg-q75", "noise-4", "anti-aliased"])
def test_the_hint_fires_on_smoothed_or_noisy_art_with_its_numbers(make, why):
    rgba = make()
    colours = len(np.unique(rgba.reshape(-1, 4), axis=0))
    hint = noise_hint(rgba)
    assert hint is not None and why in hint
    assert hint.startswith(f"{colours} colours, ")
    snapped = prepare(rgba, denoise=True)
    assert hint.endswith(f": denoise snaps them to {snapped.palette} (--denoise)") and snapped.palette < colours / 5


@pytest.mark.parametrize("path", fixture_pngs(), ids=lambda p: p.name)
def test_no_hint_on_the_fixtures(path):
    assert noise_hint(load_image(path)) is None


@needs_corpus
def test_no_hint_on_the_corpus():
    """The 54 sprites of the paper and the SNES frames: all clean (icon_disk, 198 colours of
    gradients, passes the colour count and must fail both other tests)."""
    paths = sorted(CORPUS.glob("*.png")) + sorted((CORPUS.parent / "frames").glob("*.png"))
    fired = {p.name: hint for p in paths if (hint := noise_hint(load_image(p))) is not None}
    assert fired == {}


def test_no_hint_on_a_gradient():
    icon = gradient_icon()
    assert len(np.unique(icon.reshape(-1, 4), axis=0)) >= noisy.MIN_COLOURS  # past the colour count
    assert noise_hint(icon) is None


def test_prepare_notes_the_hint_only_when_denoise_is_undecided():
    rgba = through_jpeg(ghost(), 90)
    hint = noise_hint(rgba)
    assert prepare(rgba).notes == (hint,)
    assert hint in prepare(rgba).describe("ghost.png")
    assert prepare(rgba, denoise=False).notes == () and prepare(rgba, denoise=True).notes == ()
    assert prepare(rgba, lossy="JPEG").notes == ()  # a lossy file is denoised already


def test_the_command_prints_the_hint_once(tmp_path, capsys):
    Image.fromarray(with_noise(ghost(), 4)).save(tmp_path / "noisy.png")
    assert main(["convert", str(tmp_path / "noisy.png"), "-o", str(tmp_path / "noisy.svg")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert [line for line in err if "--denoise" in line] == [
        f"depixel: note: {tmp_path / 'noisy.png'}: {noise_hint(with_noise(ghost(), 4))}"]
    assert main(["convert", str(tmp_path / "noisy.png"), "-o", str(tmp_path / "noisy.svg"), "-q"]) == 0
    assert capsys.readouterr().err == ""
