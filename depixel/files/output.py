"""Writing files safely: a temporary file in the target folder, then an atomic rename.

A failure at any point leaves no partial or empty output, and an existing file at the
target is only replaced once the new content is complete (and flushed to disk). A symbolic
link at the target keeps pointing where it did; the file it points to gets the content.
Character devices and pipes (``/dev/null``, ``/dev/stdout``, ``>(gzip > x.svgz)``) are
written directly, never replaced; a named pipe nobody reads is refused at once instead of
waiting for a reader, and block devices and sockets are refused.

Temporary files have a name only this run can have, in one fixed pattern:
``.NAME.depixel-PID-TOKEN.tmp`` beside the output (NAME: the output's name, cut to 64 bytes;
PID: the writing process; TOKEN: the run's random token, :func:`run_token`, which a batch
passes to every worker it starts, including Dask's). Cleanup removes only such names:
a process's own by its registry (:func:`remove_created`), another process's (a worker that
was killed) by the pattern with this run's token (:func:`remove_temporary`), never by a
glob that a user's ``.big.svg.mine.tmp`` could match.

A batch whose tasks cannot be stopped once started (Dask's) sets :data:`STILL_WANTED` around
each task: outputs are renamed into place only while it answers True, so a stopped batch's
tasks do not complete files that its report says were not made.
"""
from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import sys
import threading
from collections.abc import Callable, Sequence
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import OutputError, ParameterError, display_name

#: Bytes of the output's name kept in a temporary file's name (NAME_MAX is 255 bytes).
NAME_BYTES = 64
_TOKEN = re.compile(r"[0-9a-f]{8,32}")
_run_token: str | None = None
#: The temporary files this process created and has not yet renamed or removed.
_created: set[Path] = set()
#: Asked just before outputs are renamed into place, when set: False means that the batch
#: they belong to has stopped, and they are not written (depixel_cli/dask/task.py).
STILL_WANTED: ContextVar[Callable[[], bool] | None] = ContextVar("depixel_still_wanted", default=None)


def run_token() -> str:
    """This run's token: 12 random hex digits drawn on first use (a forked worker inherits
    it; other workers are given it, e.g. ``write_atomic(..., token=...)``)."""
    global _run_token
    if _run_token is None:
        _run_token = os.urandom(6).hex()
    return _run_token


def temporary_path(target: str | os.PathLike, token: str | None = None, pid: int | None = None) -> Path:
    """The temporary file that process ``pid`` (this one by default) of run ``token`` (this
    run's by default) writes ``target`` through: ``.NAME.depixel-PID-TOKEN.tmp`` beside it
    (symbolic links resolved, as :func:`write_atomic` does)."""
    real = Path(os.path.realpath(target))
    return real.parent / f"{_prefix(real.name)}{os.getpid() if pid is None else int(pid)}-{_token(token)}.tmp"


def remove_temporary(target: str | os.PathLike, token: str, pid: int | None = None) -> list[Path]:
    """Remove the temporary files of ``target`` left by run ``token`` (by its process ``pid``,
    or by any of its processes): only names in the fixed pattern with that token, which no
    other run and no user file has. Returns what was removed; never raises."""
    try:
        real = Path(os.path.realpath(target))
        mine = re.compile(re.escape(_prefix(real.name)) + (str(int(pid)) if pid is not None else r"[0-9]+")
                          + "-" + _token(token) + r"(?:-[0-9]+)?\.tmp")
        with os.scandir(real.parent) as entries:
            names = [entry.name for entry in entries if mine.fullmatch(entry.name)]
    except (OSError, ValueError):  # ParameterError (a bad token) included: nothing is ours
        return []
    return [real.parent / name for name in names if _remove(real.parent / name)]


def remove_temporary_in(folder: str | os.PathLike, token: str) -> list[Path]:
    """Remove every temporary file of run ``token`` in ``folder``, whatever its output and
    process: :func:`remove_temporary` for all the outputs of a folder at once (one look at
    the folder, not one an output). Returns what was removed; never raises."""
    try:
        real = Path(os.path.realpath(folder))
        mine = re.compile(r"\..+\.depixel-[0-9]+-" + _token(token) + r"(?:-[0-9]+)?\.tmp", re.DOTALL)
        with os.scandir(real) as entries:
            names = [entry.name for entry in entries if mine.fullmatch(entry.name)]
    except (OSError, ValueError):  # ParameterError (a bad token) included: nothing is ours
        return []
    return [real / name for name in names if _remove(real / name)]


def remove_stale_in(folder: str | os.PathLike) -> list[Path]:
    """Remove the temporary files in ``folder`` (of any output, any run) whose process is
    no longer running on this machine: what a run killed with SIGKILL left behind. A
    process that is alive, or may be (another user's), keeps its files. (On a folder that
    several machines write at once, the process of another machine looks gone here: call
    this only where one machine writes, as ``depixel diff --update`` in its baseline.)
    Returns what was removed; never raises."""
    try:
        real = Path(os.path.realpath(folder))
        pattern = re.compile(r"\..+\.depixel-([0-9]+)-[0-9a-f]{8,32}(?:-[0-9]+)?\.tmp", re.DOTALL)
        with os.scandir(real) as entries:
            found = [(entry.name, int(m[1])) for entry in entries if (m := pattern.fullmatch(entry.name))]
    except OSError:
        return []
    return [real / name for name, pid in found if not process_alive(pid) and _remove(real / name)]


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine (this process: True)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # another user's (PermissionError): alive; a pid out of range: not
        return isinstance(sys.exc_info()[1], PermissionError)
    return True


