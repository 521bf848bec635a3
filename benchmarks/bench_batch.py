"""Batch speed-up: ``depixel convert FOLDER --out-dir OUT -j N`` on many sprites, ``-j 1``
against ``-j 2`` (or any ``--jobs``), wall time of the whole command, rounds interleaved.

The paper corpus is copied (under new names) until there are ``--files`` inputs, in a
temporary folder that is removed afterwards::

    python benchmarks/bench_batch.py                      # 200 sprites, -j 1 and -j 2, 2 rounds
    python benchmarks/bench_batch.py --jobs 1 2 4 --rounds 3

Needs ``../shared/corpus/paper`` (or ``--corpus``). Not part of the test suite.
"""
from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CORPUS = ROOT.parent / "shared" / "corpus" / "paper"


def make_inputs(corpus: Path, folder: Path, count: int) -> None:
    """``count`` PNG files in ``folder``: the corpus sprites, copied round after round."""
    sprites = sorted(corpus.glob("*.png"))
    if not sprites:
        sys.exit(f"no sprites in {corpus}")
    for i in range(count):
        source = sprites[i % len(sprites)]
        shutil.copyfile(source, folder / f"{source.stem}-{i // len(sprites)}.png")


def batch_seconds(inputs: Path, out: Path, jobs: int) -> float:
    """Wall time of one batch into an empty ``out``."""
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "depixel_cli.main", "convert", str(inputs), "--out-dir", str(out),
                           "-j", str(jobs), "-q"], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"-j {jobs} failed ({done.returncode}): {done.stderr.strip()}")
    return seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder of sprites (PNG)")
    ap.add_argument("--files", type=int, default=200, help="number of inputs")
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="-j values to compare (the first is the base)")
    ap.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "in"
        inputs.mkdir()
        make_inputs(args.corpus, inputs, args.files)
        times: dict[int, list[float]] = {j: [] for j in args.jobs}
        for round_ in range(args.rounds):
            for jobs in args.jobs:
                times[jobs].append(batch_seconds(inputs, Path(tmp) / "out", jobs))
                print(f"round {round_ + 1}, -j {jobs}: {times[jobs][-1]:.1f} s", flush=True)
    base = statistics.median(times[args.jobs[0]])
    for jobs in args.jobs:
        median = statistics.median(times[jobs])
        print(f"-j {jobs}: median {median:.1f} s for {args.files} files, {base / median:.2f}x -j {args.jobs[0]}")


if __name__ == "__main__":
    main()
