"""Make the comparison figures of docs/rendering.md from the project's own images.

    python docs/img/rendering_figures.py

Each figure is one PNG: nearest neighbour | flat SVG render (cairosvg) | smooth render,
all at the same magnification, over a light checkerboard where the image is transparent.
The orb (fixtures/orb.png) is a shaded ball whose neighbouring tones are similar, so the
smooth renderer has something to shade.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render.shading import render_smooth
from depixel.svg.writer import to_svg

HERE = Path(__file__).resolve().parent
FIXTURES = HERE.parent.parent / "fixtures"
GAP, TITLE = 8, 16
TITLES = ("nearest neighbour", "flat (SVG, cairosvg)", "smooth (render_smooth)")


def checkerboard(h: int, w: int, cell: int = 8) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    board = np.where((y // cell + x // cell) % 2, 235, 250).astype(np.uint8)
    return np.stack([board] * 3 + [np.full_like(board, 255)], axis=-1)


def over_checkerboard(rgba: np.ndarray) -> Image.Image:
    back = Image.fromarray(checkerboard(*rgba.shape[:2]))
    return Image.alpha_composite(back, Image.fromarray(rgba)).convert("RGB")


def figure(rgba: np.ndarray, scale: int) -> Image.Image:
    import cairosvg  # noqa: PLC0415

    vector = depixelize(rgba).vector
    h, w = rgba.shape[:2]
    nearest = np.repeat(np.repeat(rgba, scale, axis=0), scale, axis=1)
    flat_png = cairosvg.svg2png(bytestring=to_svg(vector, scale=scale, shading="flat").encode())
    flat = np.asarray(Image.open(io.BytesIO(flat_png)).convert("RGBA"))
    smooth = render_smooth(vector, scale)
    panels = [over_checkerboard(p) for p in (nearest, flat, smooth)]
    sheet = Image.new("RGB", (3 * w * scale + 4 * GAP, h * scale + TITLE + 2 * GAP), "white")
    draw = ImageDraw.Draw(sheet)
    for k, (panel, title) in enumerate(zip(panels, TITLES)):
        left = GAP + k * (w * scale + GAP)
        draw.text((left, GAP // 2), title, fill=(40, 40, 40))
        sheet.paste(panel, (left, TITLE + GAP))
    return sheet


def main() -> None:
    sources = {
        "ghost": (load_image(FIXTURES / "ghost.png"), 12),
        "chip": (load_image(FIXTURES / "chip.png"), 12),
        "heart": (load_image(FIXTURES / "heart.png"), 16),
        "orb": (load_image(FIXTURES / "orb.png"), 12),
    }
    for name, (rgba, scale) in sources.items():
        figure(rgba, scale).save(HERE / f"rendering_{name}.png", optimize=True)


if __name__ == "__main__":
    main()