def remove_created() -> list[Path]:
    """Remove every temporary file this process created and has not renamed into place yet
    (its registry: e.g. after an interrupt that came between creating one and the ``try``
    that removes it). Returns what was removed."""
    return [tmp for tmp in list(_created) if _remove(tmp)]


def _remove(tmp: Path) -> bool:
    """Remove a temporary file; it leaves the registry once it is gone. Whether it was removed."""
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        _created.discard(tmp)
        return False
    except OSError:
        return False
    _created.discard(tmp)
    return True


def _prefix(name: str) -> str:
    """``.NAME.depixel-``: the start of every temporary name of the output ``name``."""
    cut = os.fsdecode(os.fsencode(name)[:NAME_BYTES])
    return f".{cut}.depixel-"


def _token(token: str | None) -> str:
    token = run_token() if token is None else token
    if not isinstance(token, str) or not _TOKEN.fullmatch(token):
        raise ParameterError(f"a run token is 8 to 32 lowercase hex digits, not {token!r}", parameter="token")
    return token


def write_atomic(path: str | os.PathLike, data: bytes | str, protect: tuple[Path, ...] = (),
                 token: str | None = None, replace_link: bool = False) -> None:
    """Write ``data`` (str is UTF-8 encoded) to ``path`` atomically, through the temporary
    file :func:`temporary_path` names (run ``token``, this run's by default).

    Refuses, with a one-line :class:`OutputError`, to overwrite any file in ``protect``
    (the inputs; symbolic and hard links to them included), a folder, or a read-only file,
    and reports a missing or unwritable output folder. With ``replace_link``, a symbolic
    link at ``path`` is itself replaced by the file (what it points to is left alone).
    """
    staged = stage(path, data, protect, token, replace_link)
    commit([staged] if staged is not None else [])


@dataclass(eq=False)
class Staged:
    """An output written in full to its temporary file, waiting to be renamed into place."""

    target: Path  # symbolic links resolved
    tmp: Path
    name: str  # as shown in messages


