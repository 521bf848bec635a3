"""Draw the before/after figures of docs/svg.md, "Hidden colours and the backdrop" (issue 46).

    git archive 2e13e64 | tar -x -C ../old              # the checkout before issue 46
    python docs/img/halo_figures.py --before ../old

Crops of two paper sprites at 8x (../shared/corpus/paper, not in the project): sbm4_02's
shoes (svg_halo_shoe.png) and gaxe_skeleton's skull (svg_glow_skull.png). Each row is one
checkout (before, after); its three panels are the flat SVG and the default SVG rendered by
resvg (which applies the filter and the masks), and the PNG renderer (paper §3.5).
"""
from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parent
CORPUS = ROOT.parent / "shared" / "corpus" / "paper"
ZOOM = 8
#: (sprite, output, crop in pixels: x0, y0, x1, y1)
FIGURES = (("sbm4_02", "svg_halo_shoe.png", (0, 15, 18, 25)),
           ("gaxe_skeleton", "svg_glow_skull.png", (12, 0, 36, 16)))
#: renders the three panels of a sprite with the depixel on sys.path; prints an .npz's bytes
RENDER = """
import io, sys
import numpy as np, resvg_py
from PIL import Image
from depixel import depixelize, load_image, to_svg
from depixel.render.shading import render_smooth
vector = depixelize(load_image(sys.argv[1])).vector
def resvg(svg):
    png = bytes(resvg_py.svg_to_bytes(svg_string=svg, zoom=int(sys.argv[2])))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
out = io.BytesIO()
np.savez(out, flat=resvg(to_svg(vector, shading="flat")), smooth=resvg(to_svg(vector)),
         png=render_smooth(vector, int(sys.argv[2])))
sys.stdout.buffer.write(out.getvalue())
"""


def renders(checkout: Path, sprite: str) -> dict[str, np.ndarray]:
    """The three panels of ``sprite`` with the depixel of ``checkout``."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    out = subprocess.run([sys.executable, "-c", RENDER, str(CORPUS / f"{sprite}.png"), str(ZOOM)], env=env, check=True,
                         capture_output=True, cwd=checkout).stdout
    with np.load(io.BytesIO(out)) as data:
        return {name: data[name] for name in ("flat", "smooth", "png")}


def panel(rgba: np.ndarray, crop: tuple[int, int, int, int], text: str) -> Image.Image:
    x0, y0, x1, y1 = (c * ZOOM for c in crop)
    image = Image.new("RGBA", (x1 - x0, y1 - y0 + 14), (255, 255, 255, 255))
    image.alpha_composite(Image.fromarray(np.ascontiguousarray(rgba[y0:y1, x0:x1])), (0, 14))
    ImageDraw.Draw(image).text((2, 1), text, fill=(40, 40, 40, 255))
    return image


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, required=True, help="a checkout of depixel before issue 46")
    args = parser.parse_args()
    titles = {"flat": "flat SVG", "smooth": "default SVG (resvg)", "png": "PNG renderer"}
    for sprite, name, crop in FIGURES:
        rows = []
        for when, checkout in (("before", args.before.resolve()), ("after", ROOT)):
            views = renders(checkout, sprite)
            rows.append([panel(views[k], crop, f"{when}: {titles[k]}") for k in titles])
        w, h = rows[0][0].size
        sheet = Image.new("RGBA", (3 * w + 16, 2 * h + 8), (255, 255, 255, 255))
        for r, row in enumerate(rows):
            for c, image in enumerate(row):
                sheet.alpha_composite(image, (c * (w + 8), r * (h + 8)))
        sheet.convert("RGB").save(OUT / name, optimize=True)
        print(OUT / name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
