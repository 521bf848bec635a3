"""Pixel-centre fidelity of the smooth PNG renderer (paper §3.5), and why centres miss.

Renders each sprite with ``render_smooth`` at 9x (a render pixel on every pixel centre) and
prints the judge's ``centre``: the share of pixels whose rendered centre is within 16 levels
(every channel) of the source, transparent ones staying transparent. For the centres that
miss it gives how far they moved (levels, worst channel) and the largest |ΔY| between the
pixel and a pixel of its own region among its 8 neighbours: 48 is the similarity limit of
§3.2, the largest difference the paper's renderer blends.

    python benchmarks/smooth_centres.py                          # the six sprites under 0.97
    python benchmarks/smooth_centres.py --all                    # the 54 paper sprites
    python benchmarks/smooth_centres.py --sigma 1 0.8 0.6        # one column per σ

Prints one JSON line per sprite. Uses the shared corpus (``../shared/corpus/paper``).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from depixel import Params, depixelize, load_image
from depixel.colour import rgb_to_yuv
from depixel.render.shading import render_smooth
from depixel.vector import regions

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "paper"
DEFAULT_SPRITES = ("sbm4_01", "sbm4_02", "sbm4_03", "sbm4_04", "vikings_baelog", "vikings_olaf")
SCALE = 9
TOLERANCE = 16


def centres_ok(rgba: np.ndarray, render: np.ndarray) -> np.ndarray:
    """(H, W) bool: the judge's centre test at every pixel."""
    h, w = rgba.shape[:2]
    got = render.astype(int)[SCALE // 2::SCALE, SCALE // 2::SCALE][:h, :w]
    opaque = rgba[..., 3] >= 128
    colour_ok = (np.abs(got[..., :3] - rgba[..., :3].astype(int)).max(axis=2) <= TOLERANCE) & (got[..., 3] >= 200)
    return np.where(opaque, colour_ok, got[..., 3] <= 55)


def largest_similar_step(rgba: np.ndarray, region: np.ndarray, y: int, x: int) -> float:
    h, w = region.shape
    luma = rgb_to_yuv(rgba[..., :3])[..., 0]
    return max((abs(float(luma[yy, xx] - luma[y, x])) for yy in range(max(0, y - 1), min(h, y + 2))
                for xx in range(max(0, x - 1), min(w, x + 2)) if region[yy, xx] == region[y, x]), default=0.0)


def measure(path: Path, sigmas: list[float]) -> dict:
    rgba = np.asarray(load_image(path))
    vector = depixelize(rgba).vector
    region = regions(vector.cells).reshape(rgba.shape[:2])
    row: dict = {"sprite": path.stem}
    for sigma in sigmas:
        render = render_smooth(vector, SCALE, params=Params(shading_sigma=sigma))
        ok = centres_ok(rgba, render)
        row[f"centre_sigma_{sigma:g}"] = round(float(ok.mean()), 4)
        if sigma == sigmas[0]:
            got = render.astype(int)[SCALE // 2::SCALE, SCALE // 2::SCALE]
            miss = np.argwhere(~ok)
            moved = [int(np.abs(got[y, x, :3] - rgba[y, x, :3].astype(int)).max()) for y, x in miss.tolist()]
            steps = [largest_similar_step(rgba, region, y, x) for y, x in miss.tolist()]
            row["missed"] = len(miss)
            row["pixels"] = int(ok.size)
            row["to_reach_0.97"] = max(0, int(np.ceil(0.97 * ok.size - ok.sum())))
            row["moved_levels"] = [min(moved, default=0), int(np.median(moved)) if moved else 0, max(moved, default=0)]
            row["largest_similar_dY"] = [round(min(steps, default=0.0), 1), round(max(steps, default=0.0), 1)]
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sprites", nargs="*", type=Path, help="PNG files (default: the six under 0.97)")
    parser.add_argument("--all", action="store_true", help="the 54 paper sprites")
    parser.add_argument("--sigma", type=float, nargs="+", default=[Params().shading_sigma])
    args = parser.parse_args()
    named = [CORPUS / f"{n}.png" for n in DEFAULT_SPRITES]
    paths = args.sprites or (sorted(CORPUS.glob("*.png")) if args.all else named)
    for path in paths:
        print(json.dumps(measure(path, args.sigma)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
