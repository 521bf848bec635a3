"""Approving a change: ``depixel diff BASELINE CURRENT --update``.

The current file of every pair that is not the same is copied over the baseline:
``different`` ones replace theirs (when the pair matched names up to the extension, the
baseline file is replaced by one of the current's name), ``new`` ones are added at their
relative path, ``missing`` ones are removed only with ``prune``. Pairs that could not be
compared (``error``) are left as they are. Each file is written atomically, so the next
comparison finds the updated pairs identical.

Nothing is written or removed outside the baseline: every change is planned and checked
first, and a path that a symbolic link to a folder takes out of the baseline refuses the
whole update before anything is changed (:class:`UpdateRefused`). A baseline file that is
itself a symbolic link is replaced by the current file (the link, not what it points to:
baselines deduplicated by links stay apart), and a removed one is the link alone.

While it runs, the update keeps a record, :data:`RECORD` in the baseline, with a line per
change as soon as it is made; a complete update removes it. An update stopped half-way (a
file that cannot be written: :class:`UpdateStopped`; Ctrl-C) leaves it, so what was changed
is known; running the same update again completes it. The temporary files an update
killed outright (SIGKILL) left in the baseline are removed by the next.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import OutputError, display_name
from ..files.output import make_folders, remove_file, remove_stale_in, signals_deferred, write_atomic
from ..prepare.image import read_source
from .pairs import DIFFERENT, MISSING, NEW, SAME, PairResult

UPDATED, ADDED, REMOVED = "updated", "added", "removed"
#: The record an update keeps in the baseline while it runs (hidden: never compared).
RECORD = ".depixel-update.log"


class UpdateRefused(OutputError):
    """A change would write or remove outside the baseline: nothing was changed."""


class UpdateStopped(OutputError):
    """A change failed half-way through the update: those before it were made (``changed``)."""

    def __init__(self, message: str, changed: list[tuple[str, str]]) -> None:
        super().__init__(message)
        self.changed = changed


@dataclass(frozen=True)
class _Change:
    action: str  # UPDATED, ADDED or REMOVED
    name: str  # relative path, as reported
    write: Path | None  # the baseline file written from ``source``
    source: Path | None
    remove: Path | None  # the baseline file removed (a pair renamed by extension, or pruned)


def update_baseline(results: list[PairResult], baseline: str | os.PathLike, current: str | os.PathLike,
                    prune: bool = False,
                    changed: list[tuple[str, str]] | None = None) -> tuple[list[tuple[str, str]], list[PairResult]]:
    """Copy the current files over the baseline; returns what changed, as (action, name),
    and the results as they stand after the update (updated pairs are now the same).

    ``changed``, when given, is filled as the changes are made, so that a caller stopped by
    an interrupt knows what was done. Raises :class:`UpdateRefused` before any change,
    :class:`UpdateStopped` after some (module docstring)."""
    done: list[tuple[str, str]] = [] if changed is None else changed
    plan, after = _plan(results, Path(baseline), Path(current), prune)
    if not plan:
        return done, after
    record = Path(baseline, RECORD)
    for folder in {Path(baseline)} | {c.write.parent for c in plan if c.write is not None and c.write.parent.is_dir()}:
        remove_stale_in(folder)  # what an update killed here left
    try:
        write_atomic(record, f"depixel diff --update: {len(plan)} changes planned; each line below is one made\n")
        with open(record, "a", encoding="utf-8", errors="backslashreplace") as log:
            for change in plan:
                with signals_deferred():  # a Ctrl-C comes between two changes, each recorded
                    _apply(change)
                    done.append((change.action, change.name))
                    log.write(f"{change.action}: {change.name}\n")
                    log.flush()
    except OutputError as exc:
        listed = f" (listed in {display_name(record)})" if record.exists() else ""
        raise UpdateStopped(f"{exc}; --update stopped after {len(done)} of {len(plan)} changes{listed}",
                            list(done)) from None
    except OSError as exc:  # the record itself
        raise UpdateStopped(f"{display_name(record)}: cannot write ({exc.strerror or exc}); --update stopped "
                            f"after {len(done)} of {len(plan)} changes", list(done)) from None
    remove_file(record)
    return done, after


def _plan(results: list[PairResult], baseline: Path, current: Path,
          prune: bool) -> tuple[list[_Change], list[PairResult]]:
    """The changes to make, each checked to stay inside the baseline, and the results after."""
    plan: list[_Change] = []
    after: list[PairResult] = []
    inside = os.path.realpath(baseline)
    for result in results:
        if result.verdict in (DIFFERENT, NEW) and result.current is not None:
            old = None
            if result.baseline is not None and result.baseline != result.current:
                old = Path(baseline, result.baseline)
            plan.append(_Change(UPDATED if result.verdict == DIFFERENT else ADDED, result.current,
                                Path(baseline, result.current), Path(current, result.current), old))
            after.append(replace(result, verdict=SAME, baseline=result.current, identical=True, different_pixels=0,
                                 antialiased_pixels=0, ratio=0.0))
        elif result.verdict == MISSING and prune and result.baseline is not None:
            plan.append(_Change(REMOVED, result.baseline, None, None, Path(baseline, result.baseline)))
        else:
            after.append(result)
    for change in plan:
        for path in (change.write, change.remove):
            if path is not None and not _within(os.path.realpath(path.parent), inside):
                link = _link_on_the_way(path, baseline)
                raise UpdateRefused(
                    f"--update: {display_name(change.name)} is reached through the symbolic link "
                    f"{display_name(link)}, which leads out of the baseline {display_name(baseline)}: refusing to "
                    f"{'remove' if path == change.remove else 'write'} there; nothing was changed (make the "
                    "link a folder of the baseline, or approve without it)")
    return plan, after


def _apply(change: _Change) -> None:
    if change.write is not None and change.source is not None:
        make_folders(change.write.parent)
        write_atomic(change.write, read_source(change.source), protect=(change.source,), replace_link=True)
    if change.remove is not None:
        remove_file(change.remove)


def _within(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def _link_on_the_way(path: Path, baseline: Path) -> Path:
    """The first symbolic link between ``baseline`` and ``path``."""
    here = baseline
    for part in path.relative_to(baseline).parts:
        here = here / part
        if here.is_symlink():
            return here
    return path
