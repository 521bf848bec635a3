"""Straight stripes: how far the SVG bends the boundaries of constant-slope pixel stripes (issue 46).

A *stripe image* (:func:`stripes`) is pixel art of parallel stripes whose boundaries are
digital lines of one slope dy:dx (1:1, 1:2, 2:1, 1:3, 3:1, 2:3, 3:2), each stripe ``width``
pixels thick along the axis across it (every column of a shallow stripe holds exactly
``width`` of its pixels, every row of a steep one), coloured from two or three colours in turn.
An artist means them as straight lines, so their drawn boundaries should be straight lines.

Each image is converted with ``depixel.convert`` (the default, or ``--simplify``/``--stage``),
rendered with cairosvg at ``--scale`` (16), and every boundary between two stripes is sampled
at every render column (every render row for a steep slope) well inside the image (``--margin``
source pixels from the border, where curves end): within a band of half a stripe on each
side of the pixel boundary, each render pixel counts for its share of the upper stripe's
colour against the lower one's (a projection on the segment between the two colours), so
the band's sum places the boundary to a fraction of a render pixel. A line is fitted to each
boundary's samples by least squares; the *departure* is the largest distance (source pixels,
across the line) of a sample from its line. Prints, per slope, the worst departure over the
widths and colour counts (one JSON line per image with ``--all``), and the worst in all.
The images are 40 x 40; a smaller ``--margin`` measures closer to the border, where each
boundary's curve ends on the image's edge and bends to reach it.

    python benchmarks/straight_stripes.py                     # the default conversion
    python benchmarks/straight_stripes.py --simplify 0        # the exact spline
    python benchmarks/straight_stripes.py --stage splines     # before the optimization
    python benchmarks/straight_stripes.py --fan fan.png       # also an 8x render of a stripe fan

cairosvg must be installed (``pip install cairosvg``).
"""
from __future__ import annotations

import argparse
import io
import json
import sys

import numpy as np

from depixel import convert
from depixel.svg.writer import DEFAULT_SIMPLIFY

SLOPES = ((1, 1), (1, 2), (2, 1), (1, 3), (3, 1), (2, 3), (3, 2))  # (dy, dx)
WIDTHS = (2, 3, 4)
#: the stripes' colours, dissimilar in pairs (contour edges, paper §3.3)
PALETTE = np.array([[40, 60, 160], [240, 200, 60], [200, 40, 40]], np.uint8)
SIZE = 40


def stripes(dy: int, dx: int, width: int, colours: int, size: int = SIZE) -> np.ndarray:
    """(size, size, 3) uint8: stripes whose boundaries run dx pixels across for every dy down,
    ``width`` pixels thick along the axis across them, in ``colours`` of :data:`PALETTE` in turn.
    The pixel (x, y) lies in stripe ⌊(dy·x − dx·y) / (width · max(dx, dy))⌋."""
    return PALETTE[np.mod(stripe_index(dy, dx, width, size), colours)]


def fan(size: int = 48) -> np.ndarray:
    """(size, size, 3) uint8: stripes fanning out from the bottom left corner, each boundary a
    digital ray of one of :data:`SLOPES` (the sectors between them in three colours in turn)."""
    y, x = np.mgrid[:size, :size]
    up = size - 1 - y  # height above the bottom row
    rays = sorted(SLOPES, key=lambda s: s[0] / s[1])
    sector = sum(((dy * x - dx * up) < 0).astype(int) for dy, dx in rays)  # rays the pixel lies above
    return PALETTE[sector % 3]


def render(svg: str, scale: int) -> np.ndarray:
    """(H·scale, W·scale, 3) float RGB of ``svg`` drawn by cairosvg."""
    import cairosvg
    from PIL import Image

    png = cairosvg.svg2png(bytestring=svg.encode(), scale=scale)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(float)


def stripe_index(dy: int, dx: int, width: int, size: int = SIZE) -> np.ndarray:
    """(size, size) int: the stripe of every pixel of :func:`stripes`."""
    y, x = np.mgrid[:size, :size]
    return np.floor_divide(dy * x - dx * y, width * max(dx, dy))


