"""Make the sprite-sheet figure of docs/inputs.md from the project's own fixtures.

    python docs/img/sheet_figures.py

A 3 × 2 sheet of five fixtures (one cell left empty) with 2-pixel transparent gutters: the
sheet with the cells ``--sheet auto`` finds outlined (:func:`depixel.cut_sheet`), the SVG
``depixel convert sheet.png --sheet auto -o sheet.svg`` writes (a layer per sprite), and that
SVG with one layer left alone.
"""
from __future__ import annotations

import re
import tempfile
from pathlib import Path

import numpy as np
from inputs_figures import FIXTURES, HERE, PANEL, nearest, row, svg_panel
from PIL import Image, ImageDraw

from depixel import cut_sheet
from depixel.prepare.image import load_image
from depixel_cli.main import main as command

CELL, GAP = (18, 16), 2
NAMES = ["ghost_rgba.png", "potion_rgba.png", "orb.png", "leaf_la.png", None, "heart_trns.png"]


def make_sheet() -> np.ndarray:
    sheet = np.zeros((2 * CELL[1] + GAP, 3 * CELL[0] + 2 * GAP, 4), np.uint8)
    for i, name in enumerate(NAMES):
        if name is None:
            continue
        sprite = load_image(FIXTURES / name)
        x = (i % 3) * (CELL[0] + GAP) + (CELL[0] - sprite.shape[1]) // 2
        y = (i // 3) * (CELL[1] + GAP) + (CELL[1] - sprite.shape[0]) // 2
        sheet[y:y + sprite.shape[0], x:x + sprite.shape[1]] = sprite
    return sheet


def main() -> None:
    sheet = make_sheet()
    found = cut_sheet(sheet)
    with tempfile.TemporaryDirectory() as folder:
        Image.fromarray(sheet, "RGBA").save(Path(folder) / "sheet.png")
        assert command(["convert", f"{folder}/sheet.png", "--sheet", "auto", "-o", f"{folder}/sheet.svg"]) == 0
        svg = (Path(folder) / "sheet.svg").read_text()
    cells = nearest(sheet, PANEL)
    zoom = PANEL / sheet.shape[1]
    draw = ImageDraw.Draw(cells)
    for sprite in found.sprites:
        box = [sprite.x * zoom, sprite.y * zoom, (sprite.x + sprite.width) * zoom - 1,
               (sprite.y + sprite.height) * zoom - 1]
        draw.rectangle(box, outline=(230, 40, 40))
        draw.text((box[0] + 2, box[1] + 1), sprite.name, fill=(230, 40, 40))
    # every layer but r0c1 emptied: what an editor shows with the others hidden
    alone = re.sub(r'(<g id="(?!r0c1")[^"]*" inkscape:groupmode="layer"[^>]*>).*?(</g>\n(?=<g id="[^"]*" '
                   r'inkscape:groupmode|</svg>))', r"\1\2", svg, flags=re.S)
    row([("sheet: the cells found", cells),
         ("a layer per sprite", svg_panel(svg, PANEL)),
         ("layer r0c1 alone", svg_panel(alone, PANEL))]).save(HERE / "inputs_sheet.png", optimize=True)


if __name__ == "__main__":
    main()
