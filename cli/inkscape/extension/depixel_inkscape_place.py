"""Part of depixel's Inkscape extension (:mod:`depixel_inkscape`, the script Inkscape runs):
putting depixel's drawing where the bitmap was — the ``<g>`` that maps the SVG's viewBox
onto the image's box, ``preserveAspectRatio`` and transform, the ids made unique in the
document, and the SVG length and transform arithmetic this takes.

Its own file, installed beside the script by ``depixel inkscape install`` (the ``.inx``
declares it as a dependency), because the script would otherwise pass 400 lines; the
script imports it from its own folder, which Python puts first on ``sys.path``. Like the
script it never imports depixel and runs on Python 3.7+ with inkex 1.0 to 1.4.
"""
from __future__ import annotations

import re

import inkex
from lxml import etree

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
INKSCAPE_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
GROUPMODE = "{http://www.inkscape.org/namespaces/inkscape}groupmode"

#: Elements of depixel's SVG that are not drawing (document data).
NOT_DRAWING = {"title", "desc", "metadata"}
#: Properties that depend on the user space they are used in: an image carrying one keeps
#: its own transform on an outer group and the viewBox mapping goes on an inner group.
SPACE_DEPENDENT = ("clip-path", "mask", "filter")
#: CSS absolute units in user units (px).
UNITS = {"": 1.0, "px": 1.0, "pt": 96 / 72, "pc": 16.0, "mm": 96 / 25.4, "cm": 96 / 2.54, "in": 96.0}


def local_name(element) -> str:
    tag = element.tag
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def describe(image) -> str:
    return f"image '{image.get('id') or image.get(INKSCAPE_LABEL) or '?'}'"


# --- putting the drawing in place -----------------------------------------------------------------

def replace_image(image, drawing, used_ids: set, keep_bitmap: bool) -> None:
    """Put ``drawing`` (depixel's SVG root) where ``image`` is drawn, in its parent."""
    elements = [e for e in drawing if local_name(e) and e.tag.startswith(f"{{{SVG_NS}}}")
                and local_name(e) not in NOT_DRAWING]
    import_ids(elements, used_ids)
    size = intrinsic_size(drawing)
    box = image_box(image, size)
    mapping = viewport(svg_viewbox(drawing), (0.0, 0.0) + size, drawing.get("preserveAspectRatio"))
    placed = viewport((0.0, 0.0) + size, box, image.get("preserveAspectRatio"))
    inner = compose(placed, mapping)
    aspect = (image.get("preserveAspectRatio") or "").split()
    sliced = aspect[-1:] == ["slice"] and "none" not in aspect
    own = _image_style(image)
    space_dependent = any(image.get(p) for p in SPACE_DEPENDENT) or any(k in SPACE_DEPENDENT for k, _ in own)

    outer = image.makeelement(f"{{{SVG_NS}}}g")
    if keep_bitmap:
        outer.set("id", unique_id((image.get("id") or "image") + "-depixel", used_ids))
    elif image.get("id"):
        outer.set("id", image.get("id"))  # clones and links to the bitmap now show the shapes
    outer.set(INKSCAPE_LABEL, f"{image.get(INKSCAPE_LABEL) or image.get('id') or 'bitmap'} (depixel)")
    parent = image.getparent()
    if any(e.get(GROUPMODE) == "layer" for e in elements) and \
            (parent.getparent() is None or parent.get(GROUPMODE) == "layer"):
        outer.set(GROUPMODE, "layer")  # an animation's frames are layers: so is what holds them, as Inkscape lists
    for name in ("class", "opacity", "visibility", "display") + SPACE_DEPENDENT:
        if image.get(name) is not None:
            outer.set(name, image.get(name))
    if own:
        outer.set("style", _style_text(own))

    own_transform = inkex.Transform(image.get("transform") or "").matrix
    if space_dependent:  # outer keeps the image's own space, inner maps the drawing into it
        set_transform(outer, own_transform)
        group = outer.makeelement(f"{{{SVG_NS}}}g")
        set_transform(group, inner)
        outer.append(group)
    else:
        set_transform(outer, compose(own_transform, inner))
        group = outer
    if sliced:  # the bitmap is cut to its box: so are the shapes
        group.set("clip-path", f"url(#{_clip_box(box, inner, image, used_ids)})")
    for element in elements:
        group.append(element)

    outer.tail = image.tail  # the document's line breaks stay as they were
    if keep_bitmap:
        parent.insert(parent.index(image) + 1, outer)
        style = [(k, v) for k, v in _style_items(image.get("style")) if k != "display"]
        image.set("style", _style_text(style + [("display", "none")]))
    else:
        parent.replace(image, outer)


