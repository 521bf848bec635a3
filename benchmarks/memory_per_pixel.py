"""Peak memory per input pixel of one conversion, above the import baseline.

Each case runs in a fresh subprocess: it imports depixel, records its peak RSS (the
baseline), converts one image to SVG and records the peak again. The worst case measured
here sets ``depixel.limits.PEAK_BYTES_PER_PIXEL``, which ``-j auto`` uses to decide how many
workers fit in memory.

    python benchmarks/memory_per_pixel.py [--sizes 128 256 512]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FRAMES = ROOT.parent / "shared" / "corpus" / "frames"

CHILD = r"""
import json, resource, sys
import numpy as np
import depixel
from depixel.api import load
kind, size = sys.argv[1], int(sys.argv[2])
if kind == "checkerboard":
    image = (np.indices((size, size)).sum(axis=0) % 2 * 255).astype(np.uint8)
elif kind == "noise":
    image = np.random.default_rng(0).integers(0, 256, (size, size, 3), dtype=np.uint8)
elif kind == "stripes":
    image = (np.arange(size)[None, :].repeat(size, 0) % 2 * 255).astype(np.uint8)
else:
    image = load(kind)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
depixel.convert(image)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"pixels": int(image.shape[0] * image.shape[1]), "base": base, "peak": peak}))
"""


def measure(kind: str, size: int) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, kind, str(size)], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    args = parser.parse_args()
    cases = [(kind, size) for kind in ("checkerboard", "noise", "stripes") for size in args.sizes]
    frames = sorted(FRAMES.glob("*.png"))[:1] if FRAMES.is_dir() else []
    cases += [(str(frame), 0) for frame in frames]
    print(f"{'case':34s} {'pixels':>8s} {'baseline MB':>12s} {'peak MB':>9s} {'bytes/pixel':>12s}")
    for kind, size in cases:
        r = measure(kind, size)
        name = Path(kind).name if size == 0 else f"{kind} {size}x{size}"
        per_pixel = (r["peak"] - r["base"]) / r["pixels"]
        print(f"{name:34s} {r['pixels']:8d} {r['base'] / 2**20:12.0f} {r['peak'] / 2**20:9.0f} {per_pixel:12.0f}")


if __name__ == "__main__":
    main()
