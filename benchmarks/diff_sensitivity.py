"""Does ``depixel diff`` see a one-pixel edit of the art? (issue 34)

Every pixel of ``fixtures/mushroom.png`` is changed, in turn, to each colour of the sprite
and two others; the original and each edit are converted to SVG and compared at every
integer scale from 1 to 8, drawn by cairosvg. An edit is missed when the comparison finds
pixels over the threshold but counts none of them (all called anti-aliasing). Printed per
scale: the misses of ``depixel diff`` (docs/cli.md, "Anti-aliasing": the three rules, and
every pixel counted below 3 pixels an art pixel), of the three rules alone at every scale,
and of pixelmatch's rule alone (its rule 1). Edits whose renders do not differ at all are
left out.

    python benchmarks/diff_sensitivity.py [--scales 1 2 3 4 5 6 7 8]   (~7,000 comparisons, minutes)
"""
from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np
from PIL import Image

import depixel
from depixel.diff import compare as C
from depixel.diff.sources import Source, too_coarse_for_antialiasing
from depixel.render.raster import render_rgba

ROOT = Path(__file__).resolve().parent.parent
EXTRA = [(0, 200, 0, 255), (128, 128, 128, 255)]


def pixelmatch_count(a: np.ndarray, b: np.ndarray) -> int:
    """Pixels over the threshold that pixelmatch's anti-aliasing test alone does not excuse."""
    limit = C.MAX_YIQ_DELTA * C.DEFAULT_THRESHOLD**2
    over = C.yiq_distance(a[..., :3], b[..., :3]) > limit
    rows, cols = np.nonzero(over)
    if not rows.size:
        return 0
    h = a.shape[0]
    flat = C._flat(a, 0, h) & C._flat(b, 0, h)
    aa = C._edge_blend(C.luma(a[..., :3]), flat, rows, cols, 0, h) | C._edge_blend(C.luma(b[..., :3]), flat, rows,
                                                                                    cols, 0, h)
    return int((~aa).sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scales", type=int, nargs="+", default=list(range(1, 9)))
    args = parser.parse_args()
    art = np.asarray(Image.open(ROOT / "fixtures" / "mushroom.png").convert("RGBA")).copy()
    h, w = art.shape[:2]
    colours = sorted({tuple(p) for p in art.reshape(-1, 4).tolist()}) + EXTRA
    original = depixel.convert(art)
    renders = {s: render_rgba(original, width=w * s, height=h * s) for s in args.scales}
    svg_source = Source("mushroom.svg", "svg", b"", (w, h), (w, h))  # depixel's SVG: its viewBox is the grid
    compared: Counter = Counter()
    missed: Counter = Counter()
    missed_rules: Counter = Counter()
    missed_pixelmatch: Counter = Counter()
    for y in range(h):
        for x in range(w):
            for colour in colours:
                if tuple(art[y, x]) == colour:
                    continue
                edited = art.copy()
                edited[y, x] = colour
                svg = depixel.convert(edited)
                for s in args.scales:
                    background = C.pick_background([renders[s]])
                    a = C.flatten_in_place(renders[s].copy(), background)
                    b = C.flatten_in_place(np.array(render_rgba(svg, width=w * s, height=h * s)), background)
                    result = C.compare(a, b)
                    if not (result.different.any() or result.antialiased.any()):
                        continue  # nothing over the threshold: the edit does not show
                    every_pixel = too_coarse_for_antialiasing(svg_source, w * s, h * s)
                    compared[s] += 1
                    missed_rules[s] += result.different_pixels == 0
                    missed[s] += result.different_pixels == 0 and not every_pixel
                    missed_pixelmatch[s] += pixelmatch_count(a, b) == 0
    print(f"{'scale':>5} {'edits':>6} {'missed (diff)':>14} {'(the rules alone)':>18} {'(pixelmatch)':>13}")
    for s in args.scales:
        print(f"{s:>5} {compared[s]:>6} {missed[s]:>14} {missed_rules[s]:>18} {missed_pixelmatch[s]:>13}")
    print(f"{'all':>5} {sum(compared.values()):>6} {sum(missed.values()):>14} {sum(missed_rules.values()):>18} "
          f"{sum(missed_pixelmatch.values()):>13}")


if __name__ == "__main__":
    main()
