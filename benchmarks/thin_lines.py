"""One-pixel-wide lines of a sprite and how evenly its SVG draws them.

A *one-pixel line* is a horizontal (vertical) run of at least ``--min-length`` pixels of one
colour whose pixels above and below (left and right) all exist and differ from it by more
than the judge's colour tolerance (``--tolerance`` in RGB levels): the line is exactly one
pixel thick along its whole length. The SVG is rendered with cairosvg at ``--scale`` (8) and,
at every inner pixel of the run (the two end pixels left out: a line's end is rounded on
purpose), the line's drawn width is measured from the anti-aliased colours, averaged over
the pixel's rendered columns:
in the band from half a pixel before the line to half a pixel after it, each rendered pixel
counts for the share of the line's colour in it, against the colour of the source pixel
beside the line on that side (a projection on the segment between the two colours). A line
drawn straight and true is 1.0 px wide everywhere; the script prints per sprite the number
of lines, how many vary in width (max - min) by more than ``--vary`` (0.2) px, how many leave
1 +- 0.1 px anywhere, and the worst of each.

    python benchmarks/thin_lines.py                          # win31_keyboard, win31_setup
    python benchmarks/thin_lines.py SPRITE.png ... --simplify 0 --stage splines
    python benchmarks/thin_lines.py --lines                  # also one row per line

Uses the shared corpus (``../shared/corpus/paper``) for the default sprites; cairosvg must be
installed (``pip install cairosvg``).
"""
from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

import numpy as np

from depixel import convert, load_image
from depixel.svg.writer import DEFAULT_SIMPLIFY

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
DEFAULT_SPRITES = ("win31_keyboard", "win31_setup")


def one_pixel_lines(rgb: np.ndarray, min_length: int, tolerance: int) -> list[tuple[str, int, int, int]]:
    """``(axis, row, first, stop)`` of every one-pixel line: axis ``"h"`` runs along row
    ``row`` over the columns ``first:stop``; ``"v"`` is the same on the transposed image."""
    lines = []
    for axis, img in (("h", rgb), ("v", rgb.transpose(1, 0, 2))):
        rgb16 = img.astype(np.int16)
        same_next = np.abs(rgb16[:, 1:] - rgb16[:, :-1]).max(-1) <= tolerance
        thin = np.zeros(img.shape[:2], bool)
        above = np.abs(rgb16[1:-1] - rgb16[:-2]).max(-1) > tolerance
        below = np.abs(rgb16[1:-1] - rgb16[2:]).max(-1) > tolerance
        thin[1:-1] = above & below
        for row in range(1, img.shape[0] - 1):
            col = 0
            while col < img.shape[1]:
                if not thin[row, col]:
                    col += 1
                    continue
                stop = col + 1
                while stop < img.shape[1] and thin[row, stop] and same_next[row, stop - 1]:
                    stop += 1
                if stop - col >= min_length:
                    lines.append((axis, row, col, stop))
                col = stop
    return lines


def widths(render: np.ndarray, rgb: np.ndarray, line: tuple[str, int, int, int], scale: int) -> np.ndarray:
    """The drawn width (pixels) of ``line`` at each of its inner pixels (the mean over the
    pixel's rendered columns)."""
    axis, row, first, stop = line
    if axis == "v":
        render, rgb = render.transpose(1, 0, 2), rgb.transpose(1, 0, 2)
    colour = rgb[row, first:stop].astype(float).mean(axis=0)
    out = []
    half = scale // 2
    for col in range(first + 1, stop - 1):
        band = render[row * scale - half: (row + 1) * scale + half, col * scale: (col + 1) * scale, :3].astype(float)
        share = np.empty(band.shape[:2])
        for rows, beside in ((slice(0, half + scale // 2), rgb[row - 1, col]),
                             (slice(half + scale // 2, None), rgb[row + 1, col])):
            other = beside.astype(float)
            d = colour - other
            share[rows] = np.clip(((band[rows] - other) @ d) / max(float(d @ d), 1e-9), 0.0, 1.0)
        out.append(share.sum() / scale / scale)  # the mean over the pixel's rendered columns
    return np.array(out)


def render_svg(svg: str, scale: int) -> np.ndarray:
    import cairosvg
    from PIL import Image

    png = cairosvg.svg2png(bytestring=svg.encode(), scale=scale)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))


def measure(path: Path, simplify: float, stage: str, scale: int, min_length: int, tolerance: int,
            vary: float) -> dict:
    image = load_image(path)
    rgba = np.asarray(image)
    rgb = rgba[..., :3]
    render = render_svg(convert(rgba, stage=stage, simplify=simplify), scale)
    rows = []
    for line in one_pixel_lines(rgb, min_length, tolerance):
        w = widths(render, rgb, line, scale)
        if w.size:
            rows.append({"line": line, "min": round(float(w.min()), 3), "max": round(float(w.max()), 3)})
    spread = [r["max"] - r["min"] for r in rows]
    off = [max(abs(r["max"] - 1), abs(r["min"] - 1)) for r in rows]
    return {"input": path.stem, "simplify": simplify, "stage": stage, "lines": len(rows),
            f"vary_over_{vary:g}": sum(s > vary + 1e-9 for s in spread),
            "off_over_0.1": sum(o > 0.1 + 1e-9 for o in off),
            "worst_vary": round(max(spread, default=0.0), 3), "worst_off": round(max(off, default=0.0), 3),
            "rows": rows}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sprites", nargs="*", type=Path, help="PNG files (default: win31_keyboard, win31_setup)")
    parser.add_argument("--simplify", type=float, default=DEFAULT_SIMPLIFY)
    parser.add_argument("--stage", default="optimized")
    parser.add_argument("--scale", type=int, default=8)
    parser.add_argument("--min-length", type=int, default=5, help="shortest line, pixels (default 5)")
    parser.add_argument("--tolerance", type=int, default=16, help="RGB levels within which colours match")
    parser.add_argument("--vary", type=float, default=0.2, help="width spread counted (default 0.2 px)")
    parser.add_argument("--lines", action="store_true", help="also print every line's widths")
    args = parser.parse_args()
    sprites = args.sprites or [SHARED / "corpus" / "paper" / f"{name}.png" for name in DEFAULT_SPRITES]
    missing = [str(p) for p in sprites if not p.is_file()]
    if missing:
        print(f"thin_lines: no such file: {', '.join(missing)}", file=sys.stderr)
        return 2
    for path in sprites:
        result = measure(path, args.simplify, args.stage, args.scale, args.min_length, args.tolerance, args.vary)
        rows = result.pop("rows")
        print(json.dumps(result), flush=True)
        if args.lines:
            for row in rows:
                print("   ", json.dumps(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
