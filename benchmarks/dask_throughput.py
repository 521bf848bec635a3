"""Batch throughput on Dask: ``depixel convert CORPUS --dask`` on a LocalCluster of 1 and 2
workers, beside ``-j 1`` and ``-j 2`` on the same files (docs/scale.md carries the figures).

Each setting runs the installed command in a fresh output folder and reports wall seconds
and files per second (best of ``--repeat``); the outputs of every setting are checked to be
byte-identical. The cluster is started before the clock and kept warm between repeats, as
a real cluster would be.

    python benchmarks/dask_throughput.py [--corpus ../shared/corpus/paper] [--repeat 2]
"""
from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def digest(folder: Path) -> str:
    h = hashlib.sha256()
    for path in sorted(folder.rglob("*")):
        if path.is_file():
            h.update(path.relative_to(folder).as_posix().encode() + path.read_bytes())
    return h.hexdigest()


def timed(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--corpus", type=Path, default=ROOT.parent / "shared" / "corpus" / "paper")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    from distributed import LocalCluster

    files = sorted(p for p in args.corpus.iterdir() if p.suffix == ".png")
    script = [sys.executable, "-m", "depixel", "convert", str(args.corpus), "--force"]
    print(f"{len(files)} files from {args.corpus}; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    digests = {}
    with tempfile.TemporaryDirectory() as tmp:
        settings: list[tuple[str, list[str], object]] = [("-j 1", ["-j", "1"], None), ("-j 2", ["-j", "2"], None)]
        settings += [(f"--dask, {n} local worker{'s' if n > 1 else ''}", [], n) for n in (1, 2)]
        for label, extra, n_workers in settings:
            out = Path(tmp) / label.replace(" ", "_").replace(",", "")
            if n_workers is None:
                times = [timed(script + ["--out-dir", str(out)] + extra) for _ in range(args.repeat)]
            else:
                with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
                    times = [timed(script + ["--out-dir", str(out), "--dask", cluster.scheduler_address])
                             for _ in range(args.repeat)]
            best = min(times)
            digests[label] = digest(out)
            print(f"{label:28s} {best:6.2f} s  {len(files) / best:5.1f} files/s")
    same = len(set(digests.values())) == 1
    print("outputs byte-identical across settings:", "yes" if same else f"NO {digests}")


if __name__ == "__main__":
    main()
