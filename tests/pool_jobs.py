"""Job functions for the pool tests, importable by the spawned worker processes.

``crash`` kills its own worker with SIGKILL (a real dead worker, as the OOM killer leaves
one): always for a job named "always", only the first time for "once" (a marker file
remembers it).
"""
from __future__ import annotations

import os
import signal
from pathlib import Path


def crash(job: tuple[str, str]) -> str:
    name, folder = job
    marker = Path(folder) / f"{name}.tried"
    if name == "always" or (name == "once" and not marker.exists()):
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return f"{name} done in {os.getpid()}"
