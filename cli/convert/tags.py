"""``depixel convert --animate`` on Aseprite files with tags: which tags an input's animated
outputs play, and their names (docs/animation.md, "Aseprite tags").

With ``--tag NAME`` one output plays that tag; without it, an Aseprite file with tags gets
an animated output per tag, ``{stem}-{tag}.svg`` (``-o FILE``: ``FILE-{tag}.svg``); a file
without tags plays every frame, as any animation. The library plays a tag
(:meth:`depixel.prepare.animation.Animation.tagged`); an output's tag is its options' ``tag``,
so its stamp holds it (:func:`tagged`).
"""
from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from depixel.errors import InputError, display_name
from depixel.options import ConvertOptions
from depixel.prepare.image import ImageSource, read_source

#: (frame, format, path, part) of one planned output: ``part`` a sheet's sprite or an
#: animation's tag (batch.Job.targets)
Planned = tuple[int, str, Path, "str | None"]


def file_part(part: str) -> str:
    """A sprite's or a tag's name as part of a file name: a folder separator (TexturePacker's
    ``hero/walk_01``) becomes ``_``, as does a leading dot."""
    text = part.replace("/", "_").replace("\\", "_")
    return "_" + text[1:] if text.startswith(".") else text


def tagged(options: ConvertOptions, tag: str | None) -> ConvertOptions:
    """``options`` playing the tag ``tag`` (None: as they are): the options of one tag's output."""
    if tag is None or tag == options.output.tag:
        return options
    return replace(options, output=replace(options.output, tag=tag))


def played_tags(source: ImageSource, tag: str | None, animate: bool, name: str) -> tuple[str, ...]:
    """The tags an input's animated outputs play (``animate``), one output each: ``tag``
    (``--tag``), checked to be there; else every tag of an Aseprite file, in the file's order;
    none (one output of every frame) for a file without tags, or without ``animate``. Two tags
    of one name are one line: the outputs would be one file."""
    if not animate:
        return ()
    if isinstance(source, (str, os.PathLike)) and not os.path.isfile(source):
        return () if tag is None else (tag,)  # a pipe is read once, by the conversion (which checks the tag)
    tags = _aseprite_tags(source, name)
    if tags is None:
        if tag is None:
            return ()
        raise InputError(f"{name}: not an Aseprite file, so it has no tags for --tag", parameter="tag")
    names = [item.name for item in tags]
    if tag is not None:
        from depixel.prepare.aseprite import find_tag  # noqa: PLC0415

        find_tag(tags, tag, name=name)  # an unknown tag: one line naming those there are
        return (tag,)
    twice = next((item for n, item in enumerate(names) if item in names[:n]), None)
    if twice is not None:
        raise InputError(f"{name}: has two tags named {twice!r}, whose animations would be one file; rename one "
                         f"(--tag {twice} plays the first)")
    return tuple(names)


def output_tags(source: ImageSource, output: Path, tag: str | None, fmt: str, animate: bool,
                name: str) -> tuple[Planned, ...]:
    """``-o FILE --animate``: (0, format, path, tag) of each tag's output (:func:`played_tags`),
    FILE itself for ``--tag``'s, ``FILE-{tag}.svg`` for each tag of a file without it; none
    for a file without tags (FILE plays every frame)."""
    tags = played_tags(source, tag, animate, name)
    if tag is not None:
        return tuple((0, fmt, output, tag) for tag in tags)
    targets = tuple((0, fmt, output.with_name(f"{output.stem}-{file_part(tag)}{output.suffix}"), tag) for tag in tags)
    twice = written_twice(targets, "tags")
    if twice is not None:
        raise InputError(f"{name}: {twice}")
    return targets


def written_twice(targets: tuple[Planned, ...], kind: str = "sprites") -> str | None:
    """Why two outputs of one input would be one file (two sprites or tags, ``kind``, whose
    names differ only in a folder separator), or None."""
    seen: dict[Path, str | None] = {}
    for _, _, path, part in targets:
        if path in seen:
            return (f"{kind} {seen[path]!r} and {part!r} would both be written to {display_name(path)}; "
                    + ("name them apart with --name" if kind == "sprites" else "play one with --tag NAME"))
        seen[path] = part
    return None


def _aseprite_tags(source: ImageSource, name: str):
    """The tags of ``source`` if it is an Aseprite file (its chunks walked, no pixel decoded),
    else None; a file on disk is read whole only when its header says Aseprite."""
    if isinstance(source, (str, os.PathLike)):
        try:
            with open(source, "rb") as file:
                head = file.read(6)
        except OSError:
            head = b"\0\0\0\0\xe0\xa5"  # read_source says why
        if head[4:6] != b"\xe0\xa5":
            return None
    data = read_source(source)
    from depixel.prepare.aseprite import is_aseprite, parse_aseprite  # noqa: PLC0415 (~15 ms: for Aseprite files)

    return parse_aseprite(data, name, None).tags if is_aseprite(data) else None
