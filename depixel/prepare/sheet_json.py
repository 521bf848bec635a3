"""Stage 0 — input: the JSON that Aseprite or TexturePacker writes beside a sprite sheet →
its sprites (:class:`~depixel.prepare.sheet.Sheet`).

Both write ``"frames"`` as a hash (``{"name.png": {"frame": {"x", "y", "w", "h"}, …}}``) or
an array (``[{"filename": "name.png", "frame": {…}}, …]``); Aseprite adds each frame's
``"duration"`` (ms) and ``meta.frameTags`` and ``meta.slices``. A sprite is named after its
frame without the file extension, made unique with ``-2``, ``-3``… A trimmed frame keeps
where it sat in its untrimmed frame (``spriteSourceSize``, ``sourceSize``: ``Sprite.trim``);
a rotated frame is refused (turn rotation off in the packer). Every problem is one
:class:`InputError` line naming the file and the frame. :class:`SheetJson` is such a file
as the ``sheet_json`` option holds it: read once, checked, and digested by its content.
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import InputError, ParameterError, display_name
from .aseprite_format import Slice, SliceKey, Tag
from .image import read_source
from .sheet import Sheet, Sprite

#: Aseprite's JSON names of the tag directions → the Aseprite reader's
_DIRECTIONS = {"forward": "forward", "reverse": "reverse", "pingpong": "pingpong",
               "pingpong_reverse": "pingpong reverse"}


def parse_sheet_json(data: str | bytes | Mapping, size: tuple[int, int] | None = None, *,
                     name: str = "<json>") -> Sheet:
    """The sprites an Aseprite or TexturePacker JSON file (its text, or the decoded object)
    places on its sheet; ``size`` (width, height) is the sheet's, which every frame must fit."""
    if isinstance(data, Mapping):
        document = data
    else:
        try:
            document = json.loads(data)
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputError(f"{name}: not JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(document, Mapping) or not isinstance(document.get("frames"), (Mapping, list)):
        raise InputError(f"{name}: no \"frames\" hash or array: not an Aseprite or TexturePacker sheet")
    frames = document["frames"]
    entries = list(frames.items()) if isinstance(frames, Mapping) else \
        [(_field(entry, "filename", str, name, f"frame {i}"), entry) for i, entry in enumerate(frames)]
    sprites: list[Sprite] = []
    taken: set[str] = set()
    for label, entry in entries:
        sprites.append(_sprite(label, entry, size, name, taken))
    found = document.get("meta")
    meta: Mapping = found if isinstance(found, Mapping) else {}
    tags = tuple(_tag(tag, len(sprites), name) for tag in _list(meta, "frameTags", name))
    slices = tuple(_slice(item, name) for item in _list(meta, "slices", name))
    app = str(meta.get("app", ""))
    maker = "Aseprite" if "aseprite" in app.lower() else "TexturePacker" if "texturepacker" in app.lower() else "JSON"
    layout = "hash" if isinstance(frames, Mapping) else "array"
    text = f"{len(sprites)} sprite{'' if len(sprites) == 1 else 's'} from the {maker} {layout}"
    if tags:
        text += f", {len(tags)} tag{'' if len(tags) == 1 else 's'}"
    return Sheet(tuple(sprites), None, None, text, tags, slices)


@dataclass(frozen=True)
class SheetJson:
    """A sheet's JSON file as the ``sheet_json`` option holds it: its bytes, checked when
    made (a malformed file is one :class:`InputError` line at once), and the name messages
    give it. Two are equal when their bytes are; a file's stamp digests :attr:`digest` (what
    ``str()`` gives), so an edited JSON makes the outputs stale and a renamed one does not."""

    name: str = field(compare=False)
    data: bytes = field(repr=False)

    def __post_init__(self) -> None:
        parse_sheet_json(self.data, name=self.name)

    @property
    def digest(self) -> str:
        """The first 16 hex digits of the SHA-256 of the bytes."""
        import hashlib  # noqa: PLC0415 (~4 ms of OpenSSL: only when a sheet's JSON is given)

        return hashlib.sha256(self.data).hexdigest()[:16]

    def __str__(self) -> str:
        return f"sheet-json:{self.digest}"

    def sheet(self, size: tuple[int, int]) -> Sheet:
        """The sprites it places on a sheet of ``size`` (width, height), which they must fit."""
        return parse_sheet_json(self.data, size, name=self.name)


def sheet_json_of(value: SheetJson | str | os.PathLike | bytes | Mapping | None) -> SheetJson | None:
    """The ``sheet_json`` option normalized: a path is read (an :class:`InputError` naming
    it if it cannot be), bytes are the file's, a mapping is the decoded document."""
    if value is None or isinstance(value, SheetJson):
        return value
    if isinstance(value, (str, os.PathLike)):
        return SheetJson(display_name(value), read_source(value))
    if isinstance(value, (bytes, bytearray, memoryview)):
        return SheetJson("<json>", bytes(value))
    if isinstance(value, Mapping):
        return SheetJson("<json>", json.dumps(value, sort_keys=True).encode("utf-8"))
    raise ParameterError(f"sheet_json must be a path, the JSON's bytes or its decoded object, not "
                         f"{type(value).__name__}", parameter="sheet_json")


def _sprite(label: str, entry, size: tuple[int, int] | None, name: str, taken: set[str]) -> Sprite:
    where = f"frame {label!r}"
    if not isinstance(entry, Mapping):
        raise InputError(f"{name}: {where} is not an object")
    if entry.get("rotated"):
        raise InputError(f"{name}: {where} is rotated on the sheet; depixel reads unrotated frames "
                         "(turn rotation off in the packer)")
    x, y, w, h = _rect(entry.get("frame"), "xywh", name, where)
    if w < 1 or h < 1:
        raise InputError(f"{name}: {where} is empty ({w}x{h})")
    if size is not None and (x + w > size[0] or y + h > size[1]):
        raise InputError(f"{name}: {where} at {x},{y} {w}x{h} runs past the {size[0]}x{size[1]} sheet")
    trim = None
    if entry.get("trimmed"):
        sx, sy, _, _ = _rect(entry.get("spriteSourceSize"), "xywh", name, where)
        sw, sh = _rect(entry.get("sourceSize"), "wh", name, where)
        trim = (sx, sy, sw, sh)
    duration = entry.get("duration")
    if duration is not None and (not isinstance(duration, int) or isinstance(duration, bool) or duration < 0):
        raise InputError(f"{name}: {where} has a duration of {duration!r}, not a number of ms")
    stem = os.path.splitext(label)[0] or label or "sprite"
    unique, n = stem, 1
    while unique in taken:
        n += 1
        unique = f"{stem}-{n}"
    taken.add(unique)
    return Sprite(unique, x, y, w, h, duration, trim)


def _rect(value, keys: str, name: str, where: str) -> tuple[int, ...]:
    """The whole numbers ``keys`` of a JSON rectangle (``{"x", "y", "w", "h"}``)."""
    if not isinstance(value, Mapping):
        raise InputError(f"{name}: {where} has no {{{', '.join(keys)}}} rectangle")
    return tuple(_field(value, key, int, name, where) for key in keys)


def _field(value, key: str, kind: type, name: str, where: str) -> Any:
    """``value[key]``, a ``kind`` (an int ≥ 0, or a str), else an :class:`InputError`."""
    item: Any = value.get(key) if isinstance(value, Mapping) else None
    negative = isinstance(item, int) and item < 0
    if not isinstance(item, kind) or isinstance(item, bool) or negative:
        raise InputError(f"{name}: {where} has no {key!r} ({'a whole number ≥ 0' if kind is int else 'a text'})")
    return item


def _list(meta: Mapping, key: str, name: str) -> list:
    value = meta.get(key, [])
    if not isinstance(value, list):
        raise InputError(f"{name}: meta.{key} is not an array")
    return value


def _tag(tag, frames: int, name: str) -> Tag:
    label = _field(tag, "name", str, name, "a frame tag")
    where = f"tag {label!r}"
    first, last = _field(tag, "from", int, name, where), _field(tag, "to", int, name, where)
    if first > last or last >= frames:
        raise InputError(f"{name}: {where} runs from frame {first} to {last}, not within the {frames} frames")
    direction = tag.get("direction", "forward")
    if direction not in _DIRECTIONS:
        raise InputError(f"{name}: {where} has the direction {direction!r}, not one of {', '.join(_DIRECTIONS)}")
    repeat = tag.get("repeat", 0)
    return Tag(label, first, last, _DIRECTIONS[direction], int(repeat) if str(repeat).isdigit() else 0)


def _slice(item, name: str) -> Slice:
    label = _field(item, "name", str, name, "a slice")
    keys = []
    for key in item.get("keys", []) if isinstance(item.get("keys"), list) else []:
        x, y, w, h = _rect(key.get("bounds") if isinstance(key, Mapping) else None, "xywh", name, f"slice {label!r}")
        keys.append(SliceKey(_field(key, "frame", int, name, f"slice {label!r}"), x, y, w, h))
    return Slice(label, tuple(keys))
