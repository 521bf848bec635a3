"""What the smooth shading costs in the file: the default SVG against ``--shading flat``.

Converts each sprite of ``../shared/corpus/paper`` both ways and prints the total size of
the default SVGs over the flat ones (the filter, a ``<g>`` per smooth group and the masks
that keep what shapes on top hide out of each group's blur, docs/svg.md "Hidden parts"), the
median, the sprites that grow most, and the ``<use>`` elements of the masks.

    python benchmarks/shading_bytes.py
"""
from __future__ import annotations

import statistics
import sys
from pathlib import Path

from depixel import depixelize, load_image, to_svg

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "corpus" / "paper"


def main() -> int:
    if not CORPUS.is_dir():
        print(f"shading_bytes: no corpus at {CORPUS}", file=sys.stderr)
        return 2
    smooth_total = flat_total = uses = 0
    rows = []
    for src in sorted(CORPUS.glob("*.png")):
        vector = depixelize(load_image(src)).vector
        smooth, flat = to_svg(vector), to_svg(vector, shading="flat")
        smooth_total += len(smooth)
        flat_total += len(flat)
        uses += smooth.count("<use ")
        rows.append((len(smooth) / len(flat) - 1.0, src.stem))
    rows.sort()
    worst = ", ".join(f"{name} +{100 * grow:.1f} %" for grow, name in rows[-3:][::-1])
    print(f"default over flat: total +{100 * (smooth_total / flat_total - 1):.1f} %, median "
          f"+{100 * statistics.median(g for g, _ in rows):.1f} %; most: {worst}; mask <use>: {uses}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
