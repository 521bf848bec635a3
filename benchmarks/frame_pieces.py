"""How much of the SVG of an animation frame stays byte-identical where the picture does not change.

For two frames of a sequence, a pixel is *stable* when its 9×9 neighbourhood is the same in
both. A boundary piece (the writer's unit of path data between two junctions,
:mod:`depixel.svg.boundaries`) is stable when every point of it lies on stable pixels. The
script counts the stable pieces of the first frame and how many of them the second frame
draws with the very same numbers (in either direction), once for the exact spline
(``--simplify 0``) and once for the simplified one; and, among the pieces whose exact spline
is the same in both frames, how many stay the same once simplified (the simplification's own
locality: what it keeps of what the curves keep).

    python benchmarks/frame_pieces.py                         # smw0000 / smw0040 / smw0080, in pairs
    python benchmarks/frame_pieces.py A.png B.png --box 8 8 64 32 --simplify 0.5

``--box X0 Y0 X1 Y1`` counts only the pieces within that rectangle (pixels), e.g. a HUD.
"""
from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import minimum_filter

from depixel import depixelize, load_image
from depixel.curves.bspline import elevate
from depixel.svg.boundaries import CUBIC, QUAD, BoundaryPieces
from depixel.svg.outlines import OutlineShapes
from depixel.svg.writer import DEFAULT_SIMPLIFY

FRAMES = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "frames"
GRID = 0.01  # the writer's default precision


def piece_keys(pieces: BoundaryPieces) -> tuple[list[bytes], list[np.ndarray]]:
    """Each piece's control points as bytes, the same whichever way it runs, and its points."""
    start = np.roll(pieces.end, 1, axis=0)
    starts = pieces.ptr[:-1][np.diff(pieces.ptr) > 0]
    start[starts] = pieces.start[np.diff(pieces.ptr) > 0]
    q1, q2 = elevate(start, np.nan_to_num(pieces.ctrl), pieces.end)
    quad, cubic = pieces.kind == QUAD, pieces.kind == CUBIC
    c1 = np.where(quad[:, None], q1, np.where(cubic[:, None], pieces.ctrl, start))
    c2 = np.where(quad[:, None], q2, np.where(cubic[:, None], pieces.ctrl2, pieces.end))
    control = np.round(np.stack([start, c1, c2, pieces.end], axis=1) / GRID).astype(np.int64)  # (K, 4, 2)
    keys, points = [], []
    for a, b in zip(pieces.ptr[:-1].tolist(), pieces.ptr[1:].tolist()):
        forward = control[a:b].reshape(-1, 2)
        backward = control[a:b][::-1, ::-1].reshape(-1, 2)
        keys.append(min(forward.tobytes(), backward.tobytes()))
        points.append(forward * GRID)
    return keys, points


def stable_pixels(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels whose 9×9 neighbourhood is the same in both frames."""
    same = (a == b).all(axis=-1)
    return minimum_filter(same.astype(np.uint8), size=9, mode="constant", cval=0).astype(bool)


def compare(first: Path, second: Path, simplify: float, box: tuple[int, int, int, int] | None) -> dict:
    images = [np.asarray(load_image(p)) for p in (first, second)]
    stable = stable_pixels(*images)
    if box is not None:
        x0, y0, x1, y1 = box
        inside = np.zeros_like(stable)
        inside[y0:y1, x0:x1] = True
        stable &= inside
    vectors = [depixelize(rgba).vector for rgba in images]
    row: dict = {"first": first.stem, "second": second.stem, "stable_pixels": int(stable.sum())}
    keys = {}
    for tolerance in (0.0, simplify):
        both = [piece_keys(OutlineShapes(v, "stacked", GRID, tolerance).pieces) for v in vectors]
        keys[tolerance] = both
    exact_keys, exact_points = keys[0.0][0]
    h, w = stable.shape
    on_stable = []
    for pts in exact_points:
        x = np.clip(np.floor(pts[:, 0]).astype(int), 0, w - 1)
        y = np.clip(np.floor(pts[:, 1]).astype(int), 0, h - 1)
        on_stable.append(bool(stable[y, x].all()))
    second_exact, second_simple = set(keys[0.0][1][0]), set(keys[simplify][1][0])
    simple_keys = keys[simplify][0][0]
    stable_pieces = [i for i, s in enumerate(on_stable) if s]
    same_exact = [i for i in stable_pieces if exact_keys[i] in second_exact]
    row.update({
        "stable_pieces": len(stable_pieces),
        "identical_exact": len(same_exact),
        f"identical_at_{simplify:g}": sum(simple_keys[i] in second_simple for i in stable_pieces),
        f"identical_at_{simplify:g}_where_exact_identical": sum(simple_keys[i] in second_simple for i in same_exact),
    })
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("frames", nargs="*", type=Path, help="two or more frames (default: the shared SMW frames)")
    parser.add_argument("--simplify", type=float, default=DEFAULT_SIMPLIFY)
    parser.add_argument("--box", type=int, nargs=4, metavar=("X0", "Y0", "X1", "Y1"))
    args = parser.parse_args()
    frames = args.frames or sorted(FRAMES.glob("*.png"))
    if len(frames) < 2 or not all(p.is_file() for p in frames):
        print("frame_pieces: give two frames or more (or put ../shared/corpus/frames beside the checkout)",
              file=sys.stderr)
        return 2
    for first, second in itertools.combinations(frames, 2):
        print(json.dumps(compare(first, second, args.simplify, tuple(args.box) if args.box else None)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
