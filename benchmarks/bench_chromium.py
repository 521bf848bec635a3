"""Time Chromium drawing depixel's SVG, smooth (the default) against flat (issue 32).

    python benchmarks/bench_chromium.py               # 7 runs each, the 3 frames and a shaded frame
    python benchmarks/bench_chromium.py --runs 11 --sprite gaxe_skeleton

Method: for each case the SVG is written twice (``to_svg`` with ``shading="smooth"`` and
``"flat"``) and headless Chromium takes a screenshot of a page showing it ``--copies``
times at ``--scale``× (each copy an ``<img>`` of its own URL, so each is loaded and drawn
on its own, side by side in a window that shows them all; software rendering,
``--disable-gpu``), one process per screenshot. A process's wall time is mostly Chromium
starting, so an empty page is timed too; a render's time is the least time over the runs
less the empty page's least time, divided by the copies. The three kinds of page are
alternated run by run, so the drift of a shared machine falls on all of them alike.

Cases: every ``corpus/frames/*.png`` (256×224; their regions are each one colour, so the
smooth SVG has no group and is the flat one), the synthetic 256×224 gradient of
``bench_render.py`` (every region shaded: the worst case), and the shaded paper sprites
named with ``--sprite``.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_render import shaded_gradient

from depixel import depixelize, load_image, to_svg

DEFAULT_CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus"


def screenshot_seconds(page: Path, out: Path, width: int, height: int) -> float:
    """Wall time of one headless Chromium screenshot of ``page``."""
    start = time.perf_counter()
    subprocess.run(["chromium", "--headless", "--disable-gpu", "--no-sandbox", "--hide-scrollbars",
                    "--force-device-scale-factor=1", f"--window-size={width},{height}", f"--screenshot={out}",
                    page.as_uri()], check=True, capture_output=True, timeout=300)
    return time.perf_counter() - start


def page_for(svg: Path | None, width: int, height: int, folder: Path, name: str, copies: int) -> Path:
    """A page showing ``copies`` of the SVG side by side (none: an empty page)."""
    style = f"display:inline-block;vertical-align:top;width:{width}px;height:{height}px"
    body = "".join(f"<img src='{svg.resolve().as_uri()}?{k}' style='{style}'>" for k in range(copies)) if svg else ""
    page = folder / f"{name}.html"
    page.write_text(f"<!doctype html><html><body style='margin:0'>{body}</body></html>")
    return page


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--scale", type=float, default=4.0)
    parser.add_argument("--copies", type=int, default=4, help="copies of the SVG on the page (default 4)")
    parser.add_argument("--keep", type=Path, help="keep the SVGs and the last screenshots in this folder")
    parser.add_argument("--sprite", action="append", default=[], help="a paper sprite's name (repeatable)")
    args = parser.parse_args(argv)
    if shutil.which("chromium") is None:
        print("bench_chromium: chromium is not installed", file=sys.stderr)
        return 2
    cases = [(p.name, load_image(p)) for p in sorted((args.corpus / "frames").glob("*.png"))]
    cases.append(("synthetic shaded 256x224", shaded_gradient()))
    cases += [(name, load_image(args.corpus / "paper" / f"{name}.png")) for name in args.sprite]
    print(f"Chromium screenshot of {args.copies} copies at {args.scale:g}x, least of {args.runs} runs less the "
          "empty page's, per copy (seconds)")
    print(f"{'input':28s} {'output':>10s} {'flat':>7s} {'smooth':>7s} {'ratio':>6s} {'groups':>6s}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for name, rgba in cases:
            vector = depixelize(rgba).vector
            h, w = rgba.shape[:2]
            width, height = round(w * args.scale), round(h * args.scale)
            pages = {"empty": page_for(None, width, height, folder, "empty", 0)}
            groups = 0
            for shading in ("flat", "smooth"):
                svg = folder / f"{shading}.svg"
                text = to_svg(vector, scale=args.scale, shading=shading)
                groups = max(groups, text.count('filter="url(#smooth)"'))
                svg.write_text(text)
                pages[shading] = page_for(svg, width, height, folder, shading, args.copies)
            best = {key: float("inf") for key in pages}
            for _ in range(args.runs):
                for key, page in pages.items():
                    best[key] = min(best[key], screenshot_seconds(page, folder / f"{key}.png", width * args.copies,
                                                                  height))
            flat, smooth = ((best[key] - best["empty"]) / args.copies for key in ("flat", "smooth"))
            print(f"{name:28s} {width:>4d}x{height:<5d} {flat:>7.3f} {smooth:>7.3f} {smooth / flat:>6.2f} {groups:>6d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
