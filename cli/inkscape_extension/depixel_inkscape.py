#!/usr/bin/env python3
"""Inkscape extension: replace the selected bitmaps by depixel's vector shapes.

Inkscape runs it as ``python3 depixel_inkscape.py [options] --id=ID ... DOCUMENT.svg`` and
reads the changed document from stdout. For each selected ``<image>`` (embedded ``data:``
URI or linked file; images inside selected groups count too) it runs the ``depixel``
program, ``depixel convert IMAGE -o OUT.svg``, takes the drawing elements of the SVG it
writes and puts them in a ``<g>`` that maps that SVG's viewBox onto the place of the
bitmap: its x/y/width/height, ``preserveAspectRatio`` and transform, inside the same parent.

It never imports depixel: Inkscape's Python is often not the one depixel is installed in,
so the program is looked for (dialog setting, ``$DEPIXEL``, the command recorded by
``depixel inkscape install``, ``PATH``). It reads nothing of depixel's SVG structure but
the root's size and viewBox, so it works with any version of depixel's SVG writer; every
id it imports is made unique in the document. Runs on Python 3.7+ with inkex 1.0 to 1.4.
"""
from __future__ import annotations

import base64
import json
import os
import re
import shutil
import subprocess
import tempfile
import urllib.parse
import urllib.request

import inkex
from lxml import etree

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
INKSCAPE_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
SODIPODI_ABSREF = "{http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd}absref"

#: The file ``depixel inkscape install`` writes beside this script: the command that runs
#: the depixel it was installed from (``{"command": [python, "-m", "depixel"]}``).
RECORDED_COMMAND = "depixel_inkscape.json"
#: Environment variable naming the depixel program, for setups the dialog cannot reach.
ENVIRONMENT_VARIABLE = "DEPIXEL"

#: Dialog option → ``depixel convert`` flag, with the CLI's default. A flag is passed only
#: when its value differs from the default, so the extension works with depixel versions
#: that predate some of the flags (an unknown flag is then reported with the dialog field).
FLAGS = (
    # (option, flag, CLI default, dialog field)
    ("stage", "--stage", "optimized", "Result"),
    ("layout", "--layout", "stacked", "Shapes"),
    ("simplify", "--simplify", 0.25, "Simplify"),
    ("pixel_size", "--pixel-size", "auto", "Pixel size"),
    ("transparent", "--transparent", "", "Backdrop"),
    ("seed", "--seed", 0, "Random seed"),
)

#: Elements of depixel's SVG that are not drawing (document data).
NOT_DRAWING = {"title", "desc", "metadata"}
#: Ancestors under which an image is not drawn where it stands (a selected group may hold one).
NOT_RENDERED = {"defs", "clipPath", "mask", "pattern", "symbol", "marker"}
#: Properties that depend on the user space they are used in: an image carrying one keeps
#: its own transform on an outer group and the viewBox mapping goes on an inner group.
SPACE_DEPENDENT = ("clip-path", "mask", "filter")
#: CSS absolute units in user units (px).
UNITS = {"": 1.0, "px": 1.0, "pt": 96 / 72, "pc": 16.0, "mm": 96 / 25.4, "cm": 96 / 2.54, "in": 96.0}
#: File suffix of the bitmap handed to depixel, by the media type of a data: URI.
SUFFIXES = {"image/png": ".png", "image/gif": ".gif", "image/jpeg": ".jpg", "image/bmp": ".bmp",
            "image/webp": ".webp", "image/tiff": ".tif", "image/x-icon": ".ico"}


class DepixelizeEffect(inkex.EffectExtension):
    """Extensions ▸ Raster ▸ Depixelize (depixel)."""

    def add_arguments(self, pars) -> None:
        pars.add_argument("--tab", default="options", help="dialog page (ignored)")
        pars.add_argument("--stage", default="optimized", choices=("cells", "splines", "optimized"))
        pars.add_argument("--layout", default="stacked", choices=("stacked", "cutout"))
        pars.add_argument("--simplify", type=float, default=0.25, help="tolerance in pixels, 0 = the exact spline")
        pars.add_argument("--pixel_size", default="auto", help="auto, 1 (as is), N or NxM")
        pars.add_argument("--backdrop", default="keep", choices=("keep", "auto", "colour"))
        pars.add_argument("--backdrop_colour", default="#ffffff", help="colour removed with --backdrop colour")
        pars.add_argument("--seed", type=int, default=0)
        pars.add_argument("--keep_bitmap", type=inkex.Boolean, default=False,
                          help="keep the bitmap, hidden, below the shapes")
        pars.add_argument("--depixel", default="", help="the depixel program (empty: found automatically)")

    def effect(self) -> None:
        images = selected_images(list(self.svg.selection.values()))
        command = find_depixel(self.options.depixel)
        flags = convert_flags(self.options)
        used_ids = set(self.document.getroot().xpath("//@id"))
        with tempfile.TemporaryDirectory(prefix="depixel-inkscape-") as folder:
            # convert every image before changing the document: one failure changes nothing
            drawings = [run_depixel(command, read_bitmap(image, self.document_folders(), folder, n),
                                    flags, folder, describe(image)) for n, image in enumerate(images)]
        for image, drawing in zip(images, drawings):
            replace_image(image, drawing, used_ids, self.options.keep_bitmap)

    def document_folders(self) -> list[str]:
        """Where relative links are looked up: the saved document's folder (Inkscape 1.1+
        tells it in $DOCUMENT_PATH), then the folder of the file the script was given."""
        folders = []
        for path in (os.environ.get("DOCUMENT_PATH"), self.options.input_file):
            if isinstance(path, str) and path:
                folders.append(os.path.dirname(os.path.abspath(path)))
        return folders


