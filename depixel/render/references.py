"""How many copies an SVG's ``<use>`` elements draw, counted before anything is drawn.

A ``<use>`` draws a copy of what it references, which may hold ``<use>`` elements itself:
eleven levels of ten uses each fit in 3 KB and draw 10**11 copies. cairosvg stops after
:data:`depixel.limits.MAX_SVG_REFERENCES` of them, but only once it has drawn them one by
one (15 s, each looking up its target in the whole document); :func:`check_references`
counts them from the tree first, each element once, and refuses the document at once.
"""
from __future__ import annotations

from typing import Any

from ..errors import RenderError
from ..limits import MAX_SVG_REFERENCES

#: Elements whose content is not drawn where it stands, only when something references it
#: (a ``<use>``, a ``url(#…)``); reached through a ``<use>``, they are drawn.
_NOT_DRAWN = frozenset({"defs", "symbol", "clipPath", "mask", "pattern", "marker", "linearGradient",
                        "radialGradient", "filter", "title", "desc", "metadata", "style", "script"})
_HREF = ("{http://www.w3.org/1999/xlink}href", "href")


def _local(tag: Any) -> str:
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def check_references(root: Any, name: str, limit: int = MAX_SVG_REFERENCES) -> None:
    """Refuse (:class:`RenderError`) an SVG (its ElementTree ``root``) whose ``<use>``
    elements would draw more than ``limit`` copies, counting the uses inside the copies, or
    that references itself (a ``<use>`` inside what it draws)."""
    if all(next(root.iter(tag), None) is None for tag in ("{http://www.w3.org/2000/svg}use", "use")):
        return  # (most documents, depixel's own included: a search in C, no count)
    if references(root, limit) > limit:
        raise RenderError(f"{name}: its <use> elements draw over {limit} copies (references of references, "
                          "or one that contains itself); refusing to render it")


def references(root: Any, limit: int) -> int:
    """The ``<use>`` copies drawing ``root`` makes (a use inside a copy counts once per copy),
    up to ``limit`` + 1, which also stands for a cycle. Each (element, reached by a use or
    not) is counted once, in a loop rather than by recursion (a deep document is no error)."""
    by_id: dict[str, Any] = {}
    for element in root.iter():
        key = element.get("id")
        if key is not None:
            by_id.setdefault(key, element)

    def parts(element: Any, used: bool) -> list[tuple[Any, bool]]:
        tag = _local(element.tag)
        if tag == "use":
            href = next((element.get(h) for h in _HREF if element.get(h)), "")
            target = by_id.get(href[1:]) if href.startswith("#") else None
            return [] if target is None else [(target, True)]
        if tag in _NOT_DRAWN and not used:
            return []
        return [(child, False) for child in element]

    done: dict[tuple[int, bool], int] = {}
    open_: set[tuple[int, bool]] = set()  # being counted: reached again, a cycle
    stack: list[tuple[Any, bool, bool]] = [(root, False, False)]
    while stack:
        element, used, expanded = stack.pop()
        key = (id(element), used)
        if not expanded:
            if key in done:
                continue
            if key in open_:
                return limit + 1
            open_.add(key)
            stack.append((element, used, True))
            stack.extend((child, via, False) for child, via in parts(element, used))
            continue
        open_.discard(key)
        own = 1 if _local(element.tag) == "use" else 0
        done[key] = min(limit + 1, own + sum(done[id(child), via] for child, via in parts(element, used)))
    return done[id(root), False]
