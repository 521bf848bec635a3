"""An animation as one SVG against one SVG a frame: time per frame and bytes.

1. The three Super Nintendo frames of the corpus (``../shared/corpus/frames``, smw0000,
   smw0040, smw0080) as a 3-frame APNG of 100 ms frames: the seconds per frame of
   ``--frames all`` beside those of ``--animate``, each as the command converts a file
   (:func:`depixel.files.convert.convert_frames`: read, converted, written and stamped), best
   of ``--repeats``; then the bytes of each frame's SVG, their sum and the animated SVG's.
2. With ``--patches``, every paper sprite as a 3-frame animation whose frames differ in one
   2×2 patch (the middle pixels set to the sprite's second, then third most common colour):
   the animated SVG's bytes over the first frame's alone, per sprite and their median.

    python benchmarks/animation.py
    python benchmarks/animation.py --repeats 5 --patches
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import depixel
from depixel.files.convert import InputFile, convert_frames, file_target
from depixel.options import ConvertOptions
from depixel.prepare.animation import Animation
from depixel.render.animation import encode_apng

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "corpus"
FRAMES = [SHARED / "frames" / f"smw{n:04d}.png" for n in (0, 40, 80)]


def sequence(folder: Path, repeats: int) -> None:
    frames = [depixel.load_image(path) for path in FRAMES]
    source = folder / "smw.png"
    source.write_bytes(encode_apng(frames, [100.0] * len(frames), 0))
    outputs = [folder / f"smw-{n:03d}.svg" for n in range(len(frames))]
    still, animated = ConvertOptions(), ConvertOptions.build(animate=True)
    targets = [file_target(out, still, frame=n) for n, out in enumerate(outputs)]
    every, together = [], []
    for _ in range(repeats):
        began = time.perf_counter()
        convert_frames(InputFile.read(source), targets, still, every_frame=True)
        every.append((time.perf_counter() - began) / len(frames))
        began = time.perf_counter()
        convert_frames(InputFile.read(source), [file_target(folder / "smw.svg", animated)], animated)
        together.append((time.perf_counter() - began) / len(frames))
    print(f"{len(frames)} frames of {frames[0].shape[1]}x{frames[0].shape[0]}, best of {repeats}:")
    print(f"  --frames all   {min(every):.3f} s a frame")
    print(f"  animate        {min(together):.3f} s a frame ({min(together) / min(every):.2f}x)")
    sizes = [out.stat().st_size for out in outputs]
    animated = (folder / "smw.svg").stat().st_size
    print(f"  SVG a frame    {', '.join(f'{s:,}' for s in sizes)} bytes (sum {sum(sizes):,}; stamps included)")
    print(f"  animated SVG   {animated:,} bytes ({animated / sizes[0]:.2f}x the first frame, "
          f"{animated / sum(sizes):.2f}x the sum)")


def patches() -> None:
    ratios = []
    for path in sorted((SHARED / "paper").glob("*.png")):
        base = depixel.load_image(path)
        colours, counts = np.unique(base.reshape(-1, 4), axis=0, return_counts=True)
        order = np.argsort(-counts, kind="stable")
        y, x = base.shape[0] // 2 - 1, base.shape[1] // 2 - 1
        frames = [base]
        for rank in (1, 2):
            frame = base.copy()
            frame[y : y + 2, x : x + 2] = colours[order[rank % len(colours)]]
            frames.append(frame)
        one = len(depixel.convert(base))
        ratios.append(len(depixel.convert(Animation(tuple(frames), (100.0,) * 3, 0), animate=True)) / one)
        print(f"  {path.stem:28s} {one:7,} bytes  {ratios[-1]:.2f}x")
    print(f"  median {statistics.median(ratios):.2f}x, {min(ratios):.2f}-{max(ratios):.2f}x, "
          f"{sum(r <= 1.6 for r in ratios)} of {len(ratios)} within 1.6x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--patches", action="store_true", help="the 2x2-patch animations of the paper sprites")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        sequence(Path(folder), args.repeats)
    if args.patches:
        print("paper sprites, frames differing in one 2x2 patch: animated SVG / first frame's SVG")
        patches()


if __name__ == "__main__":
    main()
