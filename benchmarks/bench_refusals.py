"""Time the refusal of an SVG whose ``<use>`` elements fan out (issue 35, finding 12).

    python benchmarks/bench_refusals.py            # min of 5 runs
    python benchmarks/bench_refusals.py --levels 8 --runs 9

The SVG has ``--levels`` groups, each ten ``<use>`` of the group before (10**11 copies of a
rectangle at 11 levels, in 3 KB). Printed: the time :func:`depixel.render.raster.render`
takes to refuse it (parse and count, in this process, min of ``--runs``) and the wall time
of ``depixel render`` refusing it (a fresh process: start-up included, min of ``--runs``).
cairosvg alone drew 100,000 copies before its own error: 15-38 s on a shared 2-core machine.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from depixel.errors import RenderError
from depixel.render.raster import render


def fanout(levels: int, width: int = 10) -> str:
    """``levels`` groups, each ``width`` uses of the one before."""
    defs = ['<rect id="l0" width="1" height="1"/>']
    for k in range(1, levels + 1):
        defs.append(f'<g id="l{k}">' + f'<use xlink:href="#l{k - 1}"/>' * width + "</g>")
    return ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="10" '
            f'height="10"><defs>{"".join(defs)}</defs><use xlink:href="#l{levels}"/></svg>')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", type=int, default=11)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    svg = fanout(args.levels)
    times = []
    for _ in range(args.runs):
        start = time.perf_counter()
        try:
            render(svg, "png")
            print("rendered: not refused")
        except RenderError:
            pass
        times.append(time.perf_counter() - start)
    print(f"{len(svg)} bytes, 10**{args.levels} copies: render() refuses in {min(times) * 1000:.1f} ms "
          f"(min of {args.runs})")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fanout.svg"
        path.write_text(svg)
        walls = []
        for _ in range(args.runs):
            start = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "depixel", "render", str(path), "-o",
                                   str(Path(folder) / "f.png")], capture_output=True, text=True)
            walls.append(time.perf_counter() - start)
        print(f"depixel render: exit {done.returncode} in {min(walls):.2f} s wall (min of {args.runs}): "
              f"{done.stderr.strip()}")


if __name__ == "__main__":
    main()
