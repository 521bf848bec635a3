"""``depixel convert --out-dir DIR --prune``: remove the outputs in DIR whose inputs are gone,
so that a build folder kept from run to run mirrors its inputs.

An output is removed only when everything says it is depixel's and nobody else's: a regular
file (never a symbolic link, nor anything reached through one: linked folders are not
entered) inside DIR, of one of the run's formats, whose stamp is intact (as depixel wrote
it), that this run does not make (no input of the run is named onto it). A file without a
stamp is not depixel's and is never looked at again; an edited one, or one whose stamp is
too old to tell, is kept and reported. Without ``-r`` only DIR itself and the folders the run
writes into are looked at (what the run's inputs can name); hidden files and folders never.
"""
from __future__ import annotations

import argparse
import os
import stat
import sys
from dataclasses import dataclass, field
from pathlib import Path

from depixel.errors import display_name
from depixel.files import stamp as stamps

from ..streams import print_stdout
from .batch import Job, Outcome

#: Why an output whose input is gone is kept, by its stamp.KEPT status (UNSTAMPED files are not listed).
KEPT_BECAUSE = {stamps.EDITED: "its input is gone, but it was edited since depixel wrote it; not removed",
                stamps.OLD: "its input is gone, but it was written by a depixel too old to tell whether it was "
                            "edited since; not removed"}


@dataclass
class Pruned:
    """What ``--prune`` did (in a dry run: would do)."""

    removed: list[Path] = field(default_factory=list)
    kept: list[tuple[Path, str]] = field(default_factory=list)  # (output, why it stays)
    errors: list[str] = field(default_factory=list)  # one line each: an output that could not be removed
    refused: str | None = None  # why nothing was pruned at all

    def lines(self, dry_run: bool) -> list[tuple[str, str]]:
        """(kind, line) for the report: removed (dry run: would remove), kept, error."""
        done = "would remove" if dry_run else "removed"
        return ([(done, f"{display_name(p)} (its input is gone)") for p in self.removed]
                + [("kept", f"{display_name(p)}: {why}") for p, why in self.kept]
                + [("error", line) for line in self.errors + ([self.refused] if self.refused else [])])

    def totals(self, dry_run: bool) -> list[str]:
        """The summary line's part: ``N removed`` (``N to remove``)."""
        return [f"{len(self.removed)} {'to remove' if dry_run else 'removed'}"]

    def failed(self) -> bool:
        """Whether pruning failed (exit 1): a file not removed, or nothing pruned at all."""
        return bool(self.errors or self.refused)


def with_pruned(report: dict, pruned: Pruned | None, dry_run: bool) -> dict:
    """The ``--json`` report of a batch with what ``--prune`` did: ``removed`` (the count),
    an entry in ``outputs`` for each file removed (``to-remove`` in a dry run) or kept, and
    its errors in ``failed``."""
    if pruned is None:
        return report
    status = "to-remove" if dry_run else "removed"
    return {**report, "removed": len(pruned.removed),
            "outputs": report["outputs"] + [{"output": str(p), "input": None, "status": status}
                                            for p in pruned.removed]
            + [{"output": str(p), "input": None, "status": "kept", "reason": why} for p, why in pruned.kept],
            "failed": report["failed"] + [{"input": None, "error": line} for kind, line in pruned.lines(dry_run)
                                          if kind == "error"]}


