"""Batch speed-up: ``depixel convert`` on many copies of a 32×32 sprite with ``-j 2`` vs ``-j 1``.

The sprite is built from the bundled fixtures (ghost, mushroom, heart and leaf in the four
quadrants of a 32×32 canvas), so the benchmark needs nothing outside the repository. Each
setting runs the installed ``depixel`` command in a fresh folder (``--force`` is not
needed) and the best of ``--repeat`` runs is reported, with the outputs checked to be
byte-identical between the two settings.

    python benchmarks/batch_parallel.py [--copies 200] [--repeat 2] [--stage optimized]
"""
from __future__ import annotations

import argparse
import hashlib
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "fixtures"


def sprite_32() -> np.ndarray:
    """A 32×32 RGBA sprite: four fixtures in the quadrants of a dark-blue canvas."""
    canvas = np.zeros((32, 32, 4), np.uint8)
    canvas[...] = (24, 20, 60, 255)
    for name, (r, c) in (("ghost.png", (0, 0)), ("mushroom.png", (0, 16)), ("heart.png", (19, 3)),
                         ("leaf.png", (18, 18))):
        img = np.asarray(Image.open(FIXTURES / name).convert("RGBA"))[:16, :16]
        canvas[r : r + img.shape[0], c : c + img.shape[1]] = img
    return canvas


def run(folder: Path, out: Path, jobs: int, stage: str) -> tuple[float, float]:
    """Wall seconds and CPU seconds (user + system, all processes) of one batch."""
    script = Path(sys.executable).with_name("depixel")
    command = [str(script), "convert", str(folder), "--out-dir", str(out), "-j", str(jobs), "--stage", stage]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def digest(folder: Path) -> str:
    h = hashlib.sha256()
    for path in sorted(folder.iterdir()):
        h.update(path.name.encode() + path.read_bytes())
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--copies", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--stage", default="optimized")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "in"
        folder.mkdir()
        data = sprite_32()
        for i in range(args.copies):
            Image.fromarray(data, "RGBA").save(folder / f"sprite{i:04d}.png")
        print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} cores "
              "(other work on the machine lowers the speed-up)")
        best, digests = {}, {}
        for jobs in (1, 2):
            times, cpu = [], []
            for k in range(args.repeat):
                out = Path(tmp) / f"out-j{jobs}-{k}"
                wall, used = run(folder, out, jobs, args.stage)
                times.append(wall)
                cpu.append(used)
                digests.setdefault(jobs, digest(out))
            best[jobs] = min(times)
            print(f"-j {jobs}: {best[jobs]:.2f} s for {args.copies} files "
                  f"({1000 * best[jobs] / args.copies:.1f} ms/file; runs: {', '.join(f'{t:.2f}' for t in times)}; "
                  f"CPU {min(cpu):.1f} s)")
        assert digests[1] == digests[2], "outputs differ between -j 1 and -j 2"
        print(f"speed-up -j 2 vs -j 1: {best[1] / best[2]:.2f}x (stage {args.stage}, outputs identical)")


if __name__ == "__main__":
    main()