# --- what to convert ------------------------------------------------------------------------------

def local_name(element) -> str:
    tag = element.tag
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def selected_images(selection: list) -> list:
    """The ``<image>`` elements of the selection, or inside selected groups, in document
    order; aborts with what to do when there is none."""
    if not selection:
        raise inkex.AbortExtension(
            "Depixelize: nothing is selected. Select one or more bitmaps (pixel art imported "
            "with File > Import or pasted), then run Extensions > Raster > Depixelize (depixel) again.")
    found = []
    for element in selection:
        candidates = [element] if local_name(element) == "image" else element.iter(f"{{{SVG_NS}}}image")
        for image in candidates:
            if image not in found and not _hidden_in_definitions(image, element):
                found.append(image)
    if not found:
        kinds = sorted({local_name(e) or "?" for e in selection})
        raise inkex.AbortExtension(
            f"Depixelize: the selection holds no bitmap (it has: {', '.join(kinds)}). Select an image: "
            "Inkscape's status bar says 'Image' for one.")
    wanted = set(found)
    return [e for e in found[0].getroottree().iter(f"{{{SVG_NS}}}image") if e in wanted]


def _hidden_in_definitions(image, top) -> bool:
    """Whether ``image`` sits in a <defs>, <clipPath>, ... between itself and ``top``."""
    node = image.getparent()
    while node is not None and node is not top.getparent():
        if local_name(node) in NOT_RENDERED:
            return True
        node = node.getparent()
    return False


def describe(image) -> str:
    return f"image '{image.get('id') or image.get(INKSCAPE_LABEL) or '?'}'"


def read_bitmap(image, folders: list[str], scratch: str, index: int) -> str:
    """Write the image's bitmap into ``scratch`` and return its path."""
    href = (image.get(XLINK_HREF) or image.get("href") or "").strip()
    if not href:
        raise inkex.AbortExtension(f"Depixelize: {describe(image)} has no bitmap (no href).")
    if href.startswith("data:"):
        data, suffix = decode_data_uri(href, describe(image))
    else:
        path = find_linked_file(href, image.get(SODIPODI_ABSREF), folders, describe(image))
        with open(path, "rb") as handle:
            data = handle.read()
        suffix = os.path.splitext(path)[1].lower() or ".png"
    target = os.path.join(scratch, f"image-{index}{suffix}")
    with open(target, "wb") as handle:
        handle.write(data)
    return target


def decode_data_uri(href: str, name: str):
    """``data:[type][;base64],payload`` → (bytes, file suffix)."""
    header, comma, payload = href[5:].partition(",")
    if not comma:
        raise inkex.AbortExtension(f"Depixelize: {name} has a malformed data: URI.")
    parts = [p.strip().lower() for p in header.split(";")]
    media = parts[0] or "text/plain"
    if media == "image/svg+xml" or not media.startswith("image/"):
        raise inkex.AbortExtension(
            f"Depixelize: {name} holds {media}, not a bitmap: depixel converts PNG, GIF, BMP, ... pixel art.")
    try:
        if "base64" in parts[1:]:
            data = base64.b64decode(re.sub(r"\s+", "", urllib.parse.unquote(payload)), validate=True)
        else:
            data = urllib.parse.unquote_to_bytes(payload)
    except ValueError:
        raise inkex.AbortExtension(f"Depixelize: {name} has corrupt base64 image data.") from None
    return data, SUFFIXES.get(media, ".png")


def find_linked_file(href: str, absref, folders: list[str], name: str) -> str:
    """The file a linked image shows: ``file:`` URI, absolute or relative path (to the
    document's folder), else Inkscape's ``sodipodi:absref`` copy of the absolute path."""
    parsed = urllib.parse.urlparse(href)
    if parsed.scheme == "file":
        path = urllib.request.url2pathname(parsed.path)
    elif parsed.scheme and len(parsed.scheme) > 1:  # one letter: a Windows drive, C:\...
        raise inkex.AbortExtension(
            f"Depixelize: {name} links to {href}; only embedded bitmaps and local files can be "
            "converted (download it first).")
    else:
        path = urllib.parse.unquote(href)
    path = os.path.expanduser(path)
    candidates = [path] if os.path.isabs(path) else [os.path.join(folder, path) for folder in folders]
    if absref:
        candidates.append(absref)
    for candidate in candidates:
        if os.path.isfile(candidate):
            return candidate
    looked = ", ".join(candidates) if candidates else path
    raise inkex.AbortExtension(
        f"Depixelize: {name} links to a file that was not found: {href} (looked for {looked}). Save the "
        "document next to the image or embed it (Extensions > Images > Embed Images).")


