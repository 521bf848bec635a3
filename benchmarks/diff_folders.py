"""Time of ``depixel diff BASELINE CURRENT`` on 1,000 pairs of 64 × 64 SVG renders (issue 34:
at most 30 s with ``-j 2`` on a 2-core machine).

The fixtures are converted once and written 1,000 times with width and height 64 into
each folder; every current file differs from its baseline in its bytes (a comment), so
every pair is read, rendered twice and compared, and one in ten is also drawn differently
(a colour changed), so the run writes diff pictures too. Each configuration runs
``--repeat`` times; the minimum is printed (the machine may be shared).

    python benchmarks/diff_folders.py [--pairs 1000] [--jobs 2] [--repeat 3] [--html]
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ["chip", "ghost", "heart", "leaf", "mushroom", "potion_rgba", "ghost_rgba"]


def make_folders(root: Path, pairs: int) -> tuple[Path, Path]:
    import numpy as np
    from PIL import Image

    import depixel

    svgs = []
    for name in FIXTURES:
        text = depixel.convert(np.asarray(Image.open(ROOT / "fixtures" / f"{name}.png").convert("RGBA")))
        svgs.append(re.sub(r'width="[^"]*" height="[^"]*"', 'width="64" height="64"', text, count=1))
    base, cur = root / "baseline", root / "current"
    for folder in (base, cur):
        folder.mkdir()
    for i in range(pairs):
        text = svgs[i % len(svgs)]
        (base / f"icon-{i:04d}.svg").write_text(text)
        changed = text.replace("\n", f"\n<!-- build {i} -->\n", 1)
        if i % 10 == 0:  # drawn differently: the first shape's colour
            fill = re.search(r'fill="(#[0-9a-f]{6})"', changed).group(1)
            changed = changed.replace(f'fill="{fill}"', 'fill="#00ff00"', 1)
        (cur / f"icon-{i:04d}.svg").write_text(changed)
    return base, cur


def timed(argv: list[str], repeat: int) -> tuple[float, int]:
    best, code = float("inf"), -1
    for _ in range(repeat):
        start = time.perf_counter()
        code = subprocess.run([sys.executable, "-m", "depixel", *argv], capture_output=True).returncode
        best = min(best, time.perf_counter() - start)
    return best, code


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pairs", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base, cur = make_folders(Path(tmp), args.pairs)
        runs = [("every pair rendered", [str(base), str(cur)]),
                ("with --html and --junit", [str(base), str(cur), "--html", f"{tmp}/report",
                                             "--junit", f"{tmp}/diff.xml"]),
                ("identical folders (bytes compared, nothing rendered)", [str(base), str(base)])]
        for label, argv in runs:
            seconds, code = timed(["diff", *argv, "-j", str(args.jobs)], args.repeat)
            print(f"{args.pairs} pairs of 64x64 SVG renders, -j {args.jobs}, {label}: {seconds:.2f} s "
                  f"(min of {args.repeat}; exit {code})")


if __name__ == "__main__":
    main()
