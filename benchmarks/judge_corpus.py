"""Quality figures on the whole paper corpus: ../shared/tools/judge.py at every stage.

Converts each sprite of ``../shared/corpus/paper`` at the chosen stages (default: all three)
and scale, runs the shared judge with each renderer (cairosvg, and rsvg-convert when it is
installed) and prints, per stage and renderer, the minimum centre / diag / fg figures, the
total of seam pixels and the median number of paths per pixel. Not part of the test suite
(tests/test_judge_corpus.py keeps a sample in CI).

    python benchmarks/judge_corpus.py [--scale 2.5] [--stage optimized] [--keep DIR]
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from depixel import STAGES, Params, depixelize, load_image, to_svg

SHARED = Path(__file__).resolve().parents[1].parent / "shared"


def _pixels(size: str) -> int:
    width, height = (int(v) for v in size.split("x"))
    return width * height


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared folder (corpus and judge)")
    parser.add_argument("--stage", action="append", choices=STAGES, help="stage(s) to judge (default: all)")
    parser.add_argument("--scale", type=float, default=2.5, help="SVG width/height scale (default 2.5)")
    parser.add_argument("--keep", type=Path, help="write the SVGs here instead of a temporary folder")
    args = parser.parse_args()
    corpus, judge = args.shared / "corpus" / "paper", args.shared / "tools" / "judge.py"
    if not corpus.is_dir() or not judge.is_file():
        print(f"judge_corpus: {args.shared} has no corpus/paper or tools/judge.py", file=sys.stderr)
        return 2
    renderers = ["cairosvg"] + (["rsvg"] if shutil.which("rsvg-convert") else [])
    work = args.keep or Path(tempfile.mkdtemp(prefix="depixel-judge-"))
    for stage in args.stage or list(STAGES):
        folder = work / stage
        folder.mkdir(parents=True, exist_ok=True)
        pairs = []
        for src in sorted(corpus.glob("*.png")):
            svg = folder / f"{src.stem}.svg"
            svg.write_text(to_svg(depixelize(load_image(src), Params(), stage=stage).vector, scale=args.scale))
            pairs.append(f"{src}\t{svg}")
        listing = folder / "pairs.tsv"
        listing.write_text("\n".join(pairs) + "\n")
        for renderer in renderers:
            out = subprocess.run([sys.executable, str(judge), "--pairs", str(listing), "--renderer", renderer],
                                 capture_output=True, text=True, check=False)
            rows = [json.loads(line) for line in out.stdout.splitlines() if line.strip()]
            good = [r for r in rows if "error" not in r]
            ratio = statistics.median(r["shapes"] / _pixels(r["size"]) for r in good)
            print(f"{stage:9} {renderer:8} images {len(rows)} errors {len(rows) - len(good)} "
                  f"min centre {min(r['centre'] for r in good)} min diag {min(r['diag'] for r in good)} "
                  f"min fg {min(r['fg'] for r in good)} seam_px {sum(r['seam_px'] for r in good)} "
                  f"median paths/pixel {ratio:.4f}")
    if not args.keep:
        shutil.rmtree(work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
