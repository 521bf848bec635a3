"""What the input preparation costs next to the conversion of a 1× sprite (issue 14: ≤ 10%).

For every paper sprite: the median time of ``prepare`` (upscale detection; for the JPEG
copy, quality 85, also the lossy grid search and the palette snapping) against the median
time of the conversion it precedes (``depixelize`` + ``to_svg``), in process, after one
warm-up run. Also the 4× upscaled PNG and 4× JPEG q90 copies, whose preparation replaces a
conversion 16 times as large by one of the 1× sprite.

    python benchmarks/bench_prepare.py [--repeats 5] [--corpus DIR]
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import io  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from depixel import Params, depixelize, load_image, to_svg  # noqa: E402
from depixel.prepare.inputs import prepare  # noqa: E402

DEFAULT_CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus"


def timed(fn, repeats: int) -> float:
    """Median seconds of ``repeats`` calls after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def as_jpeg(rgba: np.ndarray, quality: int) -> np.ndarray:
    buffer = io.BytesIO()
    Image.fromarray(rgba[..., :3], "RGB").save(buffer, "JPEG", quality=quality)
    return load_image(buffer.getvalue())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder with paper/")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    sprites = sorted((args.corpus / "paper").glob("*.png"))
    if not sprites:
        print(f"bench_prepare: no sprites in {args.corpus / 'paper'}", file=sys.stderr)
        return 2
    rows: dict[str, list[tuple[float, float]]] = {"1x PNG": [], "1x JPEG q85": [], "4x PNG": [], "4x JPEG q90": []}
    for path in sprites:
        clean = load_image(path)
        convert = timed(lambda clean=clean: to_svg(depixelize(clean, Params()).vector), args.repeats)
        big = clean.repeat(4, axis=0).repeat(4, axis=1)
        inputs = {"1x PNG": (clean, None), "1x JPEG q85": (as_jpeg(clean, 85), "JPEG"),
                  "4x PNG": (big, None), "4x JPEG q90": (as_jpeg(big, 90), "JPEG")}
        for label, (rgba, lossy) in inputs.items():
            seconds = timed(lambda rgba=rgba, lossy=lossy: prepare(rgba, lossy=lossy), args.repeats)
            rows[label].append((seconds, convert))
    print(f"{len(sprites)} paper sprites, median of {args.repeats} runs each; preparation time as a share "
          f"of converting the 1x sprite (depixelize + to_svg)")
    print(f"{'input':12} {'prepare ms median':>17} {'max':>7} {'share median':>12} {'max':>7}")
    for label, pairs in rows.items():
        ms = [1000 * p for p, _ in pairs]
        share = [p / c for p, c in pairs]
        print(f"{label:12} {statistics.median(ms):17.2f} {max(ms):7.2f} {100 * statistics.median(share):11.1f}% "
              f"{100 * max(share):6.1f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
