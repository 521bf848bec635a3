"""Batch speed-up: ``depixel convert FOLDER --out-dir OUT -j N`` on many sprites, ``-j 1``
against ``-j 2`` (or any ``--jobs``), wall time of the whole command, rounds interleaved.

Also the CPU time of the command's whole process tree (on Linux this script adopts the
orphans, e.g. a fork server and its workers, and reaps them, so they are counted): on a
machine that others load, the wall-time ratio says little, while ``-j N``'s extra CPU over
``-j 1`` still shows what a parallel batch costs beyond its files. The load average is
printed with each run.

The paper corpus is copied (under new names) until there are ``--files`` inputs, in a
temporary folder that is removed afterwards::

    python benchmarks/bench_batch.py                      # 200 sprites, -j 1 and -j 2, 2 rounds
    python benchmarks/bench_batch.py --jobs 1 2 4 --rounds 3

Needs ``../shared/corpus/paper`` (or ``--corpus``). Not part of the test suite.
"""
from __future__ import annotations

import argparse
import os
import resource
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


def adopt_orphans() -> None:
    """Linux: become the parent of the command's orphaned descendants (PR_SET_CHILD_SUBREAPER)."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None).prctl(36, 1)


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def batch_seconds(inputs: Path, out: Path, jobs: int) -> tuple[float, float]:
    """Wall time and CPU time (the whole process tree) of one batch into an empty ``out``."""
    shutil.rmtree(out, ignore_errors=True)
    cpu, start = children_cpu(), time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "depixel_cli.main", "convert", str(inputs), "--out-dir", str(out),
                           "-j", str(jobs), "-q"], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    while True:  # the adopted orphans, once they end
        try:
            os.wait()
        except ChildProcessError:
            break
    if done.returncode != 0:
        sys.exit(f"-j {jobs} failed ({done.returncode}): {done.stderr.strip()}")
    return seconds, children_cpu() - cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder of sprites (PNG)")
    ap.add_argument("--files", type=int, default=200, help="number of inputs")
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="-j values to compare (the first is the base)")
    ap.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    args = ap.parse_args()
    adopt_orphans()
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "in"
        inputs.mkdir()
        make_inputs(args.corpus, inputs, args.files)
        times: dict[int, list[float]] = {j: [] for j in args.jobs}
        cpus: dict[int, list[float]] = {j: [] for j in args.jobs}
        for round_ in range(args.rounds):
            for jobs in args.jobs:
                load = os.getloadavg()[0]
                seconds, cpu = batch_seconds(inputs, Path(tmp) / "out", jobs)
                times[jobs].append(seconds)
                cpus[jobs].append(cpu)
                print(f"round {round_ + 1}, -j {jobs}: {seconds:.1f} s (CPU {cpu:.1f} s, load {load:.1f})", flush=True)
    base, base_cpu = statistics.median(times[args.jobs[0]]), statistics.median(cpus[args.jobs[0]])
    for jobs in args.jobs:
        median, cpu = statistics.median(times[jobs]), statistics.median(cpus[jobs])
        print(f"-j {jobs}: median {median:.1f} s for {args.files} files, {base / median:.2f}x -j {args.jobs[0]}; "
              f"CPU {cpu:.1f} s, {100 * (cpu / base_cpu - 1):+.1f} % over -j {args.jobs[0]}")


if __name__ == "__main__":
    main()
