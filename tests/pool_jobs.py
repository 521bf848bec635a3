"""Job functions for the pool tests, importable by the spawned worker processes.

``crash`` kills its own worker with SIGKILL (a real dead worker, as the OOM killer leaves
one): always for a job named "always", only the first time for "once" (a marker file
remembers it). ``imported`` tells whether modules are imported in the worker and its
parent's pid. ``crash_holding_next`` first waits until the worker's next job is in its
pipe, and writes down whether it came, so the worker dies holding two jobs.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path


def crash(job: tuple[str, str]) -> str:
    name, folder = job
    marker = Path(folder) / f"{name}.tried"
    if name == "always" or (name == "once" and not marker.exists()):
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return f"{name} done in {os.getpid()}"


def crash_holding_next(job: tuple[str, str]) -> str:
    name, folder = job
    if name == "once" and not (Path(folder) / f"{name}.tried").exists():
        conn = sys._getframe(1).f_locals["conn"]  # the pipe of the worker loop (worker.serve)
        deadline = time.monotonic() + 10
        while not conn.poll() and time.monotonic() < deadline:
            time.sleep(0.01)
        (Path(folder) / "held next").write_text(str(conn.poll()))
    return crash(job)


def imported(modules: tuple[str, ...]) -> tuple[int, bool]:
    """The worker's parent and whether every module of ``modules`` is imported in it."""
    return os.getppid(), all(name in sys.modules for name in modules)
