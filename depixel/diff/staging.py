"""Output folders written whole or not at all (``diff --html DIR``, ``--diff-out DIR``).

A report folder is filled under a temporary name beside it (``.NAME.<pid>-<token>.tmp``)
and renamed into place when complete; a run that fails or is interrupted removes it, so
``DIR`` is never half written. An existing ``DIR`` is replaced only when it is empty or
a report of ``depixel diff`` (it holds the marker file :data:`MARKER`): a folder of the
user's is never deleted. ``DIR`` given as a symbolic link is the folder it points to
(replaced there; the link is kept). The marker names the machine and process that
wrote the folder, so a later run removes the temporary folders of a run killed on this
machine (SIGKILL gives no chance to clean up), and never another machine's.
"""
from __future__ import annotations

import os
import re
import shutil
import socket
from pathlib import Path

from ..errors import OutputError, display_name
from ..files.output import process_alive

#: The file that marks a folder as written by ``depixel diff`` (so a rerun may replace it).
MARKER = ".depixel-diff"


class Staged:
    """A folder being written under a temporary name, for ``target``."""

    def __init__(self, target: str | os.PathLike) -> None:
        self.target = Path(os.path.realpath(target)) if os.path.islink(target) else Path(target)
        self.shown = Path(target)  # as given, for messages
        name = display_name(target)
        if self.target.exists() and not self.target.is_dir():
            raise OutputError(f"{name}: is a file, not a folder")
        if self.target.is_dir() and not _replaceable(self.target):
            raise OutputError(f"{name}: exists and is not a report of depixel diff; remove it or choose "
                              "another folder")
        parent = self.target.absolute().parent
        if not parent.is_dir():
            raise OutputError(f"{name}: its folder {display_name(parent)} does not exist")
        _remove_stale(parent, self.target.name[:64])
        self.path = parent / f".{self.target.name[:64]}.{os.getpid()}-{os.urandom(4).hex()}.tmp"
        try:
            self.path.mkdir()
            (self.path / MARKER).write_bytes(f"written by depixel diff: a rerun replaces this folder\nhost "
                                             f"{socket.gethostname()} pid {os.getpid()}\n".encode())
        except OSError as exc:
            self.discard()
            raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None

    def publish(self) -> None:
        """Move the finished folder into place (replacing an older report)."""
        old = None
        try:
            if self.target.is_dir():
                old = self.path.with_name(self.path.name[:-4] + ".old")
                os.rename(self.target, old)
            os.rename(self.path, self.target)
        except OSError as exc:
            if old is not None and not self.target.exists():
                os.rename(old, self.target)
            self.discard()
            raise OutputError(f"{display_name(self.shown)}: cannot write ({exc.strerror or exc})") from None
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def discard(self) -> None:
        """Remove the unfinished folder."""
        shutil.rmtree(self.path, ignore_errors=True)


def _remove_stale(parent: Path, name: str) -> None:
    """Remove the temporary folders of ``name`` in ``parent`` that a run killed on this
    machine left (the marker says this host, and its process is gone)."""
    pattern = re.compile(re.escape(f".{name}.") + r"([0-9]+)-[0-9a-f]{8}\.(?:tmp|old)")
    try:
        with os.scandir(parent) as entries:
            found = [(entry.path, int(m[1])) for entry in entries if (m := pattern.fullmatch(entry.name))]
    except OSError:
        return
    host = socket.gethostname()
    for path, pid in found:
        try:
            lines = Path(path, MARKER).read_text(encoding="utf-8", errors="replace").splitlines()
        except OSError:
            continue
        written_by = lines[1].split() if len(lines) > 1 else []
        here = written_by[:2] == ["host", host] or path.endswith(".old")  # an old report: its publisher's pid
        if here and not process_alive(pid):
            shutil.rmtree(path, ignore_errors=True)


def _replaceable(folder: Path) -> bool:
    try:
        return (folder / MARKER).is_file() or not any(folder.iterdir())
    except OSError:
        return False
