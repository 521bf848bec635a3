"""Output folders written whole or not at all (``diff --html DIR``, ``--diff-out DIR``).

A report folder is filled under a temporary name beside it (``.NAME.<pid>-<token>.tmp``)
and renamed into place when complete; a run that fails or is interrupted removes it, so
``DIR`` is never half written. An existing ``DIR`` is replaced only when it is empty or
a report of ``depixel diff`` (it holds the marker file :data:`MARKER`): a folder of the
user's is never deleted.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

from ..errors import OutputError, display_name

#: The file that marks a folder as written by ``depixel diff`` (so a rerun may replace it).
MARKER = ".depixel-diff"


class Staged:
    """A folder being written under a temporary name, for ``target``."""

    def __init__(self, target: str | os.PathLike) -> None:
        self.target = Path(target)
        name = display_name(target)
        if self.target.exists() and not self.target.is_dir():
            raise OutputError(f"{name}: is a file, not a folder")
        if self.target.is_dir() and not _replaceable(self.target):
            raise OutputError(f"{name}: exists and is not a report of depixel diff; remove it or choose "
                              "another folder")
        parent = self.target.absolute().parent
        if not parent.is_dir():
            raise OutputError(f"{name}: its folder {display_name(parent)} does not exist")
        self.path = parent / f".{self.target.name[:64]}.{os.getpid()}-{os.urandom(4).hex()}.tmp"
        try:
            self.path.mkdir()
            (self.path / MARKER).write_bytes(b"written by depixel diff: a rerun replaces this folder\n")
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
            raise OutputError(f"{display_name(self.target)}: cannot write ({exc.strerror or exc})") from None
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def discard(self) -> None:
        """Remove the unfinished folder."""
        shutil.rmtree(self.path, ignore_errors=True)


def _replaceable(folder: Path) -> bool:
    try:
        return (folder / MARKER).is_file() or not any(folder.iterdir())
    except OSError:
        return False
