"""A Dask worker preload (``LocalCluster(preload=[this file], env={...})``) that makes the
worker faulty, the way tests/test_dask_faults.py needs, as ``DEPIXEL_TEST_WORKER`` says:

* ``no-depixel``: depixel is not installed (importing it fails, as in a venv without it);
* ``other-version``: depixel reports another version (and stamps its outputs with it);
* ``liar``: each task reports its output converted without writing anything (a worker
  that writes to another filesystem than the command's);
* ``kill``: the worker process kills itself (SIGKILL) during the atomic write of the
  output named by ``DEPIXEL_TEST_KILL_BEFORE`` (its temporary file written, not renamed)
  and just after the rename of ``DEPIXEL_TEST_KILL_AFTER``, once each (flag files in
  ``DEPIXEL_TEST_FLAGS``; the nanny restarts the worker, which imports this again);
* ``track``: each task leaves ``NAME.started`` and ``NAME.ended`` in ``DEPIXEL_TEST_FLAGS``
  (``NAME``: its output's), so that a test can wait for the tasks still running after the
  command stopped instead of sleeping for a time that a busy machine outlasts.
"""
from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

MODE = os.environ.get("DEPIXEL_TEST_WORKER", "")


class _Missing:
    """A meta path finder that finds depixel nowhere."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("depixel", "depixel_cli"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


def _once(name: str) -> bool:
    """True the first time ``name`` is asked, across restarts of the worker."""
    try:
        (Path(os.environ["DEPIXEL_TEST_FLAGS"]) / name).touch(exist_ok=False)
        return True
    except FileExistsError:
        return False


if MODE == "no-depixel":
    for module in [m for m in sys.modules if m.split(".")[0] in ("depixel", "depixel_cli")]:
        del sys.modules[module]
    sys.meta_path.insert(0, _Missing())

elif MODE == "other-version":  # reports it, and stamps its outputs with it, as another release would
    import depixel
    import depixel.files.stamp
    import depixel.version

    depixel.__version__ = depixel.version.__version__ = depixel.files.stamp.__version__ = "0.0.0+other"

elif MODE == "liar":
    import depixel_cli.convert.batch as batch

    def _claims(job):
        return batch.Outcome(job.source, job.output, written=[job.output])

    batch.run_job = _claims
    try:
        import depixel_cli.dask.task as dask_task

        dask_task.run_job = _claims
    except ImportError:  # an older depixel: its task is batch.run_job itself
        pass

elif MODE == "kill" and not hasattr(os.replace, "original"):  # Dask imports a preload twice
    def _replace_or_die(src, dst, *args, **kwargs):
        name = os.path.basename(os.fspath(dst))
        if name == os.environ.get("DEPIXEL_TEST_KILL_BEFORE") and _once("before"):
            os.kill(os.getpid(), signal.SIGKILL)
        _replace_or_die.original(src, dst, *args, **kwargs)
        if name == os.environ.get("DEPIXEL_TEST_KILL_AFTER") and _once("after"):
            os.kill(os.getpid(), signal.SIGKILL)

    _replace_or_die.original = os.replace  # type: ignore[attr-defined]
    os.replace = _replace_or_die

elif MODE == "track":
    import depixel_cli.dask.task as dask_task

    if not hasattr(dask_task.run_job, "tracked"):  # Dask imports a preload twice
        def _tracked(job, _run=dask_task.run_job):
            flags = Path(os.environ["DEPIXEL_TEST_FLAGS"])
            (flags / f"{job.output.name}.started").touch()
            try:
                return _run(job)
            finally:
                (flags / f"{job.output.name}.ended").touch()

        _tracked.tracked = True  # type: ignore[attr-defined]
        dask_task.run_job = _tracked
