"""Make the figure of docs/animation.md from the project's own animated GIF.

    python docs/img/animation_figures.py

fixtures/heart_beat.gif, read with its timing and made one animated SVG: above, each frame of
the GIF (nearest neighbour); below, each layer of the SVG drawn alone (resvg, which draws the
smooth shading; cairosvg where resvg-py is not installed).
"""
from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import depixel
from depixel.prepare.animation import read_animation

HERE = Path(__file__).resolve().parent
FIXTURES = HERE.parent.parent / "fixtures"
SCALE, GAP, TITLE = 16, 8, 16


def only_layer(svg: str, number: int) -> str:
    """``svg`` with layer ``number`` (from 1) shown and the others hidden, the animation left out."""
    svg = re.sub(r"<animate [^>]*/>\n", "", svg).replace(' display="none"', "")
    return re.sub(r'(<g id="frame-(\d+)")', lambda m: m.group(1) + ("" if int(m.group(2)) == number
                                                                      else ' display="none"'), svg)


def draw(svg: str, width: int) -> Image.Image:
    try:
        import resvg_py  # noqa: PLC0415

        png = bytes(resvg_py.svg_to_bytes(svg_string=svg, width=width))
    except ImportError:
        import cairosvg  # noqa: PLC0415

        png = cairosvg.svg2png(bytestring=svg.encode(), output_width=width)
    return Image.open(io.BytesIO(png)).convert("RGBA")


def main() -> None:
    animation = read_animation(FIXTURES / "heart_beat.gif")
    svg = depixel.convert(animation, animate=True)
    h, w = animation.frames[0].shape[:2]
    n = len(animation.frames)
    sheet = Image.new("RGB", (n * (w * SCALE + GAP) + GAP, 2 * (h * SCALE + TITLE + GAP) + GAP), "white")
    pen = ImageDraw.Draw(sheet)
    for k, (frame, ms) in enumerate(zip(animation.frames, animation.durations)):
        x = GAP + k * (w * SCALE + GAP)
        nearest = Image.fromarray(np.repeat(np.repeat(frame, SCALE, axis=0), SCALE, axis=1))
        layer = draw(only_layer(svg, k + 1), w * SCALE)
        for row, (title, panel) in enumerate(((f"GIF frame {k + 1} ({ms:g} ms)", nearest),
                                              (f"SVG layer {k + 1}", layer))):
            y = GAP + row * (h * SCALE + TITLE + GAP)
            pen.text((x, y), title, fill="black")
            sheet.paste(panel, (x, y + TITLE), panel)
    sheet.save(HERE / "animation_heart.png", optimize=True)


if __name__ == "__main__":
    main()
