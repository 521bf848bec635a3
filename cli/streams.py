"""Standard input and output as a Unix tool treats them.

* A closed pipe (``depixel convert big.png -o - | head -c 100``) ends the command quietly
  with :data:`CLOSED_PIPE`, the status a shell shows for a tool that SIGPIPE killed: the
  reader has what it wanted, a message would only interleave with its output.
* Any other failure to write standard output (``> /dev/full``, standard output closed with
  ``>&-``) is a one-line :class:`~depixel.errors.OutputError`, ``<stdout>: cannot write (…)``.
* Standard input closed with ``<&-`` is a usage error where ``-`` asks for it.

Python's buffered writer may return after writing part of a large block to a pipe whose
reader has gone, without an error (the next write would fail): :func:`write_stdout` writes
until everything is written or an error says why not.
"""
from __future__ import annotations

import os
import sys

#: Exit status after the reader of standard output went away: 128 + SIGPIPE, as a shell
#: reports a tool that the signal ended.
CLOSED_PIPE = 141
#: How messages name standard output.
STDOUT = "<stdout>"


def reserve_closed_descriptors() -> None:
    """Point each closed standard descriptor (0, 1, 2) at the null device, so that no file
    opened later takes its number (a temporary output opened as descriptor 1 would receive
    whatever is meant for standard output). ``sys.stdin`` and ``sys.stdout`` stay None, which
    is how :func:`stdin_closed` and :func:`write_stdout` recognise a closed stream."""
    for fd in (0, 1, 2):  # in order: os.open takes the lowest free number, this one
        try:
            os.fstat(fd)
        except OSError:
            try:
                os.open(os.devnull, os.O_RDONLY if fd == 0 else os.O_WRONLY)
            except OSError:
                return


def stdin_closed() -> bool:
    """Whether standard input was closed when the command started (``<&-``)."""
    return sys.stdin is None


def write_stdout(data: bytes) -> None:
    """Write ``data`` to standard output, all of it. A closed pipe raises
    :class:`BrokenPipeError` (the command ends with :data:`CLOSED_PIPE`); any other failure
    is an :class:`OutputError`."""
    from depixel.errors import OutputError  # noqa: PLC0415

    if sys.stdout is None:
        raise OutputError(f"{STDOUT}: cannot write (standard output is closed)")
    try:
        sys.stdout.flush()
        out = sys.stdout.buffer
        view = memoryview(data)
        while view:
            written = out.write(view)
            if not written:
                raise OSError("nothing written")
            view = view[written:]
        out.flush()
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise OutputError(f"{STDOUT}: cannot write ({exc.strerror or exc})") from None


def print_stdout(text: str) -> None:
    """``print(text)`` through :func:`write_stdout` (a report can be larger than a pipe holds)."""
    encoding = getattr(sys.stdout, "encoding", None) or "utf-8"
    write_stdout((text + "\n").encode(encoding, "replace"))


def flush_stdout() -> None:
    """Flush what ``print`` left in standard output's buffer, while a closed pipe can still
    be handled (at exit Python would report it with a traceback)."""
    if sys.stdout is not None:
        sys.stdout.flush()


def closed_pipe() -> int:
    """After standard output's reader went away: point descriptor 1 at the null device, so
    that the interpreter's last flush has nowhere to fail, and return :data:`CLOSED_PIPE`."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.close(null)
    except OSError:
        pass
    return CLOSED_PIPE
