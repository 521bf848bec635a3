"""Approving a change: ``depixel diff BASELINE CURRENT --update``.

The current file of every pair that is not the same is copied over the baseline:
``different`` ones replace theirs (when the pair matched names up to the extension, the
baseline file is replaced by one of the current's name), ``new`` ones are added at their
relative path, ``missing`` ones are removed only with ``prune``. Pairs that could not be
compared (``error``) are left as they are. Each file is written atomically, so the next
comparison finds the updated pairs identical.
"""
from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from ..errors import OutputError, display_name
from ..files.output import write_atomic
from ..prepare.image import read_source
from .pairs import DIFFERENT, MISSING, NEW, SAME, PairResult

UPDATED, ADDED, REMOVED = "updated", "added", "removed"


def update_baseline(results: list[PairResult], baseline: str | os.PathLike, current: str | os.PathLike,
                    prune: bool = False) -> tuple[list[tuple[str, str]], list[PairResult]]:
    """Copy the current files over the baseline; returns what changed, as (action, name),
    and the results as they stand after the update (updated pairs are now the same)."""
    changed: list[tuple[str, str]] = []
    after: list[PairResult] = []
    for result in results:
        if result.verdict in (DIFFERENT, NEW) and result.current is not None:
            target = Path(baseline, result.current)
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OutputError(f"{display_name(target)}: cannot write ({exc.strerror or exc})") from None
            write_atomic(target, read_source(Path(current, result.current)), protect=(Path(current, result.current),))
            if result.baseline is not None and result.baseline != result.current:
                _remove(Path(baseline, result.baseline))
            changed.append((UPDATED if result.verdict == DIFFERENT else ADDED, result.current))
            after.append(replace(result, verdict=SAME, baseline=result.current, identical=True, different_pixels=0,
                                 antialiased_pixels=0, ratio=0.0))
        elif result.verdict == MISSING and prune and result.baseline is not None:
            _remove(Path(baseline, result.baseline))
            changed.append((REMOVED, result.baseline))
        else:
            after.append(result)
    return changed, after


def _remove(path: Path) -> None:
    try:
        path.unlink()
    except FileNotFoundError:
        pass
    except OSError as exc:
        raise OutputError(f"{display_name(path)}: cannot remove ({exc.strerror or exc})") from None
