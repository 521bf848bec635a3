"""Halos and glow of the smooth shading (issue 46, items 2 and 3).

Renders each sprite at 8x three ways: the default SVG and the ``--shading flat`` SVG with
resvg, and the PNG renderer (paper §3.5, ``render_smooth``). Prints per sprite:

* ``halo``: the share of render pixels of the default SVG more than 16 levels (any channel)
  outside the range of colours that the flat SVG and the PNG renderer span within the 3x3
  render pixels around it. A blend between those is shading; a colour outside them is a
  colour no one shows there, such as a band hidden under a shape on top, pulled out around
  it by the blur (target: at most 0.1 % on each sprite);
* ``glow_svg``, ``glow_png``: render pixels where the flat SVG shows the backdrop (the
  area of the corners' colour joined to the image border, two render pixels in from its
  edges) but the default SVG / the PNG renderer departs from it by more than 6 levels: the
  art blending into a similar backdrop (target: 0). Sprites whose corners differ have none.

    python benchmarks/halos.py            # sbm4_01-04, the Vikings, gaxe_skeleton, sma_toad
    python benchmarks/halos.py --all      # the 54 paper sprites
    python benchmarks/halos.py SPRITE.png ...

Uses the shared corpus (``../shared/corpus/paper``); resvg must be installed (``pip install
resvg-py``) and scipy.
"""
from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

import numpy as np

from depixel import depixelize, load_image
from depixel.prepare.backdrop import border_connected
from depixel.render.shading import render_smooth
from depixel.svg.writer import to_svg

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "paper"
DEFAULT_SPRITES = ("sbm4_01", "sbm4_02", "sbm4_03", "sbm4_04", "vikings_baelog", "vikings_eric", "vikings_olaf",
                   "gaxe_skeleton", "sma_toad")
SCALE = 8
HALO_LEVELS = 16
GLOW_LEVELS = 6
GLOW_INSET = 2


def resvg(svg: str) -> np.ndarray:
    import resvg_py
    from PIL import Image

    png = bytes(resvg_py.svg_to_bytes(svg_string=svg, zoom=SCALE))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(np.int64)


def halo(smooth: np.ndarray, flat: np.ndarray, png: np.ndarray) -> np.ndarray:
    """(H, W) bool: render pixels of ``smooth`` outside the 3x3 colour range of the others."""
    from scipy.ndimage import maximum_filter, minimum_filter

    size = (3, 3, 1)
    lo = np.minimum(minimum_filter(flat, size), minimum_filter(png, size))[..., :3]
    hi = np.maximum(maximum_filter(flat, size), maximum_filter(png, size))[..., :3]
    rgb = smooth[..., :3]
    return ((rgb < lo - HALO_LEVELS) | (rgb > hi + HALO_LEVELS)).any(axis=-1)


def backdrop_area(rgba: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """(H, W) bool: render pixels where the flat render shows the backdrop, GLOW_INSET in."""
    from scipy.ndimage import binary_erosion

    corners = rgba[[0, 0, -1, -1], [0, -1, 0, -1]]
    if not (corners == corners[0]).all() or corners[0, 3] != 255:
        return np.zeros(flat.shape[:2], bool)
    shows = (flat == corners[0]).all(axis=-1)
    side = 2 * GLOW_INSET + 1
    return binary_erosion(border_connected(shows), np.ones((side, side)), border_value=0)


def measure(path: Path) -> dict:
    rgba = np.asarray(load_image(path))
    vector = depixelize(rgba).vector
    smooth, flat = resvg(to_svg(vector)), resvg(to_svg(vector, shading="flat"))
    png = render_smooth(vector, SCALE).astype(np.int64)
    row: dict = {"sprite": path.stem, "halo_pct": round(100 * float(halo(smooth, flat, png).mean()), 3)}
    area = backdrop_area(rgba, flat)
    colour = flat[..., :3][area][:1]
    for name, render in (("svg", smooth), ("png", png)):
        departs = np.abs(render[..., :3] - colour).max(axis=-1) > GLOW_LEVELS if colour.size else False
        row[f"glow_{name}"] = int((area & departs).sum())
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sprites", nargs="*", type=Path, help="PNG files (default: the nine of issue 46)")
    parser.add_argument("--all", action="store_true", help="the 54 paper sprites")
    args = parser.parse_args()
    named = [CORPUS / f"{n}.png" for n in DEFAULT_SPRITES]
    paths = args.sprites or (sorted(CORPUS.glob("*.png")) if args.all else named)
    worst = {"halo_pct": 0.0, "glow_svg": 0, "glow_png": 0}
    for path in paths:
        row = measure(path)
        for key in worst:
            worst[key] = max(worst[key], row[key])
        print(json.dumps(row), flush=True)
    print(json.dumps({"worst": worst}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
