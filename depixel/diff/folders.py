"""Comparing two folders of renders, file by file, for CI (``depixel diff BASELINE CURRENT``).

Files are paired by relative path: the SVG, SVGZ, PNG and PDF files under each folder
(hidden files and folders left out). A name in both is a pair; a name on one side only
is paired with the one file of the other side that has the same name up to the extension
(``icons/a.png`` in the baseline with ``icons/a.svg`` in the current, compared as any SVG
with a PNG); whatever is left is **missing** (only in the baseline) or **new** (only in the
current). Each pair gets a verdict, **same**, **different** or **error** (a file that
could not be read, rendered or compared, with the one-line reason), from
:func:`compare_pair`, which never raises and writes the pictures a report shows.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError, display_name
from .pairs import DIFFERENT, ERROR, MISSING, NEW, SAME, VERDICTS, Pair, PairResult
from .sources import EXTENSIONS


def renders(folder: str | os.PathLike) -> list[str]:
    """The relative paths (``/``-separated, sorted) of the renders under ``folder``."""
    root = Path(folder)
    found = []
    for here, dirs, names in os.walk(root, onerror=_raise):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in names:
            if not name.startswith(".") and os.path.splitext(name)[1].lower() in EXTENSIONS:
                found.append(Path(here, name).relative_to(root).as_posix())
    return sorted(found)


def _raise(exc: OSError) -> None:
    raise InputError(f"{display_name(exc.filename)}: cannot list the folder ({exc.strerror or exc})")


def pair_folders(baseline: str | os.PathLike, current: str | os.PathLike) -> list[Pair]:
    """Every render of either folder in one pair (module docstring), sorted by name."""
    old, new = renders(baseline), renders(current)
    both = set(old) & set(new)
    pairs = [Pair(name, name) for name in both]
    lone_old = _by_stem(n for n in old if n not in both)
    lone_new = _by_stem(n for n in new if n not in both)
    for stem in sorted(set(lone_old) | set(lone_new)):
        a, b = lone_old.get(stem, []), lone_new.get(stem, [])
        if len(a) == 1 and len(b) == 1:
            pairs.append(Pair(a[0], b[0]))
        else:
            pairs += [Pair(n, None) for n in a] + [Pair(None, n) for n in b]
    return sorted(pairs, key=lambda p: (p.name, p.baseline or ""))


def _by_stem(names) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for name in names:
        out.setdefault(os.path.splitext(name)[0], []).append(name)
    return out




def totals(results: list[PairResult]) -> dict[str, int]:
    """How many results have each verdict."""
    return {verdict: sum(1 for r in results if r.verdict == verdict) for verdict in VERDICTS}


def status(results: list[PairResult], allow_new: bool = False, allow_missing: bool = False) -> str:
    """The verdict on the whole comparison: ``"same"`` when every pair is the same (new and
    missing files accepted when allowed), ``"error"`` when nothing could be compared (no
    file at all, or every pair an error), else ``"different"``."""
    counts = totals(results)
    if not results or counts[ERROR] == len(results):
        return ERROR
    failing = counts[DIFFERENT] + counts[ERROR] + (0 if allow_new else counts[NEW]) + \
        (0 if allow_missing else counts[MISSING])
    return DIFFERENT if failing else SAME
