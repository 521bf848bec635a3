"""Stage 7 — SVG export — the SVGs of an animation's frames → one animated SVG.

Each frame, converted alone, becomes a top-level layer ``<g inkscape:groupmode="layer"
inkscape:label="frame N (D ms)">``; every frame after the first has ``display="none"``, and
every frame switches its ``display`` with SMIL (``<animate attributeName="display"
calcMode="discrete">``, values and keyTimes over one cycle). Browsers play it; a renderer
without animation (cairosvg, resvg, rsvg, Inkscape) draws the starting state, the first
frame, exactly as the first frame's own SVG (docs/animation.md has the renderers).
``display``, not ``opacity`` or ``visibility``: all frames at opacity 0 draw nothing without
animation, and Inkscape 1.2 shows the *last* of several ``visibility="hidden"`` layers that
animate to visible.

Shapes shared across frames: the elements of a frame's SVG (a shape's ``<path>``, a region's or
smooth group's ``<g>``) that are the same text in several frames but for their ``id`` are
written once, in ``<defs>``, and each frame draws them with ``<use xlink:href>`` (Inkscape 1.2
ignores a plain ``href``). Consecutive elements that always come together (the same frames
have them, always one after the other) are one block: one ``<g>`` in ``<defs>``, one ``<use>``
a frame, so unchanged art costs a few dozen bytes a frame. The drawing order inside each
frame is its own SVG's, so the stacked layout and the smooth groups work as in the frame's
SVG. Ids get the prefix of the frame they come from (``f2-outline-181425``), so they stay
unique; the shared filters keep their ids. A smooth group's mask (what the shapes above it
hide, :mod:`depixel.svg.hiding`) is named by what it holds, the shapes its ``<use>`` draw
(known by their text, as shared shapes are), so frames whose groups are hidden alike share one
mask, and it points to wherever those shapes are written. With ``--swatches`` every frame's
swatches are written once (:class:`~depixel.svg.swatches.SharedSwatches`; the frames are
named from the colours of all, so their shapes stay the same text).
"""
from __future__ import annotations

import dataclasses
import re
from collections.abc import Collection, Iterator, Sequence

from .svgtext import number
from .swatches import SharedSwatches

XLINK_NS = "http://www.w3.org/1999/xlink"
_ID = re.compile(r' id="([^"]*)"')
_LABEL = re.compile(r' inkscape:label="([^"]*)"')
_MASK = re.compile(r'<mask id="([^"]*)"')
_HREF = re.compile(r'xlink:href="#([^"]*)"')


@dataclasses.dataclass(frozen=True)
class Node:
    """An element of a frame's SVG: a ``<path>`` line, or a ``<g>`` with its open line, its
    children and ``</g>``; ``text`` is the whole element."""

    text: str
    children: tuple[Node, ...] = ()

    @property
    def open(self) -> str:
        return self.text[: self.text.index("\n") + 1]


@dataclasses.dataclass(frozen=True)
class FrameSvg:
    """The parts of one frame's SVG as depixel's writer makes them (one element a line)."""

    head: str  # the <svg …> tag
    title: str  # "<title>…</title>\n" or ""
    defs: str  # what its <defs> holds (the smooth shading's filter), or ""
    nodes: tuple[Node, ...]  # the top-level elements in drawing order


def split_svg(svg: str) -> FrameSvg:
    """Cut an SVG of :func:`depixel.svg.writer.to_svg` (its size maybe rewritten by
    :func:`depixel.render.overlay.overlay_svg`) into its parts."""
    start = svg.find("<svg")
    end = svg.find(">", start) + 1
    close = svg.rfind("</svg>")
    if start < 0 or end <= 0 or close < end:
        raise ValueError("not an SVG of depixel's writer: no <svg> element")
    head, rest = svg[start:end], svg[end:close].lstrip("\n")
    title = defs = ""
    if rest.startswith("<title>"):
        cut = rest.index("</title>\n") + len("</title>\n")
        title, rest = rest[:cut], rest[cut:]
    if rest.startswith("<defs>\n"):
        cut = rest.index("</defs>\n")
        defs, rest = rest[len("<defs>\n") : cut], rest[cut + len("</defs>\n") :]
    root: list[Node] = []
    stack: list[tuple[list[str], list[Node]]] = []  # each open group: its text so far, its children
    for line in rest.splitlines(keepends=True):
        if line.startswith("<g ") and not line.rstrip().endswith("/>"):
            stack.append(([line], []))
            continue
        if line.startswith("</g>"):
            if not stack:
                raise ValueError("not an SVG of depixel's writer: unbalanced groups")
            texts, children = stack.pop()
            node = Node("".join(texts) + line, tuple(children))
        else:
            node = Node(line)
        if stack:
            stack[-1][0].append(node.text)
            stack[-1][1].append(node)
        else:
            root.append(node)
    if stack:
        raise ValueError("not an SVG of depixel's writer: unbalanced groups")
    return FrameSvg(head, title, defs, tuple(root))


