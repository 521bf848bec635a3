"""Threads where stacked shapes meet: the shared judge's ``conflation_px`` per sprite and in total.

Converts each sprite of ``../shared/corpus/paper`` (with ``--frames`` also the three game
frames) with the given options and counts, with ``../shared/tools/judge.py``'s own
``conflation`` function (cairosvg at 8x against the exact coverage, more than 32 levels off,
inside the opaque art), the pixels where a colour from below shows through an edge. Prints
one line per sprite that has any, then the total, the number of sprites with any and the
median path commands per sprite (docs/svg.md, "Threads"). Not part of the test suite
(tests/test_insets.py and tests/test_judge_corpus.py keep hand-made and corpus cases).

    python benchmarks/conflation.py                      # default output
    python benchmarks/conflation.py --frames --all       # every sprite, the frames too
    python benchmarks/conflation.py --layout cutout      # the cutout layout's seams, for scale
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import tempfile
from pathlib import Path

from depixel import depixelize, load_image, to_svg
from depixel.svg.outlines import LAYOUTS

SHARED = Path(__file__).resolve().parents[1].parent / "shared"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared folder (corpus and judge)")
    parser.add_argument("--layout", choices=LAYOUTS, default="stacked")
    parser.add_argument("--simplify", type=float, default=None, help="tolerance in pixels (default: the default)")
    parser.add_argument("--frames", action="store_true", help="also the three 256x224 game frames")
    parser.add_argument("--all", action="store_true", help="a line for every sprite, also those without threads")
    args = parser.parse_args()
    corpus, judge_path = args.shared / "corpus", args.shared / "tools" / "judge.py"
    if not (corpus / "paper").is_dir() or not judge_path.is_file():
        print(f"conflation: {args.shared} has no corpus/paper or tools/judge.py", file=sys.stderr)
        return 2
    spec = importlib.util.spec_from_file_location("judge", judge_path)
    assert spec is not None and spec.loader is not None
    judge = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(judge)
    sources = sorted((corpus / "paper").glob("*.png"))
    if args.frames:
        sources += sorted((corpus / "frames").glob("*.png"))
    options = {} if args.simplify is None else {"simplify": args.simplify}
    total = with_any = 0
    commands = []
    with tempfile.TemporaryDirectory(prefix="depixel-conflation-") as tmp:
        for src in sources:
            svg = Path(tmp) / f"{src.stem}.svg"
            svg.write_text(to_svg(depixelize(load_image(src)).vector, layout=args.layout, **options))
            found = judge.conflation(judge.load_rgba(src), svg)
            commands.append(judge.count_commands(svg))
            total += found
            with_any += found > 0
            if found or args.all:
                print(f"{src.stem:28s} {found:7d}", flush=True)
    print(f"total {total} conflation pixels on {with_any} of {len(sources)} images; "
          f"median {statistics.median(commands):g} path commands")
    return 0


if __name__ == "__main__":
    sys.exit(main())