def _style_items(style) -> list:
    items = []
    for declaration in (style or "").split(";"):
        key, colon, value = declaration.partition(":")
        if colon and key.strip():
            items.append((key.strip(), value.strip()))
    return items


def _style_text(items: list) -> str:
    return ";".join(f"{key}:{value}" for key, value in items)


def _image_style(image) -> list:
    """The image's style without what only applies to bitmaps."""
    return [(k, v) for k, v in _style_items(image.get("style")) if k not in ("image-rendering",)]


def _clip_box(box: tuple, inner: tuple, image, used_ids: set) -> str:
    """A <clipPath> of the image's box in the drawing's coordinates; returns its id."""
    x, y, w, h = box
    sx, sy, tx, ty = inner[0][0], inner[1][1], inner[0][2], inner[1][2]
    root = image.getroottree().getroot()
    defs = root.find(f"{{{SVG_NS}}}defs")
    if defs is None:
        defs = root.makeelement(f"{{{SVG_NS}}}defs")
        root.insert(0, defs)
    clip = defs.makeelement(f"{{{SVG_NS}}}clipPath")
    clip.set("id", unique_id("depixel-clip", used_ids))
    clip.set("clipPathUnits", "userSpaceOnUse")
    rect = clip.makeelement(f"{{{SVG_NS}}}rect")
    for name, value in (("x", (x - tx) / sx), ("y", (y - ty) / sy), ("width", w / sx), ("height", h / sy)):
        rect.set(name, number(value))
    clip.append(rect)
    defs.append(clip)
    return clip.get("id")


# --- ids ------------------------------------------------------------------------------------------

URL_REFERENCE = re.compile(r"""url\(\s*(['"]?)#([^'")\s]+)\1\s*\)""")


def unique_id(wanted: str, used_ids: set) -> str:
    """``wanted``, or ``wanted-2``, ``wanted-3``, ... the first not in ``used_ids`` (then used)."""
    candidate, n = wanted, 1
    while candidate in used_ids:
        n += 1
        candidate = f"{wanted}-{n}"
    used_ids.add(candidate)
    return candidate


def import_ids(elements: list, used_ids: set) -> None:
    """Give every imported id that the document already uses a free one, and follow the
    renames in the imported references (``url(#id)``, ``href="#id"``)."""
    renamed = {}
    for top in elements:
        for element in top.iter():
            old = element.get("id")
            if old is not None:
                new = unique_id(old, used_ids)
                if new != old:
                    renamed[old] = new
                    element.set("id", new)
    if not renamed:
        return
    for top in elements:
        for element in top.iter():
            for name, value in element.attrib.items():
                if name in (XLINK_HREF, "href") and value.startswith("#") and value[1:] in renamed:
                    element.set(name, "#" + renamed[value[1:]])
                elif "url(" in value:
                    element.set(name, URL_REFERENCE.sub(
                        lambda m: f"url({m.group(1)}#{renamed.get(m.group(2), m.group(2))}{m.group(1)})", value))


# --- geometry -------------------------------------------------------------------------------------

def length(text, name: str) -> float:
    """An SVG length in user units (absolute CSS units only)."""
    match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-z]*)\s*", text or "")
    if not match or match.group(2) not in UNITS:
        raise inkex.AbortExtension(f"Depixelize: cannot use the {name} {text!r}: give it in px, mm, pt, ...")
    return float(match.group(1)) * UNITS[match.group(2)]