def compose(svgs: Sequence[str], durations: Sequence[float], plays: int = 0) -> str:
    """One animated SVG of the frames' SVGs (module docstring): frame i shows for
    ``durations[i]`` milliseconds, the whole plays ``plays`` times (0: for ever) and a finite
    animation stays on its last frame. The SVGs must be of one size (the same ``<svg>`` tag)."""
    if not svgs or len(svgs) != len(durations):
        raise ValueError(f"{len(svgs)} frame SVGs for {len(durations)} durations")
    swatches = SharedSwatches()  # (--swatches: one set for every frame)
    svgs = [swatches.take(svg) for svg in svgs]
    masks: dict[str, str] = {}  # a mask's content, its shapes by token → its id
    tokens: dict[str, str] = {}  # a shape's key → the token masks draw it by
    frame_keys: list[dict[str, str]] = []  # per frame: a shape's id → its key
    frames = [_named_masks(split_svg(svg), masks, tokens, frame_keys) for svg in svgs]
    head = frames[0].head
    if any(svg_size(f.head) != svg_size(head) for f in frames):
        raise ValueError("the frames' SVGs differ in size")
    filters = _shared_defs([f.defs for f in frames])
    items, relabelled = frame_items([f.nodes for f in frames])
    defs = [*swatches.lines, *filters]
    bodies: list[list[str]] = [[] for _ in frames]
    written: dict[tuple[str, ...], tuple[str, str]] = {}  # a shared block → the id its uses point to, its label
    blocks = shared_blocks([[key for key, _ in frame] for frame in items], relabelled)
    for index, (frame, frame_blocks) in enumerate(zip(items, blocks)):
        for block in frame_blocks:
            texts = [_prefixed(frame[i][1], index) for i in block.items]
            if not block.shared:
                bodies[index] += texts
                continue
            label = _label(texts[0]) if len(texts) == 1 else ""
            if block.key not in written:
                if len(texts) == 1:  # an element: its own id
                    ident = _ID.search(texts[0]).group(1)  # type: ignore[union-attr]
                    defs.append(texts[0])
                else:
                    ident = f"shared-{len(written) + 1}"
                    defs.append(f'<g id="{ident}">\n{"".join(texts)}</g>\n')
                written[block.key] = ident, label
            ident, first_label = written[block.key]
            # a shape that is the same but named otherwise here (a band there, an outline here)
            own = f' inkscape:label="{label}"' if label != first_label else ""
            bodies[index].append(f'<use xlink:href="#{ident}"{own}/>\n')
    switches = display_animations([float(d) for d in durations], plays)
    if "xmlns:xlink=" not in head:  # (a frame whose smooth groups are masked declares it already)
        head = head.replace("<svg", f'<svg xmlns:xlink="{XLINK_NS}"', 1)
    parts = ['<?xml version="1.0" encoding="UTF-8"?>\n', head,
             "\n", frames[0].title]
    if masks:  # each mask once, drawing its shapes where they are written (the defs first)
        written_as: dict[str, str] = {}  # a shape's token → an id it is written under
        for text in [*defs, *(line for body in bodies for line in body)]:
            for found in re.finditer(r' id="f(\d+)-([^"]*)"', text):
                token = tokens.get(frame_keys[int(found.group(1)) - 1].get(found.group(2), ""))
                if token is not None:  # (a shape some mask draws)
                    written_as.setdefault(token, f"f{found.group(1)}-{found.group(2)}")
        at = len(swatches.lines) + len(filters)
        defs[at:at] = [
            _HREF.sub(lambda m: f'xlink:href="#{written_as.get(m.group(1), m.group(1))}"',
                      content.replace("<mask ", f'<mask id="{ident}" ', 1)) for content, ident in masks.items()]
    if defs:
        parts += ["<defs>\n", *defs, "</defs>\n"]
    for index, body in enumerate(bodies):
        hidden = ' display="none"' if index else ""
        label = f"frame {index + 1} ({number(float(durations[index]), 3)} ms)"
        parts += [f'<g id="frame-{index + 1}" inkscape:groupmode="layer" inkscape:label="{label}"{hidden}>\n',
                  switches[index], *body, "</g>\n"]
    parts.append("</svg>\n")
    return "".join(parts)


