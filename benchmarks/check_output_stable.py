"""Guard for performance work: the SVG of every corpus image must stay byte-identical.

Records (``--record``) or compares the SHA-256 of ``to_svg(depixelize(img, stage=S).vector)``
for the bundled fixtures, the paper corpus, the game frames and a few crops of the frames
(crops put dense content against the image border). Hashes live in
``benchmarks/output_hashes.json``, one table per stage, so an optimization can be checked
against the output it started from::

    python benchmarks/check_output_stable.py --stage cells --record   # before optimizing
    python benchmarks/check_output_stable.py --stage cells            # after: exit 1 on any change
    python benchmarks/check_output_stable.py --layout cutout --simplify 0   # other SVG options
    python benchmarks/check_output_stable.py --stage optimized --packed 16  # batches in one pass: same bytes

Images under ``../shared`` are skipped (with a note) when that folder is absent.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

import depixel
from depixel import Params, depixelize, load_image, to_svg
from depixel.svg.outlines import LAYOUTS
from depixel.svg.writer import DEFAULT_SIMPLIFY

ROOT = Path(__file__).resolve().parents[1]
HASHES = ROOT / "benchmarks" / "output_hashes.json"
DEFAULT_CORPUS = ROOT.parent / "shared" / "corpus"
#: (top, left, height, width) crops of every frame: two corners and the middle
CROPS = ((0, 0, 32, 32), (100, 60, 64, 64), (96, 128, 128, 128))


def inputs(corpus: Path) -> dict[str, np.ndarray]:
    """Name → RGBA array of every image the check covers, in a fixed order."""
    images: dict[str, np.ndarray] = {}
    for path in sorted((ROOT / "fixtures").glob("*.png")):
        images[f"fixtures/{path.name}"] = load_image(path)
    return images | corpus_images(corpus)


def corpus_images(corpus: Path) -> dict[str, np.ndarray]:
    """Name → RGBA of the paper sprites, the game frames and the frames' crops (absent
    folders give nothing)."""
    images: dict[str, np.ndarray] = {}
    for path in sorted((corpus / "paper").glob("*.png")):
        images[f"paper/{path.name}"] = load_image(path)
    for path in sorted((corpus / "frames").glob("*.png")):
        frame = load_image(path)
        images[f"frames/{path.name}"] = frame
        for top, left, h, w in CROPS:
            images[f"frames/{path.name}[{top}:{top + h},{left}:{left + w}]"] = frame[top : top + h, left : left + w]
    return images


def svg_hash(rgba: np.ndarray, stage: str, layout: str = "stacked", simplify: float = DEFAULT_SIMPLIFY) -> str:
    svg = to_svg(depixelize(rgba, Params(), stage=stage).vector, layout=layout, simplify=simplify)
    return hashlib.sha256(svg.encode("utf-8")).hexdigest()


def packed_hashes(images: dict[str, np.ndarray], stage: str, layout: str, simplify: float, size: int
                  ) -> dict[str, str]:
    """:func:`svg_hash` of every image, ``size`` images at a time in one pass
    (:func:`depixel.api.passes`: the pipelines by :func:`depixel.pipeline.depixelize_many`,
    the outlines' simplification together), as a batch runs them: each must be the bytes of
    the image alone."""
    from depixel.options import ConvertOptions

    options = ConvertOptions.build(Params(), stage=stage, layout=layout, simplify=simplify)
    names = list(images)
    out = {}
    for first in range(0, len(names), size):
        pack = names[first:first + size]
        with depixel.api.passes([images[n] for n in pack], options, ["svg"]):
            for name in pack:
                out[name] = svg_hash(images[name], stage, layout, simplify)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=depixel.STAGES, default="cells")
    parser.add_argument("--layout", choices=LAYOUTS, default="stacked")
    parser.add_argument("--simplify", type=float, default=DEFAULT_SIMPLIFY, help="tolerance of to_svg (0: exact)")
    parser.add_argument("--record", action="store_true", help="store the current hashes instead of comparing")
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder with paper/ and frames/")
    parser.add_argument("--packed", type=int, default=0, metavar="N",
                        help="N images at a time in one pass (depixel.api.passes), as a batch: same hashes")
    parser.add_argument("--hashes", type=Path, default=HASHES, help=f"hash file (default {HASHES.relative_to(ROOT)})")
    args = parser.parse_args(argv)
    if not args.corpus.is_dir():
        print(f"note: {args.corpus} not found; checking the fixtures only", file=sys.stderr)

    # the default SVG options are stored under the stage's name, others under stage/layout/simplify
    key = args.stage
    if (args.layout, args.simplify) != ("stacked", DEFAULT_SIMPLIFY):
        key = f"{args.stage}/{args.layout}/{args.simplify:g}"
    images = inputs(args.corpus)
    current = packed_hashes(images, args.stage, args.layout, args.simplify, args.packed) if args.packed else \
        {name: svg_hash(rgba, args.stage, args.layout, args.simplify) for name, rgba in images.items()}
    table = json.loads(args.hashes.read_text()) if args.hashes.exists() else {}
    if args.record:
        table[key] = current
        args.hashes.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
        print(f"recorded {len(current)} hashes for {key} in {args.hashes}")
        return 0
    stored = table.get(key)
    if stored is None:
        print(f"no hashes stored for {key}; run with --record first", file=sys.stderr)
        return 2
    changed = sorted(name for name in current if name in stored and stored[name] != current[name])
    missing = sorted(set(stored) - set(current))
    for name in changed[:10]:
        print(f"CHANGED {name}")
    if len(changed) > 10:
        print(f"... and {len(changed) - 10} more")
    print(f"{len(current) - len(changed)} of {len(current)} outputs unchanged at {key}"
          + (f" ({len(missing)} stored images not found)" if missing else ""))
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