def stage(path: str | os.PathLike, data: bytes | str, protect: tuple[Path, ...] = (),
          token: str | None = None, replace_link: bool = False) -> Staged | None:
    """The first half of :func:`write_atomic`: ``data`` written and flushed to the temporary
    file, with the mode the output will have; :func:`commit` renames it into place,
    :func:`discard` removes it. Several outputs staged and then committed together are
    all written or none (a frame set). A device or pipe is written in place at once: None."""
    token = _token(token)
    name = display_name(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    try:
        link = replace_link and os.path.islink(path)
        kind = None if link else _stat(Path(path), name)  # through every link, /proc/self/fd/1's included
        if kind is not None and not stat.S_ISREG(kind.st_mode) and not stat.S_ISDIR(kind.st_mode):
            _write_stream(path, kind.st_mode, data, name)
            return None
        target = Path(os.path.realpath(path))
        if link:  # the link itself is replaced: its folder's real path, its own name
            target = Path(os.path.realpath(Path(path).parent), Path(path).name)
        current = None if link else _stat(target, name)
        if current is not None:
            for p in protect:
                if _same_file(target, p):
                    raise OutputError(f"{name}: is the input file; refusing to overwrite it")
            if stat.S_ISDIR(current.st_mode):
                raise OutputError(f"{name}: is a directory")
            if not os.access(target, os.W_OK):
                raise OutputError(f"{name}: file is read-only")
        folder, shown = target.parent, display_name(Path(path).parent)
        if not folder.exists():
            raise OutputError(f"{name}: output folder {shown} does not exist")
        if not folder.is_dir():
            raise OutputError(f"{name}: {shown} is not a folder")
        fd, tmp = _temporary_file(target, token)
    except OutputError:
        raise
    except PermissionError:
        raise OutputError(f"{name}: permission denied (cannot write in its folder)") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        raise OutputError(f"{name}: cannot write ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, stat.S_IMODE(current.st_mode) if current is not None else 0o666 & ~_umask())
    except BaseException as exc:  # KeyboardInterrupt included: never leave the temporary file
        _remove(tmp)
        if isinstance(exc, OSError):
            raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None
        raise
    return Staged(target, tmp, name)


def commit(staged: Sequence[Staged]) -> None:
    """Rename staged outputs into place, with SIGINT and SIGTERM deferred until the last is in
    place (a Ctrl-C then stops after them, not between two frames of a set). On a failure
    the ones not renamed yet are removed and an :class:`OutputError` is raised; so are all
    of them when :data:`STILL_WANTED` says their batch has stopped."""
    if staged and (wanted := STILL_WANTED.get()) is not None and not wanted():
        discard(staged)
        raise OutputError(f"{staged[0].name}: not written: its batch was stopped")
    with signals_deferred(bool(staged)):
        for i, item in enumerate(staged):
            try:
                os.replace(item.tmp, item.target)
            except BaseException as exc:  # never leave a temporary file
                discard(staged[i:])
                if isinstance(exc, OSError):
                    raise OutputError(f"{item.name}: cannot write ({exc.strerror or exc})") from None
                raise
            _created.discard(item.tmp)


@contextlib.contextmanager
def signals_deferred(active: bool = True):
    """SIGINT and SIGTERM noted and handed to their handlers once the block is done. A
    Python handler, replaced for the duration (a signal mask would not do: the kernel gives a
    process's signal to any thread that does not block it, OpenBLAS's included, and Python
    then runs the handler in the main thread all the same). Only the main thread sets
    handlers; elsewhere none runs in this thread anyway."""
    import signal  # noqa: PLC0415

    pending: list[int] = []
    saved: dict[signal.Signals, Callable[[int, Any], Any]] = {}
    if active and threading.current_thread() is threading.main_thread():
        for number in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(number)
            if callable(handler):  # a Python handler: deferred (SIG_DFL, SIG_IGN, C ones left as they are)
                saved[number] = handler
                signal.signal(number, lambda signum, frame: pending.append(signum))
    try:
        yield
    finally:
        for number, handler in saved.items():
            signal.signal(number, handler)
        for signum in pending:
            signal.raise_signal(signum)


def make_folders(folder: str | os.PathLike) -> None:
    """``folder`` and its missing parents, made one by one from the top (``Path.mkdir``
    with ``parents`` recurses, and a tree thousands of levels deep would exhaust the stack);
    one-line :class:`OutputError` when one cannot be made."""
    path = Path(folder)
    missing = []
    while not path.is_dir():
        missing.append(path)
        if path.parent == path:
            break
        path = path.parent
    for path in reversed(missing):
        try:
            path.mkdir(exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{display_name(path)}: cannot create folder ({exc.strerror or exc})") from None


def remove_file(path: str | os.PathLike) -> None:
    """Remove a file (a symbolic link: the link itself, never what it points to); one that
    is already gone is no error; any other failure is a one-line :class:`OutputError`."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError as exc:
        raise OutputError(f"{display_name(path)}: cannot remove ({exc.strerror or exc})") from None


def discard(staged: Sequence[Staged]) -> None:
    """Remove staged outputs' temporary files (those not committed)."""
    for item in staged:
        _remove(item.tmp)


def _temporary_file(target: Path, token: str) -> tuple[int, Path]:
    """A new, empty temporary file for ``target`` (:func:`temporary_path`), open for writing
    with mode 0600 and in the registry. The name is taken only when this process already
    writes ``target`` (threads): then ``-1``, ``-2``, … is added to it. (``tempfile.mkstemp``
    is not used: importing it costs a few ms of every conversion process.)"""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    first = target.parent / f"{_prefix(target.name)}{os.getpid()}-{_token(token)}.tmp"  # (target: resolved)
    for attempt in range(100):
        tmp = first if not attempt else first.with_name(f"{first.name[:-4]}-{attempt}.tmp")
        try:
            fd = os.open(tmp, flags, 0o600)
        except FileExistsError:
            continue
        _created.add(tmp)
        return fd, tmp
    raise FileExistsError(errno.EEXIST, "no free temporary file name", str(target.parent))


def _umask() -> int:
    """The process's umask (new files get 0666 without its bits, as ``open`` would give them);
    read from /proc where it can be, since setting it to read it is not thread-safe."""
    try:
        with open("/proc/self/status", "rb") as fh:
            for line in fh:
                if line.startswith(b"Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _stat(target: Path, name: str) -> os.stat_result | None:
    """``os.stat`` of the target, ``None`` when it does not exist yet."""
    try:
        return target.stat()
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise OutputError(f"{name}: a parent of it is a file, not a folder") from None


def _same_file(target: Path, other: Path) -> bool:
    try:
        return os.path.samefile(target, other)
    except (OSError, ValueError):
        return False


def _write_stream(path: str | os.PathLike, mode: int, data: bytes, name: str) -> None:
    """Write to a character device or a pipe in place (there is no partial file to clean
    up). Opened without waiting: a named pipe with no reader is refused, not waited on."""
    if stat.S_ISBLK(mode):
        raise OutputError(f"{name}: is a block device; refusing to write to it")
    if stat.S_ISSOCK(mode):
        raise OutputError(f"{name}: is a socket, not a file")
    flags = os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except PermissionError:
        raise OutputError(f"{name}: permission denied") from None
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OutputError(f"{name}: a pipe nobody reads; refusing to wait for a reader") from None
        raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None
    try:
        os.set_blocking(fd, True)  # a reader is there: the writes go at its pace
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
    except OSError as exc:
        raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
