"""Stepped pixels of the smooth shading, and where they lie (issue 32).

Renders each sprite at 8x three ways — the default SVG and the ``--shading flat`` SVG with
resvg, and the PNG renderer (paper §3.5, ``render_smooth``) — and counts *stepped pixels*
as ``../shared/tools/shape_checks.py steps`` does: horizontally neighbouring opaque render
pixels away from contours (7x7 luminance range <= 60) whose luminance (mean of R, G, B)
differs by 6 levels or more. Each stepped pair is then placed by the cells under the render
pixels around it (the pair and its 8-neighbours, ``render_smooth``'s own scanline labels; for the SVG renders
the render pixels within the simplification's tolerance, 2 at 8x, since the SVG's curves lie
that close to the exact ones, as ``tests/test_smooth_svg.py`` places Toad's steps):

* ``inside`` — every cell there belongs to one region (cells joined by invisible edges,
  paper §3.3): the paper's renderer blends such colours, so a step there is one it has not;
* ``shading`` — two of the cells lie in different regions whose colours are within the
  paper's shading distance (YUV distance <= 100, §3.3): a *shading edge*, a visible edge the
  paper draws as a spline curve, which its influence functions do not cross (§3.5);
* ``contour`` — two cells of different regions farther apart in colour.

    python benchmarks/stepped_pixels.py                     # smw_boo, sma_toad
    python benchmarks/stepped_pixels.py --all               # the 54 paper sprites
    python benchmarks/stepped_pixels.py SPRITE.png ... --pairs   # also the colour pairs of the steps

Prints one JSON line per sprite and a total line. Uses the shared corpus
(``../shared/corpus/paper``); resvg must be installed (``pip install resvg-py``).
"""
from __future__ import annotations

import argparse
import io
import json
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

from depixel import depixelize, load_image
from depixel.colour import rgb_to_yuv
from depixel.params import Params
from depixel.render.shading import _cell_labels, _flatten, _pieces_per_curve, _Segments, render_smooth
from depixel.svg.writer import DEFAULT_SIMPLIFY, to_svg
from depixel.vector import VectorImage, regions

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "paper"
DEFAULT_SPRITES = ("smw_boo", "sma_toad")
SCALE = 8
KINDS = ("inside", "shading", "contour")
#: the SVG's curves lie within the simplification's tolerance of the exact curves whose cells
#: place the steps: its steps are placed by the cells within that many render pixels
SVG_MARGIN = math.ceil(DEFAULT_SIMPLIFY * SCALE)


def resvg(svg: str) -> np.ndarray:
    import resvg_py
    from PIL import Image

    png = bytes(resvg_py.svg_to_bytes(svg_string=svg, zoom=SCALE))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))


def stepped(render: np.ndarray) -> tuple[np.ndarray, int]:
    """(K, 2) (row, column) of the left pixel of every stepped pair, and the pairs counted."""
    from scipy.ndimage import maximum_filter, minimum_filter

    luma = render[..., :3].astype(float).sum(axis=-1) / 3
    near = (maximum_filter(luma, 7) - minimum_filter(luma, 7)) > 60
    ok = (render[..., 3] == 255) & ~near
    pair = ok[:, 1:] & ok[:, :-1]
    return np.argwhere(pair & (np.abs(np.diff(luma, axis=1)) >= 6)), int(pair.sum())


def cell_labels(vector: VectorImage) -> np.ndarray:
    """(H*8, W*8) the cell under every render pixel's centre."""
    h, w = vector.shape
    segments = _Segments(vector, _flatten(vector, _pieces_per_curve(vector, 0.1 / SCALE)))
    return _cell_labels(segments, 0, h * SCALE, SCALE, SCALE, w * SCALE)


def hex_colour(rgb: np.ndarray) -> str:
    return "#" + "".join(f"{int(c):02x}" for c in rgb)


def place(steps: np.ndarray, labels: np.ndarray, region: np.ndarray, yuv: np.ndarray, rgb: np.ndarray,
          distance: float, margin: int = 1) -> tuple[Counter, Counter]:
    """How many steps lie at each kind of place, and the colour pairs of the edges
    (``margin``: the render pixels around the pair whose cells place it)."""
    kinds: Counter = Counter()
    colours: Counter = Counter()
    for y, x in steps.tolist():
        cells = np.unique(labels[max(0, y - margin):y + 1 + margin, max(0, x - margin):x + 2 + margin])
        apart = [(float(np.linalg.norm(yuv[p] - yuv[q])), p, q) for i, p in enumerate(cells.tolist())
                 for q in cells[i + 1:].tolist() if region[p] != region[q]]
        if not apart:
            kinds["inside"] += 1
            continue
        d, p, q = max(apart)
        kinds["shading" if d <= distance else "contour"] += 1
        colours[tuple(sorted((hex_colour(rgb[p]), hex_colour(rgb[q]))))] += 1
    return kinds, colours


def measure(path: Path, with_pairs: bool) -> dict:
    rgba = np.asarray(load_image(path))
    vector = depixelize(rgba).vector
    labels, region = cell_labels(vector), regions(vector.cells)
    rgb = vector.rgba.reshape(-1, 4)[:, :3].astype(int)
    yuv = rgb_to_yuv(rgb)
    row: dict = {"sprite": path.stem}
    renders = {"svg": resvg(to_svg(vector)), "flat": resvg(to_svg(vector, shading="flat")),
               "png": render_smooth(vector, SCALE)}
    for name, render in renders.items():
        steps, pairs = stepped(render)
        margin = 1 if name == "png" else SVG_MARGIN
        kinds, colours = place(steps, labels, region, yuv, rgb, Params().shading_distance, margin)
        row[name] = {"stepped": round(len(steps) / max(pairs, 1), 5), "n": len(steps),
                     **{k: kinds[k] for k in KINDS}}
        if with_pairs:
            row[name]["pairs"] = [[a, b, n] for (a, b), n in colours.most_common(8)]
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sprites", nargs="*", type=Path, help="PNG files (default: smw_boo, sma_toad)")
    parser.add_argument("--all", action="store_true", help="the 54 paper sprites")
    parser.add_argument("--pairs", action="store_true", help="also the colour pairs at the steps")
    args = parser.parse_args()
    named = [CORPUS / f"{n}.png" for n in DEFAULT_SPRITES]
    paths = args.sprites or (sorted(CORPUS.glob("*.png")) if args.all else named)
    total = {name: Counter() for name in ("svg", "flat", "png")}
    for path in paths:
        row = measure(path, args.pairs)
        for name, counts in total.items():
            counts.update({k: row[name][k] for k in ("n", *KINDS)})
        print(json.dumps(row), flush=True)
    print(json.dumps({"total": {name: dict(counts) for name, counts in total.items()}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
