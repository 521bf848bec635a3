"""Zero false positives and detection rates of the input preparation (depixel/prepare/inputs.py).

1. False positives: for every bundled fixture (every frame), every paper sprite, every game
   frame and the crops of the frames that ``check_output_stable.py`` uses, the SVG written
   with the default options must be byte-identical to the one written with
   ``pixel_size=1``; and no JPEG of a paper sprite or frame (quality 70 to 95) may be taken
   for upscaled art.
2. Detection: every paper sprite upscaled 2× to 8× (and 12×, 16×, non-square 2×3, 4×3,
   3×5), cropped by a random 0 to k-1 pixels at each edge, saved as PNG and as JPEG
   quality 70 to 95, must give back its grid; the exact copies give back the sprite itself.

Exit code 1 on any false positive or missed detection. Images under ``../shared`` are
skipped (with a note) when that folder is absent.

    python benchmarks/check_prepare.py [--quick]    # --quick: detection on every 6th sprite
"""
from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from check_output_stable import DEFAULT_CORPUS, ROOT, corpus_images  # noqa: E402

import depixel  # noqa: E402
from depixel import load_image  # noqa: E402
from depixel.prepare.image import frame_count  # noqa: E402
from depixel.prepare.inputs import prepare  # noqa: E402

FACTORS = [(k, k) for k in range(2, 9)] + [(12, 12), (16, 16), (2, 3), (4, 3), (3, 5)]
QUALITIES = (70, 80, 90, 95)


def real_art(corpus: Path) -> dict[str, np.ndarray]:
    """Name → RGBA of every 1× image: fixtures (all frames), paper sprites, frames and crops."""
    images: dict[str, np.ndarray] = {}
    for path in sorted((ROOT / "fixtures").iterdir()):
        if path.suffix in (".png", ".gif"):
            for i in range(frame_count(path)):
                images[f"fixtures/{path.name}#{i}"] = load_image(path, frame=i)
    return images | corpus_images(corpus)


def jpeg(rgb: np.ndarray, quality: int) -> np.ndarray:
    buffer = io.BytesIO()
    Image.fromarray(rgb[..., :3], "RGB").save(buffer, "JPEG", quality=quality)
    return np.asarray(Image.open(buffer).convert("RGBA"))


def upscale(rgba: np.ndarray, factor: tuple[int, int], cut: tuple[int, int, int, int]) -> np.ndarray:
    """Nearest-neighbour ``factor`` (x, y), then ``cut`` (left, top, right, bottom) pixels off."""
    big = rgba.repeat(factor[1], axis=0).repeat(factor[0], axis=1)
    left, top, right, bottom = cut
    return big[top : big.shape[0] - bottom, left : big.shape[1] - right]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder with paper/ and frames/")
    parser.add_argument("--quick", action="store_true", help="detection on every 6th sprite only")
    args = parser.parse_args()
    if not args.corpus.is_dir():
        print(f"note: {args.corpus} not found; checking the fixtures only", file=sys.stderr)
    problems = 0

    art = real_art(args.corpus)
    changed = [name for name, rgba in art.items() if depixel.convert(rgba) != depixel.convert(rgba, pixel_size=1)]
    for name in changed:
        print(f"FALSE POSITIVE {name}: the default output differs from pixel_size=1")
    print(f"false positives: {len(changed)} of {len(art)} images (default SVG == pixel_size=1 SVG)")
    problems += len(changed)

    lossy_art = {n: a for n, a in art.items() if n.startswith(("paper/", "frames/")) and "[" not in n}
    taken = [(n, q) for n, a in lossy_art.items() for q in QUALITIES
             if prepare(jpeg(a, q), lossy="JPEG").upscaled]
    for name, quality in taken:
        print(f"FALSE POSITIVE {name} as JPEG q{quality}: taken for upscaled art")
    print(f"false positives on JPEG: {len(taken)} of {len(lossy_art) * len(QUALITIES)} (1x JPEG q{QUALITIES})")
    problems += len(taken)

    rng = np.random.default_rng(14)
    sprites = [a for n, a in art.items() if n.startswith("paper/")][:: 6 if args.quick else 1]
    print(f"\ndetection on {len(sprites)} paper sprites, random crops of 0 to k-1 pixels per edge")
    print(f"{'factor':>6} {'PNG exact':>10} " + " ".join(f"{'JPEG q' + str(q):>9}" for q in QUALITIES))
    for factor in FACTORS:
        found = {key: 0 for key in ("png",) + QUALITIES}
        for sprite in sprites:
            cut = tuple(int(v) for v in rng.integers(0, [factor[0], factor[1], factor[0], factor[1]]))
            big = upscale(sprite, factor, cut)
            got = prepare(big)
            exact = got.pixel_size == factor and np.array_equal(got.rgba, sprite)
            found["png"] += exact
            for q in QUALITIES:
                found[q] += prepare(jpeg(big, q), lossy="JPEG").pixel_size == factor
        problems += sum(len(sprites) - v for v in found.values())
        label = f"{factor[0]}x{factor[1]}"
        print(f"{label:>6} {found['png']:>6}/{len(sprites):<3} "
              + " ".join(f"{found[q]:>5}/{len(sprites):<3}" for q in QUALITIES))
    print(f"\n{'OK' if not problems else f'{problems} problems'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
