"""Converting many files, the first step: finding the inputs (files, folders, globs) and
naming their outputs, as :class:`depixel_cli.convert.batch.Job` values.

Its own module so that the rules for which files a folder or glob gives and where their
outputs go (``--out-dir``, ``-r``, existing outputs) read apart from running the jobs.
"""
from __future__ import annotations

import glob
import os
import string
from pathlib import Path

from depixel.errors import DepixelError, display_name
from depixel.files import stamp as stamps
from depixel.files.output import make_folders as make_folder_and_parents
from depixel.prepare.image import load_image

from ..options import error_message
from .batch import Job, Options, Outcome, chosen_frames, numbered
from .tags import file_part, played_tags, written_twice

#: File extensions taken from folders and globs (explicitly named files are always tried).
IMAGE_SUFFIXES = frozenset({".png", ".gif", ".bmp", ".webp", ".tga", ".tif", ".tiff", ".ppm", ".pgm",
                            ".pbm", ".pcx", ".ico", ".jpg", ".jpeg", ".qoi", ".aseprite", ".ase"})


def expand_inputs(args: list[str], recursive: bool, exclude: Path | None = None,
                  skip_outputs: bool = False) -> tuple[list[tuple[Path, Path]], list[tuple[str, str]]]:
    """Files to convert as (path, path relative to its folder or glob base), and the
    arguments that gave none as (argument, message).

    A folder contributes the images directly in it (all its subfolders with ``recursive``),
    a glob its matches; hidden files and anything under ``exclude`` (the output folder) are
    left out, and with ``skip_outputs`` (outputs beside their inputs) the PNGs depixel wrote
    (they carry its options stamp). A file named twice is converted once.
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
        if skip_outputs and path.suffix.lower() == ".png" and stamps.read(path) is not None:
            return False  # an output of an earlier run beside its input
        # the output folder, when it lies inside an input folder, is not an input
        return outputs is None or outputs == base_key or outputs not in key.parents

    for arg in args:
        path = Path(arg)
        if path.is_dir():
            key = path.resolve()
            files = sorted(f for f in _entries(path, recursive) if wanted(f, path, key))
            if not files:
                hint = "" if recursive else " (-r looks in subfolders)"
                problems.append((arg, f"{display_name(arg)}: no images in this folder{hint}"))
            for f in files:
                add(f, f.relative_to(path))
        elif glob.has_magic(arg) and not path.exists():
            base = _glob_base(arg)
            key = base.resolve()
            try:
                matches = sorted(Path(m) for m in glob.glob(arg, recursive=True))
            except RecursionError:  # glob's ** recurses once a level
                problems.append((arg, f"{display_name(arg)}: its folders are nested too deeply for a ** pattern; "
                                      "give the folder with -r instead"))
                continue
            files = [m for m in matches if wanted(m, base, key)]
            if not files:
                problems.append((arg, f"{display_name(arg)}: no image matches"))
            for f in files:
                add(f, f.relative_to(base))
        else:
            add(path, Path(path.name))
    return found, problems


def _entries(folder: Path, recursive: bool) -> list[Path]:
    """What ``folder.glob("**/*" if recursive else "*")`` gives (subfolders reached through
    a symbolic link are not entered), walked with a list of folders to visit rather than by
    recursion, so that a tree thousands of levels deep is no error."""
    found: list[Path] = []
    todo = [folder]
    while todo:
        here = todo.pop()
        try:
            with os.scandir(here) as listing:
                entries = list(listing)
        except OSError:  # as glob: a folder that cannot be listed gives nothing
            continue
        for entry in entries:
            path = here / entry.name
            found.append(path)
            try:
                if recursive and entry.is_dir(follow_symlinks=False):
                    todo.append(path)
            except OSError:
                pass
    return found


def _glob_base(pattern: str) -> Path:
    """The folder part of a glob before its first wildcard ("icons/**/*.png" → icons)."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts[:-1]:
        if glob.has_magic(part):
            break
        fixed.append(part)
    return Path(*fixed) if fixed else Path(".")


#: the fields of ``--name TEMPLATE`` (docs/cli.md)
NAME_FIELDS = ("stem", "suffix", "frame", "sprite", "tag")
DEFAULT_NAME = "{stem}"
#: the default name with ``--sheet`` or ``--sheet-json``: a file per sprite
SHEET_NAME = "{stem}-{sprite}"


def uses(name: str, field: str) -> bool:
    """Whether the template ``name`` places ``{field}``."""
    return any(found == field for _, found, _, _ in string.Formatter().parse(name))


def name_template(text: str) -> str:
    """``--name``: a template of the fields NAME_FIELDS, without a format spec or a folder;
    raises ValueError with what is wrong."""
    try:
        parts = list(string.Formatter().parse(text))
    except ValueError as exc:
        raise ValueError(f"{text!r}: {exc} (write {{{{ and }}}} for a brace)") from None
    for _, field, spec, conversion in parts:
        fields = ", ".join("{" + f + "}" for f in NAME_FIELDS)
        if field is not None and field not in NAME_FIELDS:
            raise ValueError(f"{text!r}: unknown field {{{field}}}; use {fields}")
        if field is not None and (spec or conversion):
            raise ValueError(f"{text!r}: the fields take no format ({{{field}}} as it is); use {fields}")
    sample = text.format(stem="a", suffix="png", frame="000", sprite="r0c0", tag="walk")
    if "/" in sample or "\\" in sample:
        raise ValueError(f"{text!r}: a name, not a folder (outputs go to --out-dir DIR or beside their input)")
    if not sample.strip(". "):
        raise ValueError(f"{text!r}: names nothing")
    return text


