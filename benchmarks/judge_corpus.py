"""Quality and size figures on the whole paper corpus with ../shared/tools/judge.py.

Converts each sprite of ``../shared/corpus/paper`` (and with ``--frames`` the three game
frames) for every combination of the chosen stages, layouts and simplification tolerances,
runs the shared judge with each chosen renderer and prints one line per combination: the
minimum centre / diag / fg figures, the total of seam pixels, the shapes with holes over
opaque pixels (``--layers``, slow: one render per shape) and the median path commands and
bytes per sprite (frames listed on their own). Not part of the test suite
(tests/test_judge_corpus.py keeps a sample in CI).

    python benchmarks/judge_corpus.py                              # default output, cairosvg
    python benchmarks/judge_corpus.py --simplify 0 --simplify 0.1 --simplify 0.25
    python benchmarks/judge_corpus.py --layout cutout --renderer resvg --renderer chromium
    python benchmarks/judge_corpus.py --stage cells --stage splines --layers --frames
    python benchmarks/judge_corpus.py --renderer resvg --shading flat   # the bands alone
"""
from __future__ import annotations

import argparse
import itertools
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from depixel import STAGES, depixelize, load_image, to_svg
from depixel.svg.outlines import LAYOUTS
from depixel.svg.writer import DEFAULT_SIMPLIFY, SHADINGS

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
RENDERERS = ("cairosvg", "rsvg", "resvg", "chromium", "inkscape")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared folder (corpus and judge)")
    parser.add_argument("--stage", action="append", choices=STAGES, help="stage(s) (default: optimized)")
    parser.add_argument("--layout", action="append", choices=LAYOUTS, help="layout(s) (default: stacked)")
    parser.add_argument("--simplify", action="append", type=float,
                        help=f"tolerance(s) in pixels (default: {DEFAULT_SIMPLIFY}, the default output)")
    parser.add_argument("--renderer", action="append", choices=RENDERERS, help="renderer(s) (default: cairosvg)")
    parser.add_argument("--shading", choices=SHADINGS, default="smooth",
                        help="smooth (the default output; cairosvg draws it flat) or flat")
    parser.add_argument("--layers", action="store_true", help="also count shapes with holes (slow)")
    parser.add_argument("--frames", action="store_true", help="also the three 256x224 game frames")
    parser.add_argument("--scale", type=float, default=1.0, help="SVG width/height scale (default 1)")
    parser.add_argument("--keep", type=Path, help="write the SVGs here instead of a temporary folder")
    args = parser.parse_args()
    corpus, judge = args.shared / "corpus", args.shared / "tools" / "judge.py"
    if not (corpus / "paper").is_dir() or not judge.is_file():
        print(f"judge_corpus: {args.shared} has no corpus/paper or tools/judge.py", file=sys.stderr)
        return 2
    sources = sorted((corpus / "paper").glob("*.png"))
    if args.frames:
        sources += sorted((corpus / "frames").glob("*.png"))
    work = args.keep or Path(tempfile.mkdtemp(prefix="depixel-judge-"))
    combos = itertools.product(args.stage or ["optimized"], args.layout or ["stacked"],
                               args.simplify if args.simplify is not None else [DEFAULT_SIMPLIFY])
    for stage, layout, tolerance in combos:
        folder = work / f"{stage}-{layout}-{tolerance:g}"
        folder.mkdir(parents=True, exist_ok=True)
        pairs = []
        for src in sources:
            vector = depixelize(load_image(src), stage=stage).vector
            svg = folder / f"{src.stem}.svg"
            svg.write_text(to_svg(vector, scale=args.scale, layout=layout, simplify=tolerance, shading=args.shading))
            pairs.append(f"{src}\t{svg}")
        listing = folder / "pairs.tsv"
        listing.write_text("\n".join(pairs) + "\n")
        for renderer in args.renderer or ["cairosvg"]:
            command = [sys.executable, str(judge), "--pairs", str(listing), "--renderer", renderer]
            out = subprocess.run(command + (["--layers"] if args.layers else []),
                                 capture_output=True, text=True, check=False)
            rows = [json.loads(line) for line in out.stdout.splitlines() if line.strip()]
            if not rows:
                print(f"{stage} {layout} simplify {tolerance:g} {renderer}: {out.stderr.strip()[:200]}")
                continue
            good = [r for r in rows if "error" not in r]
            sprites = [r for r in good if "/frames/" not in r["input"]]
            line = (f"{stage:9} {layout:7} simplify {tolerance:<5g} {renderer:8} images {len(rows)} "
                    f"errors {len(rows) - len(good)} min centre {min(r['centre'] for r in good)} "
                    f"min diag {min(r['diag'] for r in good)} min fg {min(r['fg'] for r in good)} "
                    f"seam_px {sum(r['seam_px'] for r in good)}")
            if args.layers:
                line += f" holes {sum(r['holes'] for r in good)}"
            line += (f" | sprites: median cmds {statistics.median(r['cmds'] for r in sprites):g} "
                     f"median bytes {statistics.median(r['bytes'] for r in sprites):g}")
            for r in good:
                if "/frames/" in r["input"]:
                    line += f" | {Path(r['input']).stem}: cmds {r['cmds']} bytes {r['bytes']}"
            print(line, flush=True)
    if not args.keep:
        shutil.rmtree(work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
