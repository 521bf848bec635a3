"""Where a batch's wall time goes: ``depixel convert FOLDER --out-dir OUT -j N`` run in this
process with every file timed in the process that converts it (start, end, CPU), so the
serial parts show on a machine too busy for wall-time ratios (bench_batch.py)::

    python benchmarks/batch_timeline.py                 # 200 paper sprites, -j 2
    python benchmarks/batch_timeline.py --jobs 1 --files 100

Per process: files, busy and CPU seconds, when its first file began (after the command's
``main`` was called), the idle time between its files, its first file's CPU against the
median; then the main process's CPU (``process_time``). Not part of the test suite.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_batch import DEFAULT_CORPUS, make_inputs  # noqa: E402

import depixel_cli.convert.run as batch_run  # noqa: E402
from depixel_cli.convert.batch import Outcome, run_job  # noqa: E402


def timed_run_job(job) -> Outcome:
    """``run_job`` with (pid, start, end, CPU seconds) attached to the outcome."""
    start, cpu = time.time(), time.process_time()
    out = run_job(job)
    out.timing = (os.getpid(), start, time.time(), time.process_time() - cpu)  # type: ignore[attr-defined]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS, help="folder of sprites (PNG)")
    ap.add_argument("--files", type=int, default=200, help="number of inputs")
    ap.add_argument("--jobs", type=int, default=2, help="-j")
    args = ap.parse_args()
    from depixel_cli.main import main as depixel

    batch_run.run_job = timed_run_job  # what the pool and the main process run
    ends: list[tuple[float, tuple]] = []
    run = batch_run.run

    def recording_run(jobs, workers, report, signals, progress=None):
        def record(outcome: Outcome) -> None:
            ends.append((time.time(), getattr(outcome, "timing", None)))
            report(outcome)
        return run(jobs, workers, record, signals, progress)

    import depixel_cli.convert.command as convert
    convert.run = recording_run
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "in"
        inputs.mkdir()
        make_inputs(args.corpus, inputs, args.files)
        began, cpu = time.time(), time.process_time()
        try:
            depixel(["convert", str(inputs), "--out-dir", str(Path(tmp) / "out"), "-j", str(args.jobs), "-q"])
        except SystemExit:
            pass
        wall, cpu = time.time() - began, time.process_time() - cpu
    by_process: dict[int, list[tuple[float, float, float]]] = {}
    for _, (pid, start, end, seconds) in ((t, timing) for t, timing in ends if timing is not None):
        by_process.setdefault(pid, []).append((start, end, seconds))
    print(f"-j {args.jobs}, {args.files} files: {wall:.2f} s wall from main; main process CPU {cpu:.2f} s")
    for pid, files in by_process.items():
        files.sort()
        idle = sum(files[i + 1][0] - files[i][1] for i in range(len(files) - 1))
        who = "main process" if pid == os.getpid() else f"worker {pid}"
        print(f"  {who}: {len(files)} files, busy {sum(e - s for s, e, _ in files):.2f} s, "
              f"CPU {sum(c for *_, c in files):.2f} s, first began +{files[0][0] - began:.2f} s, "
              f"last ended +{files[-1][1] - began:.2f} s, idle between files {idle:.3f} s, "
              f"first file CPU {files[0][2]:.3f} s (median {statistics.median(c for *_, c in files):.3f})")


if __name__ == "__main__":
    main()