def svg_size(head: str) -> str:
    """An ``<svg>`` tag without its namespace declarations: its size and viewBox (a frame whose
    smooth groups are masked declares xlink, another does not)."""
    return re.sub(r' xmlns(?::\w+)?="[^"]*"', "", head)


def _shared_defs(frames: Sequence[str]) -> list[str]:
    """The ``<defs>`` lines of every frame (filters: the smooth shading's, the masks' cover),
    each once, in the order they first come; one id for two different lines is refused."""
    lines: dict[str, None] = {}
    for defs in frames:
        lines.update(dict.fromkeys(defs.splitlines(keepends=True)))
    ids = [found.group(1) for line in lines if (found := _ID.search(line))]
    if len(ids) != len(set(ids)):
        raise ValueError("the frames' SVGs have different filters")
    return list(lines)


def _named_masks(frame: FrameSvg, masks: dict[str, str], tokens: dict[str, str],
                 frame_keys: list[dict[str, str]]) -> FrameSvg:
    """``frame`` with its masks taken out of its ``<defs>`` into ``masks`` (their text with
    each ``<use>`` pointing to the token of the shape it draws, a shape's key known by one
    token in ``tokens``, and no id → the name every frame's groups use for that mask) and its
    groups pointing to those names; its shapes' keys by id appended to ``frame_keys``."""
    keys = _shape_keys(frame.nodes)
    frame_keys.append(keys)
    kept, renamed = [], {}
    for line in frame.defs.splitlines(keepends=True):
        if (mask := _MASK.match(line)) is None:
            kept.append(line)
            continue
        content = _HREF.sub(lambda m: m.group(0) if m.group(1) not in keys  # (the defs' white cover)
                            else f'xlink:href="#{tokens.setdefault(keys[m.group(1)], f"s{len(tokens)}")}"',
                            line.replace(f' id="{mask.group(1)}"', "", 1))
        renamed[mask.group(1)] = masks.setdefault(content, f"mask-{len(masks) + 1}")
    if not renamed:
        return frame
    pattern = re.compile(r'mask="url\(#([^)]*)\)"')
    text = "".join(node.text for node in frame.nodes)
    text = pattern.sub(lambda m: f'mask="url(#{renamed[m.group(1)]})"', text)
    nodes = split_svg(f"{frame.head}\n{text}</svg>\n").nodes
    return dataclasses.replace(frame, defs="".join(kept), nodes=nodes)


def _keyed(nodes: Sequence[Node]) -> Iterator[tuple[Node, str]]:
    """Every element of a frame (groups and their children, depth first) with its key: its
    text without ids (a shape's without its label too) and how many times that text came
    before it in the frame (:func:`frame_items`)."""
    seen: dict[str, int] = {}
    pending = list(reversed(nodes))
    while pending:
        node = pending.pop()
        text = _ID.sub("", node.text)
        if not node.children:
            text = _LABEL.sub("", text)
        seen[text] = seen.get(text, 0) + 1
        yield node, f"{seen[text]}\0{text}"
        pending += reversed(node.children)


def _shape_keys(nodes: Sequence[Node]) -> dict[str, str]:
    """The key of each shape (an element without children) of a frame, by its id."""
    return {found.group(1): key for node, key in _keyed(nodes)
            if not node.children and (found := _ID.search(node.text))}


def _prefixed(text: str, index: int) -> str:
    """``text`` with each id given the prefix of frame ``index`` (numbered from 1)."""
    return _ID.sub(lambda m: f' id="f{index + 1}-{m.group(1)}"', text)


def _label(text: str) -> str:
    """The ``inkscape:label`` of an element's first line ("" when it has none)."""
    found = _LABEL.search(text[: text.find("\n") + 1 or len(text)])
    return found.group(1) if found else ""


