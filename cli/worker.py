"""The worker process of :mod:`depixel_cli.pool`: serve jobs from a pipe until told to stop.

A worker ignores SIGINT (only the main process decides what Ctrl-C means), turns SIGTERM into
:class:`Stop` (its job is abandoned; a file being written removes its temporary file) and
asks the kernel for SIGTERM when the main process dies. Once it is stopping it ignores every
further signal: SIGTERM sent to the whole process group (``timeout``, systemd, ``kill -TERM
-PGID``) reaches it, and then the main process's own SIGTERM, while it exits, where a second
:class:`Stop` would escape to multiprocessing, which prints it with a traceback.
"""
from __future__ import annotations

import os
import signal
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any


class Stop(BaseException):
    """SIGTERM in a worker: abandon the job (files being written remove their temporary file)."""


def raise_stop(signum: int, frame: object) -> None:
    stopping()
    raise Stop()


def stopping() -> None:
    """From now on the worker is on its way out: SIGTERM and the re-raise timer of
    :func:`unraisable` are ignored."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGALRM, signal.SIG_IGN)


def unraisable(hook: Any) -> None:
    """A :class:`Stop` raised in a finalizer (a generator closed by the collector) is
    swallowed there, with "Exception ignored" on stderr: stop again 10 ms later (SIGALRM),
    out of it, quietly (swallowed again, it tries again)."""
    if isinstance(hook.exc_value, Stop):
        signal.signal(signal.SIGALRM, raise_stop)
        signal.setitimer(signal.ITIMER_REAL, 0.01)
        return
    sys.__unraisablehook__(hook)


def serve(conn, function: Callable, inherited: Sequence[Any] = ()) -> None:
    """A worker's life: ignore SIGINT, stop on SIGTERM or when the main process is gone.
    ``inherited``: the main process's ends of pipes, closed (a forked worker)."""
    for other in inherited:
        other.close()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, raise_stop)
    try:  # from here on SIGTERM raises Stop: the set-up too (a stop request may come at once)
        # a SIGTERM that came while the signals were blocked (since the fork) is raised here
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
        sys.unraisablehook = unraisable
        warnings.simplefilter("ignore")  # as in the command (forked workers have its filters already)
        die_with_parent()
        while True:
            try:
                job = conn.recv()
            except (EOFError, OSError):
                break
            if job is None:
                break
            result = function(job)
            try:
                conn.send(result)
            except (BrokenPipeError, OSError):
                break
        stopping()  # inside the try: a SIGTERM until here is a Stop, caught below
    except (Stop, KeyboardInterrupt):
        stopping()
    finally:
        sys.stdout.flush()


def die_with_parent() -> None:
    """Linux: ask the kernel for SIGTERM when the main process dies (even by SIGKILL)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes  # noqa: PLC0415

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() == 1:  # the parent died before prctl took effect
        raise SystemExit(0)
