"""Draw the figure of docs/palettes.md: a sprite and its palette swap, from the fixtures.

    python docs/img/palette_figures.py

palette_swap.png: mushroom.png converted as it is, and with every colour's red and blue
exchanged by index (--palette-map FROM.gpl:TO.gpl, FROM its own exported palette): the same
shapes (the same path data), other fills; each rendered 8x by the smooth renderer.
"""
from __future__ import annotations

import io
import sys
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

import depixel  # noqa: E402
from depixel.files.palette import palette_of  # noqa: E402
from depixel.prepare.gpl import Palette, PaletteEntry, PaletteMap  # noqa: E402

OUT = Path(__file__).resolve().parent
ZOOM = 8


def swap_of(source: Palette) -> Palette:
    """Each colour with its red and blue exchanged, green kept: the reds become blues."""
    return Palette(tuple(PaletteEntry((b, g, r, a), e.name) for e in source.entries
                         for r, g, b, a in [e.rgba]))


def main() -> None:
    image = depixel.api.load(ROOT / "fixtures" / "mushroom.png")
    source = palette_of(image)
    swap = PaletteMap(source, swap_of(source))
    shots = [depixel.convert_bytes(image, "png", scale=ZOOM, palette_map=m) for m in (None, swap)]
    pictures = [Image.open(io.BytesIO(png)).convert("RGBA") for png in shots]
    w, h = pictures[0].size
    sheet = Image.new("RGBA", (2 * w + 16, h), (255, 255, 255, 255))
    for i, picture in enumerate(pictures):
        sheet.alpha_composite(picture, (i * (w + 16), 0))
    sheet.convert("RGB").save(OUT / "palette_swap.png", optimize=True)


if __name__ == "__main__":
    main()