def output_targets(source: Path, folder: Path, options: Options, frames: list[int], name: str = DEFAULT_NAME,
                   parts: tuple[str, ...] = ()) -> tuple[tuple[int, str, Path, str | None], ...]:
    """(frame, format, path, part) of every output of ``source`` in ``folder``: ``name``
    filled in (``{stem}``, ``{suffix}`` the input's extension without the dot, ``{frame}``
    the frame number, 000, 001, …, ``{sprite}`` each of a sheet's sprites, ``{tag}`` each
    tag an animation plays, or ``--tag``'s: ``parts``) plus each format's extension. Several
    frames and no ``{frame}`` in the name: ``name-000.svg``, ``name-001.svg``, …
    (:func:`~depixel_cli.convert.batch.numbered`). A name that comes out empty for this input
    (``{suffix}`` of a file without extension) raises ValueError: a hidden ``.svg`` is never
    what was meant."""
    digits = max(3, len(str(max(frames))))
    field = "sprite" if options.convert.output.is_sheet else "tag"
    fixed = {"sprite": "", "tag": "" if options.tag is None else file_part(options.tag)}
    targets = []
    for fmt in options.formats:
        for part in parts or (None,):
            named = [(frame, name.format(stem=source.stem, suffix=source.suffix[1:], frame=f"{frame:0{digits}d}",
                                         **(fixed if part is None else fixed | {field: file_part(part)})))
                     for frame in frames]
            if not named[0][1].strip(". "):
                raise ValueError(f"{display_name(source)}: --name {name!r} names nothing for it (it has no "
                                 "extension); e.g. --name '{stem}-{suffix}'")
            if len(frames) > 1 and not uses(name, "frame"):
                paths = numbered(folder / f"{named[0][1]}.{fmt}", frames)
            else:
                paths = [folder / f"{stem}.{fmt}" for _, stem in named]
            targets += [(frame, fmt, path, part) for frame, path in zip(frames, paths)]
    return tuple(sorted(targets, key=lambda target: target[0]))  # frame by frame, formats as given


def plan(found: list[tuple[Path, Path]], out_dir: Path | None, options: Options,
         name: str = DEFAULT_NAME) -> tuple[list[Job], list[Outcome]]:
    """One job per input, its outputs under ``out_dir`` at the same relative place, or
    beside the input when ``out_dir`` is None, named by ``name`` (:func:`output_targets`).

    With ``frames="all"`` (or a tag) the frames of each input are counted here, so the names
    compared are the real ones (an animation gives ``name-000.svg``, … and a still image
    ``name.svg``); a sheet whose name places ``{sprite}`` is cut here, one output a sprite;
    with ``--animate``, an Aseprite file's tags are read here, one output a tag (``name``
    without ``{tag}``: ``name-{tag}``).
    Inputs whose outputs would be another input or another input's output fail here; the
    first input (in the order given) keeps the name.
    """
    inputs = {p.resolve() for p, _ in found}
    owner: dict[Path, Path] = {}
    jobs, failed = [], []
    for path, rel in found:
        folder = path.parent if out_dir is None else out_dir / rel.parent
        try:
            frames = chosen_frames(path, options, display_name(path))
            parts = sprite_names(path, options, frames[0]) if uses(name, "sprite") else \
                played_tags(path, options.tag, options.convert.output.animate, display_name(path))
        except DepixelError as exc:
            failed.append(Outcome(path, folder / f"{path.stem}.{options.formats[0]}", error=error_message(exc)))
            continue
        tags = bool(parts) and not options.convert.output.is_sheet
        try:
            targets = output_targets(path, folder, options, frames, name if not tags or uses(name, "tag") else
                                     f"{name}-{{tag}}", parts)
        except ValueError as exc:
            failed.append(Outcome(path, folder / f"{path.stem}.{options.formats[0]}", error=str(exc)))
            continue
        job = Job(path, targets[0][2], options, len(frames), targets)
        twice = written_twice(targets, "tags" if tags else "sprites")
        if twice is not None:
            failed.append(Outcome(path, job.output, error=f"{display_name(path)}: {twice}"))
            continue
        clash = next((target for _, _, target, _ in targets
                      if target.resolve() in inputs or target.resolve() in owner), None)
        if clash is not None:
            key = clash.resolve()
            reason = "would overwrite an input" if key in inputs else \
                f"is already the output of {display_name(owner[key])}"
            if key in inputs:
                hint = "; name the outputs otherwise with --name, e.g. --name '{stem}-depixel'"
            elif "{suffix}" not in name:
                hint = "; name the outputs apart with --name, e.g. --name '{stem}-{suffix}'"
            else:
                hint = ""
            failed.append(Outcome(path, job.output, error=f"{display_name(path)}: output {display_name(clash)} "
                                                         f"{reason}{hint}"))
            continue
        owner.update((target.resolve(), path) for _, _, target, _ in targets)
        jobs.append(job)
    return jobs, failed


def sprite_names(path: Path, options: Options, frame: int) -> tuple[str, ...]:
    """The names of the sprites of the sheet ``path`` (its frame ``frame``), as the options cut it."""
    limits, name = options.convert.limits, display_name(path)
    rgba = load_image(path, limits.max_pixels, frame, max_frames=limits.max_frames, name=name)
    from depixel.prepare.sheet import sheet_of  # noqa: PLC0415 (only for a sheet)

    output = options.convert.output
    return tuple(sprite.name for sprite in sheet_of(rgba, output.sheet, output.sheet_json, name).sprites)


def make_folders(jobs: list[Job]) -> tuple[list[Job], list[Outcome]]:
    """Create the output folders; jobs whose folder cannot be made fail."""
    ready, failed = [], []
    for job in jobs:
        try:
            make_folder_and_parents(job.output.parent)
            ready.append(job)
        except DepixelError as exc:
            failed.append(Outcome(job.source, job.output, error=error_message(exc)))
    return ready, failed

