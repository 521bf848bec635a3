"""Time the smooth renderer (:func:`depixel.render.shading.render_smooth`, paper §3.5).

    python benchmarks/bench_render.py              # targets of issue 8, median of 5 runs
    python benchmarks/bench_render.py --runs 9

Cases (the vector image is computed once, at the default optimized stage; only the render
is timed, median of ``--runs`` runs after one warm-up):

1. ``corpus/paper/smw_boo.png`` at 8× — target under 0.5 s;
2. every ``corpus/frames/*.png`` (256×224) at 4× — target under 5 s;
3. a synthetic 256×224 gradient at 4×, every region shaded: the worst case, since the
   frames' regions are all of one colour and take the flat-cell shortcut.

For reference, one flat render of the same SVG through cairosvg (``to_svg`` +
``svg2png``, a single run) is timed too, and the peak memory traced during one smooth
render (tracemalloc) is given. Single-threaded: BLAS and
OpenMP thread counts are pinned to 1 before numpy is imported.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from depixel.pipeline import depixelize  # noqa: E402
from depixel.prepare.image import load_image  # noqa: E402
from depixel.render.shading import render_smooth  # noqa: E402
from depixel.svg.writer import to_svg  # noqa: E402

DEFAULT_CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus"


def median_seconds(action, runs: int) -> float:
    action()  # warm-up
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        action()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def peak_mib(action) -> float:
    tracemalloc.start()
    action()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def flat_render(vector, scale: float):
    import cairosvg  # noqa: PLC0415 (optional here: only the reference figure needs it)

    return lambda: cairosvg.svg2png(bytestring=to_svg(vector, scale=scale).encode())


def shaded_gradient(h: int = 224, w: int = 256) -> np.ndarray:
    """Diagonal colour ramps with noise: neighbours similar, every region multi-coloured."""
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([40 + 0.6 * x, 60 + 0.5 * y, 120 + 0.2 * (x + y) / 2], axis=-1)
    rgb += rng.integers(-4, 5, size=rgb.shape)
    rgb[(x // 32 + y // 32) % 5 == 0] = (20, 20, 20)  # dark blocks, for some contours
    rgba = np.concatenate([np.clip(rgb, 0, 255), np.full((h, w, 1), 255)], axis=-1)
    return rgba.astype(np.uint8)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--supersample", type=int, default=3)
    args = parser.parse_args(argv)

    cases = [("smw_boo.png", load_image(args.corpus / "paper" / "smw_boo.png"), 8.0, 0.5)]
    cases += [(p.name, load_image(p), 4.0, 5.0) for p in sorted((args.corpus / "frames").glob("*.png"))]
    cases.append(("synthetic shaded 256x224", shaded_gradient(), 4.0, 5.0))

    print(f"smooth render, supersample {args.supersample}, median of {args.runs} runs (seconds)")
    print(f"{'input':28s} {'size':>9s} {'scale':>5s} {'output':>10s} {'smooth':>7s} {'target':>6s} "
          f"{'flat, cairo':>12s} {'peak MiB':>8s}")
    failed = False
    for name, rgba, scale, target in cases:
        vector = depixelize(rgba).vector
        h, w = rgba.shape[:2]
        smooth = median_seconds(lambda: render_smooth(vector, scale, args.supersample), args.runs)
        flat = median_seconds(flat_render(vector, scale), 1)
        peak = peak_mib(lambda: render_smooth(vector, scale, args.supersample))
        out_h, out_w = round(h * scale), round(w * scale)
        mark = "ok" if smooth < target else "SLOW"
        failed |= smooth >= target
        print(f"{name:28s} {w:>4d}x{h:<4d} {scale:>5g} {out_w:>4d}x{out_h:<5d} {smooth:>7.3f} "
              f"{'<' + format(target, 'g'):>6s} {flat:>12.3f} {peak:>8.0f}  {mark}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
