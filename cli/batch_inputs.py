"""Converting many files, the first step: finding the inputs (files, folders, globs) and
naming their outputs, as :class:`depixel_cli.batch.Job` values.

Its own module so that the rules for which files a folder or glob gives and where their
outputs go (``--out-dir``, ``-r``, existing outputs) read apart from running the jobs.
"""
from __future__ import annotations

import glob
from pathlib import Path

from depixel.errors import DepixelError, display_name
from depixel.prepare.image import frame_count

from .batch import Job, Options, Outcome, frame_targets
from .options import error_message

#: File extensions taken from folders and globs (explicitly named files are always tried).
IMAGE_SUFFIXES = frozenset({".png", ".gif", ".bmp", ".webp", ".tga", ".tif", ".tiff", ".ppm", ".pgm",
                            ".pbm", ".pcx", ".ico", ".jpg", ".jpeg", ".qoi"})



def expand_inputs(args: list[str], recursive: bool,
                  exclude: Path | None = None) -> tuple[list[tuple[Path, Path]], list[tuple[str, str]]]:
    """Files to convert as (path, path relative to its folder or glob base), and the
    arguments that gave none as (argument, message).

    A folder contributes the images directly in it (all its subfolders with ``recursive``),
    a glob its matches; hidden files and anything under ``exclude`` (the output folder) are
    left out. A file named twice is converted once.
    """
    found: list[tuple[Path, Path]] = []
    problems: list[tuple[str, str]] = []
    seen: set[Path] = set()
    outputs = None if exclude is None else exclude.resolve()
    resolved: dict[Path, Path] = {}  # each file is resolved once (a system call per part of its path)

    def add(path: Path, rel: Path) -> None:
        key = resolved.get(path) or path.resolve()
        if key not in seen:
            seen.add(key)
            found.append((path, rel))

    def wanted(path: Path, base: Path, base_key: Path) -> bool:
        if path.suffix.lower() not in IMAGE_SUFFIXES or any(part.startswith(".") for part in
                                                            path.relative_to(base).parts) or not path.is_file():
            return False
        key = resolved[path] = path.resolve()
        # the output folder, when it lies inside an input folder, is not an input
        return outputs is None or outputs == base_key or outputs not in key.parents

    for arg in args:
        path = Path(arg)
        if path.is_dir():
            key = path.resolve()
            files = sorted(f for f in path.glob("**/*" if recursive else "*") if wanted(f, path, key))
            if not files:
                hint = "" if recursive else " (-r looks in subfolders)"
                problems.append((arg, f"{display_name(arg)}: no images in this folder{hint}"))
            for f in files:
                add(f, f.relative_to(path))
        elif glob.has_magic(arg) and not path.exists():
            base = _glob_base(arg)
            key = base.resolve()
            matches = sorted(Path(m) for m in glob.glob(arg, recursive=True))
            files = [m for m in matches if wanted(m, base, key)]
            if not files:
                problems.append((arg, f"{display_name(arg)}: no image matches"))
            for f in files:
                add(f, f.relative_to(base))
        else:
            add(path, Path(path.name))
    return found, problems


def _glob_base(pattern: str) -> Path:
    """The folder part of a glob before its first wildcard ("icons/**/*.png" → icons)."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts[:-1]:
        if glob.has_magic(part):
            break
        fixed.append(part)
    return Path(*fixed) if fixed else Path(".")


def plan(found: list[tuple[Path, Path]], out_dir: Path, options: Options) -> tuple[list[Job], list[Outcome]]:
    """One job per input, its output under ``out_dir`` at the same relative place.

    With ``frames="all"`` the frames of each input are counted here, so the names compared
    are the real ones (an animation gives ``name-000.svg``, … and a still image
    ``name.svg``). Inputs whose outputs would be another input or another input's output
    fail here; the first input (in the order given) keeps the name.
    """
    inputs = {p.resolve() for p, _ in found}
    owner: dict[Path, Path] = {}
    jobs, failed = [], []
    for path, rel in found:
        output = out_dir / rel.with_suffix("." + options.fmt)
        n_frames = 1
        if options.frames == "all":
            try:
                n_frames = frame_count(path, options.max_frames)
            except DepixelError as exc:
                failed.append(Outcome(path, output, error=error_message(exc)))
                continue
        job = Job(path, output, options, n_frames)
        keys = [target.resolve() for _, target in frame_targets(job)]
        clash = next((k for k in keys if k in inputs or k in owner), None)
        if clash is not None:
            shown = display_name(out_dir / clash.relative_to(out_dir.resolve())) if clash.is_relative_to(
                out_dir.resolve()) else display_name(clash)
            reason = "would overwrite an input" if clash in inputs else \
                f"is already the output of {display_name(owner[clash])}"
            failed.append(Outcome(path, output, error=f"{display_name(path)}: output {shown} {reason}"))
            continue
        owner.update((k, path) for k in keys)
        jobs.append(job)
    return jobs, failed


def make_folders(jobs: list[Job]) -> tuple[list[Job], list[Outcome]]:
    """Create the output folders; jobs whose folder cannot be made fail."""
    ready, failed = [], []
    for job in jobs:
        try:
            job.output.parent.mkdir(parents=True, exist_ok=True)
            ready.append(job)
        except OSError as exc:
            failed.append(Outcome(job.source, job.output,
                                  error=f"{display_name(job.output.parent)}: cannot create folder "
                                        f"({exc.strerror or exc})"))
    return ready, failed

