"""Peak memory of ``depixel diff`` per compared pixel (issue 35: at most 64 bytes a pixel).

Two SVGs drawn at SIZE × SIZE (default 2048: the mushroom fixture and a copy with one pixel
changed, converted and given that width and height) are compared by ``depixel diff A B
--diff-out d.png`` in a fresh subprocess, which prints its peak RSS (the whole process) and
its RSS after the imports and a warm-up comparison (cairo loaded); both per pixel.

    python benchmarks/diff_memory.py [--size 2048]
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, resource, sys
from depixel_cli.main import main
a, b, small, out = sys.argv[1:5]
main(["diff", small, small])  # imports and cairo loaded: the baseline
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
code = main(["diff", a, b, "--diff-out", out])
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"code": code, "base": base, "peak": peak}), file=sys.stderr)
"""


def svgs(folder: Path, size: int) -> tuple[Path, Path, Path]:
    """The two SVGs at ``size`` × ``size`` and a small one for the warm-up."""
    import numpy as np
    from PIL import Image

    import depixel

    art = np.asarray(Image.open(ROOT / "fixtures" / "mushroom.png").convert("RGBA")).copy()
    edited = art.copy()
    edited[3, 4, :3] = (24, 20, 37)
    paths = []
    for name, image in (("a", art), ("b", edited)):
        text = depixel.convert(image)
        text = re.sub(r'width="[^"]*" height="[^"]*"', f'width="{size}" height="{size}"', text, count=1)
        path = folder / f"{name}.svg"
        path.write_text(text)
        paths.append(path)
    small = folder / "small.svg"
    small.write_text(depixel.convert(art))
    return paths[0], paths[1], small


def measure(size: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        a, b, small = svgs(Path(tmp), size)
        run = subprocess.run([sys.executable, "-c", CHILD, str(a), str(b), str(small), str(Path(tmp, "d.png"))],
                             capture_output=True, text=True, check=True)
    figures = json.loads(run.stderr.strip().splitlines()[-1])
    figures["pixels"] = size * size
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=2048)
    args = parser.parse_args()
    r = measure(args.size)
    print(f"diff of two {args.size}x{args.size} SVG renders (exit {r['code']}): peak {r['peak'] / 2**20:.0f} MB, "
          f"{r['peak'] / r['pixels']:.1f} bytes a pixel; above the baseline of {r['base'] / 2**20:.0f} MB: "
          f"{(r['peak'] - r['base']) / r['pixels']:.1f} bytes a pixel")


if __name__ == "__main__":
    main()
