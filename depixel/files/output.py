"""Writing files safely: a temporary file in the target folder, then an atomic rename.

A failure at any point leaves no partial or empty output, and an existing file at the
target is only replaced once the new content is complete (and flushed to disk). A symbolic
link at the target keeps pointing where it did; the file it points to gets the content.
Devices and pipes (``/dev/null``, ``/dev/stdout``) are written directly, never replaced.
"""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from ..errors import OutputError, display_name


def write_atomic(path: str | os.PathLike, data: bytes | str, protect: tuple[Path, ...] = ()) -> None:
    """Write ``data`` (str is UTF-8 encoded) to ``path`` atomically.

    Refuses, with a one-line :class:`OutputError`, to overwrite any file in ``protect``
    (the inputs; symbolic and hard links to them included), a folder, or a read-only file,
    and reports a missing or unwritable output folder.
    """
    name = display_name(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    try:
        target = Path(os.path.realpath(path))
        current = _stat(target, name)
        if current is not None:
            for p in protect:
                if _same_file(target, p):
                    raise OutputError(f"{name}: is the input file; refusing to overwrite it")
            if stat.S_ISDIR(current.st_mode):
                raise OutputError(f"{name}: is a directory")
            if not stat.S_ISREG(current.st_mode):
                _write_stream(target, data, name)
                return
            if not os.access(target, os.W_OK):
                raise OutputError(f"{name}: file is read-only")
        folder, shown = target.parent, display_name(Path(path).parent)
        if not folder.exists():
            raise OutputError(f"{name}: output folder {shown} does not exist")
        if not folder.is_dir():
            raise OutputError(f"{name}: {shown} is not a folder")
        fd, tmp = _temporary_file(folder, target.name)
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
        os.replace(tmp, target)
    except BaseException as exc:  # KeyboardInterrupt included: never leave the temporary file
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None
        raise


def _temporary_file(folder: Path, name: str) -> tuple[int, Path]:
    """A new, empty ``.<name>.<random>.tmp`` in ``folder``, open for writing with mode 0600:
    what ``tempfile.mkstemp`` makes, without importing ``tempfile`` (with ``shutil``, ``random``
    and the compression modules it brings, a few ms of every conversion process)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = folder / f".{name[:64]}.{os.urandom(6).hex()}.tmp"
        try:
            return os.open(tmp, flags, 0o600), tmp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary file name", str(folder))


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


def _write_stream(target: Path, data: bytes, name: str) -> None:
    """Write to a device or pipe in place (there is no partial file to clean up)."""
    try:
        with open(target, "wb") as fh:
            fh.write(data)
    except PermissionError:
        raise OutputError(f"{name}: permission denied") from None
    except OSError as exc:
        raise OutputError(f"{name}: cannot write ({exc.strerror or exc})") from None