# --- running depixel ------------------------------------------------------------------------------

def convert_flags(options) -> list[str]:
    """The ``depixel convert`` flags of the dialog's values, from :data:`FLAGS`."""
    values = {
        "stage": options.stage,
        "layout": options.layout,
        "simplify": options.simplify,
        "pixel_size": options.pixel_size.strip().lower() or "auto",
        "transparent": {"keep": "", "auto": "auto", "colour": options.backdrop_colour.strip()}[options.backdrop],
        "seed": options.seed,
    }
    flags = []
    for option, flag, default, _ in FLAGS:
        value = values[option]
        if value != default:
            flags += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
    return flags


def find_depixel(setting: str) -> list[str]:
    """The command that runs depixel: the dialog's path, ``$DEPIXEL``, the command recorded
    by ``depixel inkscape install``, or ``depixel`` on PATH, the first that is set."""
    for origin, path in (("the dialog's 'depixel program'", setting.strip()),
                         (f"the {ENVIRONMENT_VARIABLE} environment variable",
                          os.environ.get(ENVIRONMENT_VARIABLE, "").strip())):
        if path:
            program = _program(path)
            if program is None:
                raise inkex.AbortExtension(
                    f"Depixelize: {origin} is set to {path}, which is not the depixel program. Give "
                    "the path of 'depixel' (run 'which depixel', or 'where depixel' on Windows, where "
                    "depixel is installed), or leave it empty.")
            return [program]
    recorded = _recorded_command()
    if recorded:
        return recorded
    program = shutil.which("depixel")
    if program:
        return [program]
    raise inkex.AbortExtension(
        "Depixelize: the depixel program was not found. Install it (pip install depixel) and run "
        "'depixel inkscape install' from that environment, or give the path of the depixel program "
        f"in the dialog's 'depixel program' tab (or in the {ENVIRONMENT_VARIABLE} environment variable), "
        "then try again.")


def _program(path: str):
    """An executable file at ``path`` (or named depixel in the folder ``path``), else None."""
    path = os.path.expanduser(path)
    if os.path.isdir(path):
        path = shutil.which("depixel", path=path) or ""
    return path if os.path.isfile(path) and os.access(path, os.X_OK) else None


def _recorded_command():
    """The install-time command, when its interpreter still exists."""
    record = os.path.join(os.path.dirname(os.path.abspath(__file__)), RECORDED_COMMAND)
    try:
        with open(record, encoding="utf-8") as handle:
            command = json.load(handle)["command"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if isinstance(command, list) and command and all(isinstance(c, str) for c in command) \
            and os.path.isfile(command[0]):
        return command
    return None


def run_depixel(command: list[str], bitmap: str, flags: list[str], scratch: str, name: str):
    """Run ``depixel convert`` on one bitmap and parse the SVG it writes."""
    output = os.path.splitext(bitmap)[0] + ".svg"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONHOME", "PYTHONPATH")}  # Inkscape's own
    try:
        done = subprocess.run(command + ["convert", bitmap, "-o", output] + flags, cwd=scratch, env=env,
                              stdin=subprocess.DEVNULL, capture_output=True,
                              creationflags=getattr(subprocess, "CREATE_NO_WINDOW", 0))
    except OSError as exc:
        raise inkex.AbortExtension(f"Depixelize: cannot run {' '.join(command)}: {exc}") from None
    if done.returncode != 0 or not os.path.isfile(output):
        reason = _explain(done.stderr.decode("utf-8", "replace"), bitmap)
        raise inkex.AbortExtension(f"Depixelize: depixel could not convert {name}: {reason}")
    try:
        return inkex.load_svg(output).getroot()
    except Exception as exc:  # lxml's XMLSyntaxError and friends: report, never a traceback
        raise inkex.AbortExtension(f"Depixelize: depixel wrote an unreadable SVG for {name}: {exc}") from None


def _explain(stderr: str, bitmap: str) -> str:
    """depixel's one-line error, with an unknown flag named by its dialog field."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    text = lines[-1] if lines else "it stopped without a message"
    text = text.replace(bitmap, "the bitmap")
    unknown = re.search(r"unrecognized arguments: (--[\w-]+)", text)
    if unknown:
        fields = {flag: field for _, flag, _, field in FLAGS}
        flag = unknown.group(1)
        field = fields.get(flag, flag)
        return f"this depixel is too old for the '{field}' setting ({flag}): upgrade depixel, or set '{field}' " \
               "back to its default."
    return text


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

    parent = image.getparent()
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


if __name__ == "__main__":
    DepixelizeEffect().run()