def svg_viewbox(root) -> tuple:
    numbers = re.split(r"[\s,]+", (root.get("viewBox") or "").strip())
    if len(numbers) == 4:
        return tuple(float(n) for n in numbers)
    return (0.0, 0.0) + intrinsic_size(root, use_viewbox=False)


def intrinsic_size(root, use_viewbox: bool = True) -> tuple:
    """The width and height of depixel's SVG: the bitmap's size in pixels."""
    if root.get("width") and root.get("height"):
        return length(root.get("width"), "SVG width"), length(root.get("height"), "SVG height")
    if use_viewbox:
        return svg_viewbox(root)[2:]
    raise inkex.AbortExtension("Depixelize: depixel's SVG has neither width/height nor viewBox.")


def image_box(image, size: tuple) -> tuple:
    """x, y, width, height of the image in its user space; a missing width or height
    (SVG 2's auto) is the bitmap's own, ``size``."""
    x = length(image.get("x") or "0", "image x")
    y = length(image.get("y") or "0", "image y")
    w = length(image.get("width"), "image width") if image.get("width") else size[0]
    h = length(image.get("height"), "image height") if image.get("height") else size[1]
    if w <= 0 or h <= 0:
        raise inkex.AbortExtension(f"Depixelize: {describe(image)} has no area ({w} × {h}), nothing to convert.")
    return x, y, w, h


def viewport(source: tuple, target: tuple, aspect) -> tuple:
    """The matrix that fits the box ``source`` into ``target`` (x, y, w, h) the way SVG's
    ``preserveAspectRatio`` says (default ``xMidYMid meet``)."""
    sx0, sy0, sw, sh = source
    x, y, w, h = target
    words = (aspect or "xMidYMid meet").split()
    words = [word for word in words if word != "defer"] or ["xMidYMid"]
    align, mode = words[0], (words[1] if len(words) > 1 else "meet")
    scale_x, scale_y = w / sw, h / sh
    if align != "none":
        scale_x = scale_y = max(scale_x, scale_y) if mode == "slice" else min(scale_x, scale_y)
    tx, ty = x - sx0 * scale_x, y - sy0 * scale_y
    spare_x, spare_y = w - sw * scale_x, h - sh * scale_y
    tx += {"xMid": spare_x / 2, "xMax": spare_x}.get(align[:4], 0.0)
    ty += {"YMid": spare_y / 2, "YMax": spare_y}.get(align[4:], 0.0)
    return ((scale_x, 0.0, tx), (0.0, scale_y, ty))


def compose(first: tuple, second: tuple) -> tuple:
    """``first`` after ``second`` (the matrix product first · second), as inkex's 2×3 tuples."""
    (a, c, e), (b, d, f) = first
    (a2, c2, e2), (b2, d2, f2) = second
    return ((a * a2 + c * b2, a * c2 + c * d2, a * e2 + c * f2 + e),
            (b * a2 + d * b2, b * c2 + d * d2, b * e2 + d * f2 + f))


def number(value: float) -> str:
    text = f"{value:.10g}"
    return "0" if text == "-0" else text


def set_transform(element, matrix: tuple) -> None:
    """Write ``matrix`` as the element's transform: translate/scale when it is only
    those, nothing when it is the identity. Written through lxml, because inkex's
    ``set`` rounds transforms to 6 significant digits (0.02 px off at x = 12345)."""
    (a, c, e), (b, d, f) = matrix
    if (b, c) != (0.0, 0.0):
        text = f"matrix({','.join(number(v) for v in (a, b, c, d, e, f))})"
    else:
        parts = []
        if (e, f) != (0.0, 0.0):
            parts.append(f"translate({number(e)},{number(f)})")
        if (a, d) != (1.0, 1.0):
            parts.append(f"scale({number(a)},{number(d)})")
        text = " ".join(parts)
    if text:
        etree.ElementBase.set(element, "transform", text)