def departures(image: np.ndarray, index: np.ndarray, width: int, drawn: np.ndarray, scale: int,
               margin: int) -> list[float]:
    """The departure (source px) of every boundary of the stripe image ``image`` (its stripes
    ``index``) drawn as ``drawn`` (its render at ``scale``) from the line fitted to it (module
    docstring)."""
    if np.abs(np.diff(index, axis=0)).sum() < np.abs(np.diff(index, axis=1)).sum():
        # steep: the boundaries cross the rows once each; transposed, the columns
        image, index, drawn = image.transpose(1, 0, 2), index.T, drawn.transpose(1, 0, 2)
    size = image.shape[0]
    cols = np.arange(margin * scale, (size - margin) * scale)
    x = (cols + 0.5) / scale  # render column centres, source px
    src = cols // scale
    half = width / 2.0
    falling = index[-1, 0] < index[0, 0]
    out = []
    for k in range(int(index.min()) + 1, int(index.max()) + 1):  # between stripes k - 1 and k
        side = index >= k if falling else index < k
        edge = side.sum(axis=0).take(src)  # the first row past the boundary in each column
        keep = (edge - half >= margin) & (edge + half <= size - margin)
        if keep.sum() < 3 * scale:  # too short a stretch inside the margins to fit a line
            continue
        above = image[np.clip(edge - 1, 0, size - 1), src].astype(float)  # the colours either side
        below = image[np.clip(edge, 0, size - 1), src].astype(float)
        position = []
        for c, col, e, a, b in zip(cols[keep], x[keep], edge[keep], above[keep], below[keep]):
            top = int(round((e - half) * scale))
            band = drawn[top:int(round((e + half) * scale)), c]
            d = a - b
            share = np.clip(((band - b) @ d) / float(d @ d), 0.0, 1.0)
            position.append((col, top / scale + share.sum() / scale))
        pts = np.array(position)
        slope, offset = np.polyfit(pts[:, 0], pts[:, 1], 1)
        residual = pts[:, 1] - (slope * pts[:, 0] + offset)
        out.append(float(np.abs(residual).max() / np.hypot(1.0, slope)))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--simplify", type=float, default=DEFAULT_SIMPLIFY)
    parser.add_argument("--stage", default="optimized", choices=("splines", "optimized"))
    parser.add_argument("--scale", type=int, default=16, help="render scale (default 16)")
    parser.add_argument("--margin", type=int, default=5, help="source pixels left out at the border (default 5)")
    parser.add_argument("--all", action="store_true", help="one line per image, not only per slope")
    parser.add_argument("--fan", metavar="PNG", help="also write an 8x render of the stripe fan here")
    args = parser.parse_args()
    worst_all = 0.0
    for dy, dx in SLOPES:
        worst = 0.0
        for width in WIDTHS:
            for colours in (2, 3):
                image = stripes(dy, dx, width, colours)
                svg = convert(image, stage=args.stage, simplify=args.simplify)
                found = departures(image, stripe_index(dy, dx, width), width, render(svg, args.scale), args.scale,
                                   args.margin)
                worst = max(worst, *found)
                if args.all:
                    print(json.dumps({"slope": f"{dy}:{dx}", "width": width, "colours": colours,
                                      "boundaries": len(found), "departure": round(max(found), 3)}), flush=True)
        worst_all = max(worst_all, worst)
        print(json.dumps({"slope": f"{dy}:{dx}", "departure": round(worst, 3)}), flush=True)
    print(json.dumps({"slope": "all", "departure": round(worst_all, 3), "simplify": args.simplify,
                      "stage": args.stage}))
    if args.fan:
        import cairosvg

        cairosvg.svg2png(bytestring=convert(fan(), stage=args.stage, simplify=args.simplify).encode(),
                         scale=8, write_to=args.fan)
    return 0


if __name__ == "__main__":
    sys.exit(main())
