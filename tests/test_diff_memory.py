"""Issue 35, item 12: ``depixel diff`` of two 2048 × 2048 renders peaks under
DIFF_BYTES_PER_PIXEL (64) bytes a pixel, the whole process counted (it took ~150: float64
arithmetic over whole images). Run in a subprocess under ``resource.setrlimit(RLIMIT_AS)``,
so a regression fails the test instead of taking the machine's memory."""
from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
from conftest import FIXTURES
from PIL import Image

import depixel
from depixel.limits import DIFF_BYTES_PER_PIXEL

SIZE = 2048
LIMIT = 1536 * 2**20  # address space: Python, numpy and cairo, and ~4x the allowed peak

CHILD = r"""
import json, resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))
from depixel_cli.main import main
code = main(["diff", sys.argv[1], sys.argv[2], "--diff-out", sys.argv[3]])
print(json.dumps({{"code": code, "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}}))
"""


def test_diff_peak_memory_per_pixel(tmp_path):
    art = np.asarray(Image.open(FIXTURES / "mushroom.png").convert("RGBA")).copy()
    edited = art.copy()
    edited[3, 4, :3] = (24, 20, 37)
    for name, image in (("a", art), ("b", edited)):
        text = re.sub(r'width="[^"]*" height="[^"]*"', f'width="{SIZE}" height="{SIZE}"', depixel.convert(image),
                      count=1)
        (tmp_path / f"{name}.svg").write_text(text)
    run = subprocess.run([sys.executable, "-c", CHILD.format(limit=LIMIT), str(tmp_path / "a.svg"),
                          str(tmp_path / "b.svg"), str(tmp_path / "d.png")],
                         capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-500:]
    result = json.loads(run.stdout.strip().splitlines()[-1])
    assert result["code"] == 1  # the edit is seen
    with Image.open(tmp_path / "d.png") as picture:
        assert picture.size == (SIZE, SIZE)
    per_pixel = result["peak"] / SIZE**2
    assert per_pixel <= DIFF_BYTES_PER_PIXEL, f"{per_pixel:.1f} bytes a pixel"