def frame_items(frames: Sequence[Sequence[Node]]) -> tuple[list[list[tuple[str, str]]], set[str]]:
    """Each frame's elements as ``(key, text)`` items in drawing order, for
    :func:`shared_blocks`, and the keys of the shapes whose label differs between frames. An
    element is known by its text without ids (a shape's without its label too: the same
    shape can be a band of a smooth group in one frame and an outline in the next) and by
    how many times that text came before it in its frame (its key). An element that other
    frames have is one item; a group that no other frame has is its open line, its children's
    items and its ``</g>`` (so the shapes inside a changed group can still be shared)."""
    keys: list[dict[int, str]] = []  # per frame: id(node) → key
    users: dict[str, set[int]] = {}
    labels: dict[str, set[str]] = {}
    for index, nodes in enumerate(frames):
        frame_keys: dict[int, str] = {}
        for node, key in _keyed(nodes):
            if not node.children:
                labels.setdefault(key.partition("\0")[2], set()).add(_label(node.text))
            frame_keys[id(node)] = key
            users.setdefault(key, set()).add(index)
        keys.append(frame_keys)

    def flat(node: Node, index: int) -> list[tuple[str, str]]:
        key = keys[index][id(node)]
        if len(users[key]) > 1 or not node.children:
            return [(key, node.text)]
        out = [(f"{index}\0open\0{key}", node.open)]
        for child in node.children:
            out += flat(child, index)
        return out + [(f"{index}\0close\0{key}", "</g>\n")]

    relabelled = {key for key in users if len(labels.get(key.partition("\0")[2], ())) > 1}
    return [[item for node in nodes for item in flat(node, index)] for index, nodes in enumerate(frames)], relabelled


@dataclasses.dataclass(frozen=True)
class Block:
    """Consecutive items of a frame drawn as one: their places in the frame, the key they
    share with the same block in other frames, and whether other frames have it."""

    items: range
    key: tuple[str, ...]
    shared: bool


def shared_blocks(frames: Sequence[Sequence[str]], alone: Collection[str] = ()) -> list[list[Block]]:
    """Each frame's items (given by their keys, unique within a frame) cut into blocks: an
    item joins the block of the one before it when every frame that has the one has the
    other right after it, and no other frame has either; the items ``alone`` are blocks of
    their own (their ``<use>`` carries their label)."""
    users: dict[str, list[int]] = {}
    after: dict[str, str | None] = {}  # the item always next; None when that varies or none follows
    for index, keys in enumerate(frames):
        for place, key in enumerate(keys):
            users.setdefault(key, []).append(index)
            following = keys[place + 1] if place + 1 < len(keys) else None
            after[key] = following if after.get(key, following) == following else None
    out: list[list[Block]] = []
    for keys in frames:
        starts = [place for place, key in enumerate(keys)
                  if not place or after[keys[place - 1]] != key or users[keys[place - 1]] != users[key]
                  or key in alone or keys[place - 1] in alone]
        bounds = [*starts, len(keys)]
        out.append([Block(range(a, b), tuple(keys[a:b]), len(users[keys[a]]) > 1)
                    for a, b in zip(bounds[:-1], bounds[1:])])
    return out


def display_animations(durations: Sequence[float], plays: int) -> list[str]:
    """The ``<animate>`` of each frame's ``display`` (nothing for a single frame): shown from
    the start of its time in the cycle to the start of the next frame's; repeated ``plays``
    times (0: for ever), then frozen on the last frame."""
    if len(durations) < 2:
        return [""] * len(durations)
    total = float(sum(durations))
    starts = [float(sum(durations[:i])) for i in range(1, len(durations))]
    times = key_times([s / total for s in starts])
    repeat = 'repeatCount="indefinite"' if plays == 0 else f'repeatCount="{plays}" fill="freeze"'
    timing = f'dur="{number(total, 3)}ms" {repeat}'
    out = []
    last = len(durations) - 1
    for i in range(len(durations)):
        if i == 0:
            values, at = "inline;none", ["0", times[0]]
        elif i == last:
            values, at = "none;inline", ["0", times[i - 1]]
        else:
            values, at = "none;inline;none", ["0", times[i - 1], times[i]]
        out.append(f'<animate attributeName="display" calcMode="discrete" values="{values}" '
                   f'keyTimes="{";".join(at)}" {timing}/>\n')
    return out


def key_times(fractions: Sequence[float]) -> list[str]:
    """The frames' starts as fractions of the cycle, written with the fewest decimals (4 at
    least) that keep them strictly increasing between 0 and 1."""
    for decimals in range(4, 17):
        texts = [number(f, decimals) for f in fractions]
        values = [0.0, *(float(t) for t in texts), 1.0]
        if all(a < b for a, b in zip(values[:-1], values[1:])):
            return texts
    raise ValueError("frame durations too unequal to write as key times")
