"""Make the figures of docs/inputs.md from the project's own fixtures.

    python docs/img/inputs_figures.py

Each figure is one PNG of three panels at the same size: the input as a user has it
(nearest neighbour), what depixel made of it taken as it is (``pixel_size=1``,
``denoise=False``), and what it makes with the default options (or ``transparent="auto"``),
over a light checkerboard where the result is transparent.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import depixel
from depixel.prepare.image import load_image
from depixel.render.raster import render_rgba

HERE = Path(__file__).resolve().parent
FIXTURES = HERE.parent.parent / "fixtures"
GAP, TITLE = 8, 16
PANEL = 240  # panel width in pixels


def checkerboard(h: int, w: int, cell: int = 8) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    board = np.where((y // cell + x // cell) % 2, 235, 250).astype(np.uint8)
    return np.stack([board] * 3 + [np.full_like(board, 255)], axis=-1)


def shown(rgba: np.ndarray) -> Image.Image:
    back = Image.fromarray(checkerboard(*rgba.shape[:2]))
    return Image.alpha_composite(back, Image.fromarray(rgba, "RGBA")).convert("RGB")


def nearest(rgba: np.ndarray, width: int) -> Image.Image:
    height = round(rgba.shape[0] * width / rgba.shape[1])
    return shown(np.asarray(Image.fromarray(rgba, "RGBA").resize((width, height), Image.Resampling.NEAREST)))


def svg_panel(svg: str, width: int) -> Image.Image:
    return shown(render_rgba(svg, width=width))


def jpeg(rgba: np.ndarray, quality: int) -> np.ndarray:
    buffer = io.BytesIO()
    Image.fromarray(rgba[..., :3], "RGB").save(buffer, "JPEG", quality=quality)
    return np.asarray(Image.open(io.BytesIO(buffer.getvalue())).convert("RGBA"))


def row(panels: list[tuple[str, Image.Image]]) -> Image.Image:
    height = max(p.height for _, p in panels)
    sheet = Image.new("RGB", (len(panels) * (PANEL + GAP) + GAP, height + TITLE + 2 * GAP), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for i, (title, panel) in enumerate(panels):
        x = GAP + i * (PANEL + GAP)
        draw.text((x, GAP // 2), title, fill=(40, 40, 40))
        sheet.paste(panel, (x, GAP + TITLE))
    return sheet


def stack(rows: list[Image.Image]) -> Image.Image:
    sheet = Image.new("RGB", (max(r.width for r in rows), sum(r.height for r in rows)), (255, 255, 255))
    y = 0
    for r in rows:
        sheet.paste(r, (0, y))
        y += r.height
    return sheet


def main() -> None:
    ghost = load_image(FIXTURES / "ghost.png")
    mushroom = load_image(FIXTURES / "mushroom.png")
    leaf = load_image(FIXTURES / "leaf.png")

    # 1. saved 4× (and cropped by 3 and 2 pixels at the left and top), and 3×2 (wide pixels)
    crop = ghost.repeat(4, axis=0).repeat(4, axis=1)[2:, 3:]
    wide = leaf.repeat(2, axis=0).repeat(3, axis=1)
    stack([
        row([("ghost saved 4x, cropped", nearest(crop, PANEL)),
             ("taken as it is (--pixel-size 1)", svg_panel(depixel.convert(crop, pixel_size=1), PANEL)),
             ("default: 4x found, offset 1,2", svg_panel(depixel.convert(crop), PANEL))]),
        row([("leaf saved 3x2", nearest(wide, PANEL)),
             ("taken as it is (--pixel-size 1)", svg_panel(depixel.convert(wide, pixel_size=1), PANEL)),
             ("default: 3x2 found", svg_panel(depixel.convert(wide), PANEL))]),
    ]).save(HERE / "inputs_upscaled.png", optimize=True)

    # 2. JPEG: 1× quality 85, and 4× quality 90
    small = jpeg(ghost, 85)
    big = jpeg(ghost.repeat(4, axis=0).repeat(4, axis=1), 90)
    stack([
        row([("ghost as JPEG q85", nearest(small, PANEL)),
             ("taken as it is (--no-denoise)", svg_panel(depixel.convert(small, denoise=False), PANEL)),
             ("default: denoised, 4:2:0 unmixed", svg_panel(depixel.convert(small, denoise=True), PANEL))]),
        row([("ghost saved 4x, JPEG q90", nearest(big, PANEL)),
             ("taken as it is", svg_panel(depixel.convert(big, pixel_size=1, denoise=False), PANEL)),
             ("default: 4x found, denoised", svg_panel(depixel.convert(big, denoise=True), PANEL))]),
    ]).save(HERE / "inputs_jpeg.png", optimize=True)

    # 3. backdrop
    row([("mushroom on a blue backdrop", nearest(mushroom, PANEL)),
         ("default: the backdrop is a shape", svg_panel(depixel.convert(mushroom), PANEL)),
         ("--transparent auto", svg_panel(depixel.convert(mushroom, transparent="auto"), PANEL))]
        ).save(HERE / "inputs_backdrop.png", optimize=True)


if __name__ == "__main__":
    main()
