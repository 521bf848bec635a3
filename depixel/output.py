"""Writing files safely: a temporary file in the target folder, then an atomic rename.

A failure at any point leaves no partial or empty output, and an existing file at the
target is only replaced once the new content is complete.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .errors import OutputError


def write_atomic(path: str | os.PathLike, data: bytes | str, protect: tuple[Path, ...] = ()) -> None:
    """Write ``data`` to ``path`` atomically; refuse to overwrite any path in ``protect``."""
    target = Path(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    for p in protect:
        try:
            if target.exists() and p.exists() and os.path.samefile(target, p):
                raise OutputError(f"{target}: refusing to overwrite the input file")
        except OSError:
            pass
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"{target}: output folder {folder} does not exist")
    if target.is_dir():
        raise OutputError(f"{target}: is a directory")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except PermissionError:
        raise OutputError(f"{target}: permission denied (cannot write in {folder})") from None
    except OSError as exc:
        raise OutputError(f"{target}: cannot write ({exc.strerror or exc})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise OutputError(f"{target}: cannot write ({exc.strerror or exc})") from None
        raise
