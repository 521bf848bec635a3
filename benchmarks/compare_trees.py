"""CPU time of two source trees of depixel on the same images, alternated per image.

On a shared or virtual machine the speed drifts by 10-70 % within minutes, so two runs of
`bench_pipeline.py` taken one after the other can disagree more than the change being
measured. This script starts one worker process per tree (the tree first on
``PYTHONPATH``: a checkout, or a folder holding links ``depixel`` and ``depixel_cli``),
sends both workers each image in turn (which one goes first alternates), and keeps per
image and per tree the minimum CPU time (``time.process_time``) of ``depixelize`` and of
``to_svg``. Drift then hits both trees alike, and the per-image ratio cancels it.

    python benchmarks/compare_trees.py BASE_TREE NEW_TREE [--rounds 2] [--corpus DIR]

Prints per tree the paper corpus's median, sum and max (and the stage split) and each
frame's time, then the median of the per-sprite ratios and the frames' ratio (new / base),
of the whole and of the SVG writer alone.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

DEFAULT_CORPUS = Path(__file__).resolve().parents[2] / "shared" / "corpus"


def worker() -> None:
    """Read ``PATH RUNS`` lines; answer each with the minimum CPU seconds of both stages."""
    import depixel

    images: dict[str, object] = {}
    for line in sys.stdin:
        path, runs = line.split()
        image = images.setdefault(path, depixel.load_image(path))
        best_optimize = best_svg = float("inf")
        for _ in range(int(runs)):
            start = time.process_time()
            vector = depixel.depixelize(image, stage="optimized").vector
            middle = time.process_time()
            depixel.to_svg(vector)
            end = time.process_time()
            best_optimize, best_svg = min(best_optimize, middle - start), min(best_svg, end - middle)
        print(best_optimize, best_svg, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("base", help="the tree measured against (a checkout or a folder of links)")
    parser.add_argument("new", help="the tree being measured")
    parser.add_argument("--rounds", type=int, default=2, help="passes over the images (default 2)")
    parser.add_argument("--runs", type=int, default=5, help="runs per sprite and pass (frames: 2)")
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder with paper/ and frames/")
    args = parser.parse_args()
    paper = sorted(str(p) for p in (args.corpus / "paper").glob("*.png"))
    frames = sorted(str(p) for p in (args.corpus / "frames").glob("*.png"))
    if not paper:
        sys.exit(f"compare_trees: no sprites in {args.corpus / 'paper'}")
    trees = [args.base, args.new]
    workers = [
        subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         text=True, env=dict(os.environ, PYTHONPATH=str(Path(tree).resolve())), cwd="/")
        for tree in trees
    ]
    best: list[dict[str, tuple[float, float]]] = [{}, {}]
    for round_ in range(args.rounds):
        for number, path in enumerate(paper + frames):
            runs = args.runs if number < len(paper) else 2
            for side in ((0, 1) if (round_ + number) % 2 == 0 else (1, 0)):
                workers[side].stdin.write(f"{path} {runs}\n")
                workers[side].stdin.flush()
                optimize, svg = map(float, workers[side].stdout.readline().split())
                before = best[side].get(path, (float("inf"), float("inf")))
                best[side][path] = (min(before[0], optimize), min(before[1], svg))
    for process in workers:
        process.stdin.close()
        process.wait()
    for tree, times in zip(trees, best):
        total = [sum(times[p]) * 1e3 for p in paper]
        print(f"{tree}: paper median {statistics.median(total):.2f} ms (optimized stage "
              f"{statistics.median(times[p][0] * 1e3 for p in paper):.2f}, SVG "
              f"{statistics.median(times[p][1] * 1e3 for p in paper):.2f}), sum {sum(total):.0f} ms, "
              f"max {max(total):.1f} ms; frames " + ", ".join(f"{sum(times[p]):.3f} s" for p in frames))
    ratios = [sum(best[1][p]) / sum(best[0][p]) for p in paper]
    line = f"new / base: per-sprite ratio median {statistics.median(ratios):.3f}"
    if frames:
        line += f", frames {sum(sum(best[1][p]) for p in frames) / sum(sum(best[0][p]) for p in frames):.3f}"
    writer = [best[1][p][1] / best[0][p][1] for p in paper]
    line += f"; the SVG writer alone: per-sprite ratio median {statistics.median(writer):.3f}"
    if frames:
        line += f", frames {sum(best[1][p][1] for p in frames) / sum(best[0][p][1] for p in frames):.3f}"
    print(line)


if __name__ == "__main__":
    if sys.argv[1:] == ["--worker"]:
        worker()
    else:
        main()
