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
    """The relative paths (``/``-separated, sorted) of the renders under ``folder``.

    Hidden files and folders are left out, and so are the report folders of ``depixel
    diff`` (``--html``, ``--diff-out``: they hold :data:`~depixel.diff.staging.MARKER`), so a
    report written inside a compared folder is not compared on the next run. A symbolic
    link to a folder is followed (its files count as the link's, as a person browsing the
    folder sees them), except one back to a folder it lies in (a loop). The walk keeps its
    own list of folders to visit: a tree thousands of levels deep is no error."""
    from .staging import MARKER  # noqa: PLC0415

    root = Path(folder)
    found: list[str] = []
    # (folder, its parts below root, its real path, the real paths of the folders it lies in)
    todo: list[tuple[Path, tuple[str, ...], str, frozenset[str]]] = [(root, (), os.path.realpath(root), frozenset())]
    while todo:
        here, parts, real, above = todo.pop()
        try:
            with os.scandir(here) as listing:
                entries = sorted(listing, key=lambda e: e.name)
        except OSError as exc:
            raise InputError(f"{display_name(here)}: cannot list the folder ({exc.strerror or exc})") from None
        if parts and any(e.name == MARKER for e in entries):
            continue  # a report of depixel diff
        for entry in entries:
            if entry.name.startswith("."):
                continue
            if _is_dir(entry):
                # a real path costs a look at every level: only a link's is asked for
                inner = os.path.realpath(entry.path) if entry.is_symlink() else os.path.join(real, entry.name)
                if inner not in above and inner != real:  # else a link back to a folder it lies in
                    todo.append((Path(entry.path), (*parts, entry.name), inner, above | {real}))
            elif os.path.splitext(entry.name)[1].lower() in EXTENSIONS:
                found.append("/".join((*parts, entry.name)))
    return sorted(found)


def _is_dir(entry: os.DirEntry) -> bool:
    try:
        return entry.is_dir()  # through a link
    except OSError:
        return False


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