def prune_batch(args: argparse.Namespace, formats: tuple[str, ...], found: list[tuple[Path, Path]],
                problems: list[tuple[str, str]], jobs: list[Job], unnamed: list[Outcome]) -> Pruned | None:
    """``--prune`` for a batch of ``jobs`` (``unnamed``: the inputs whose outputs could not be
    named), before they run (it needs only their outputs' names), reported as it goes; None
    when not asked, or once interrupted. Nothing is removed when an input argument (``found``,
    ``problems``) gave no file: a mistyped folder would otherwise empty ``--out-dir``."""
    if not args.prune or args.signals.signum is not None:
        return None
    gone = [arg for arg, _ in problems] + [display_name(path) for path, _ in found if not os.path.lexists(path)]
    if gone:
        pruned = Pruned(refused=f"--prune: nothing removed, since {gone[0]} gave no input (a mistyped folder "
                                "would empty --out-dir)")
    else:
        pruned = prune(args.out_dir, [target for job in jobs for _, _, target, _ in job.targets],
                       [path for path, _ in found], [o.output.parent for o in unnamed if o.output is not None],
                       formats, args.recursive, args.dry_run)
    listing = args.dry_run and not args.json
    for kind, line in pruned.lines(args.dry_run):
        if kind == "error":
            print(f"depixel: error: {line}", file=sys.stderr)
        elif listing:
            print_stdout(f"{kind:<14} {line}")
        elif not args.quiet:
            print(f"depixel: {'note:' if kind == 'kept' else kind} {line}", file=sys.stderr)
    return pruned


def prune(out_dir: Path, made: list[Path], inputs: list[Path], fenced: list[Path], formats: tuple[str, ...],
          recursive: bool, dry_run: bool) -> Pruned:
    """Remove (``dry_run``: list) the outputs of ``formats`` in ``out_dir`` that are not in
    ``made`` (the run's outputs) nor ``inputs``, nor directly in a folder of ``fenced`` (where
    an input's outputs could not be named): the module's rules. Never raises: a file that
    cannot be removed is an error line."""
    done = Pruned()
    keep = {os.path.realpath(p) for p in made + inputs}
    left_alone = {os.path.realpath(p) for p in fenced}
    suffixes = {f".{fmt}" for fmt in formats}
    folders = None if recursive else {os.path.realpath(p.parent) for p in made} | {os.path.realpath(out_dir)}
    for path in _files(out_dir, recursive, folders):
        real = os.path.realpath(path)
        if path.suffix.lower() not in suffixes or real in keep or os.path.dirname(real) in left_alone:
            continue
        if stamps.read(path) is None:
            continue  # not depixel's
        now = stamps.replaceable(path)
        if now in KEPT_BECAUSE:
            done.kept.append((path, KEPT_BECAUSE[now]))
        elif now == stamps.STALE:
            if not dry_run:
                try:
                    os.unlink(path)
                except FileNotFoundError:
                    continue
                except OSError as exc:
                    done.errors.append(f"{display_name(path)}: its input is gone, but it cannot be removed "
                                       f"({exc.strerror or exc})")
                    continue
                _remove_empty_folders(path.parent, out_dir)
            done.removed.append(path)
    return done


def _files(out_dir: Path, recursive: bool, folders: set[str] | None) -> list[Path]:
    """The regular files of ``out_dir`` (its subfolders too when ``recursive``, else only
    those of ``folders``), sorted: no symbolic link followed or listed, nothing hidden; a
    list of folders to visit, not recursion, so any depth will do."""
    found: list[Path] = []
    visited = None if folders is None else folders | {str(parent) for f in folders for parent in Path(f).parents}
    todo = [out_dir]
    while todo:
        here = todo.pop()
        real = os.path.realpath(here)
        if visited is not None and real not in visited:  # leads to no folder the run writes into
            continue
        try:
            with os.scandir(here) as listing:
                entries = list(listing)
        except OSError:  # a folder that cannot be listed holds nothing to remove
            continue
        for entry in entries:
            if entry.name.startswith("."):
                continue
            try:
                mode = entry.stat(follow_symlinks=False).st_mode
            except OSError:
                continue
            if stat.S_ISDIR(mode):
                todo.append(here / entry.name)
            elif stat.S_ISREG(mode) and (folders is None or real in folders):
                found.append(here / entry.name)
    return sorted(found)


def _remove_empty_folders(folder: Path, out_dir: Path) -> None:
    """Remove ``folder`` and its parents up to ``out_dir`` (not included) while they are
    empty: a subfolder whose inputs are all gone goes too."""
    top = os.path.realpath(out_dir)
    while os.path.realpath(folder) != top and os.path.realpath(folder).startswith(top + os.sep):
        try:
            os.rmdir(folder)
        except OSError:  # not empty (or not ours to remove): stop there
            return
        folder = folder.parent
