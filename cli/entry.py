"""The ``depixel`` command's entry point: quiet signals from the first line on.

Starting the command imports numpy, Pillow and depixel (~0.1-0.2 s) before
:func:`depixel_cli.main.main` installs its handlers (:class:`depixel_cli.pool.Signals`):
Ctrl-C there would print Python's KeyboardInterrupt traceback from whatever module was
being imported. This module imports nothing else first: SIGINT or SIGTERM during those
imports (and after ``main`` has returned, while the interpreter ends) exits at once with
one line and 128 + the signal number. Only Python's own start-up before this module runs
(``site``, some 30-60 ms) is out of reach.
"""
from __future__ import annotations

import os
import signal
import sys


def _quit(signum: int, frame: object) -> None:
    """Exit now, quietly: nothing has been written yet, or everything has."""
    try:
        os.write(2, b"depixel: interrupted\n")
    except OSError:
        pass
    os._exit(128 + signum)


def main() -> None:
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is not signal.SIG_IGN:  # e.g. a background job of a script
            signal.signal(signum, _quit)
    from .main import main as run  # noqa: PLC0415 (after the handlers: this is the slow import)

    sys.exit(run())
