#!/usr/bin/env python3
"""Inkscape extension: replace the selected bitmaps by depixel's vector shapes.

Inkscape runs it as ``python3 depixel_inkscape.py [options] --id=ID ... DOCUMENT.svg`` and
reads the changed document from stdout. For each selected ``<image>`` (embedded ``data:``
URI or linked file; images inside selected groups count too) it runs the ``depixel``
program, ``depixel convert IMAGE -o OUT.svg``, takes the drawing elements of the SVG it
writes and puts them in a ``<g>`` that maps that SVG's viewBox onto the place of the
bitmap: its x/y/width/height, ``preserveAspectRatio`` and transform, inside the same parent.
With "Animation" (``--animate``) an animated bitmap's frames come as layers of that group,
which is a layer itself where the bitmap was in one (or at the top).

It never imports depixel: Inkscape's Python is often not the one depixel is installed in,
so the program is looked for (dialog setting, ``$DEPIXEL``, the command recorded by
``depixel inkscape install``, ``PATH``). It reads nothing of depixel's SVG structure but
the root's size and viewBox, so it works with any version of depixel's SVG writer; every
id it imports is made unique in the document. Runs on Python 3.7+ with inkex 1.0 to 1.4.

This file finds the bitmaps and runs depixel; putting the drawing in place (the viewBox
mapping, unique ids, SVG lengths and transforms) is ``depixel_inkscape_place.py``, and
saying what Inkscape's Python lacks is ``depixel_inkscape_check.py``, which
``depixel inkscape install`` puts beside it and the ``.inx`` declares.
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

import depixel_inkscape_check as check  # the standard library only: it runs where inkex cannot

try:
    import inkex
    from depixel_inkscape_place import SVG_NS, XLINK_HREF, describe, local_name, replace_image
except ImportError as exc:  # Inkscape's Python lacks lxml, numpy, ...: one line saying how to install them
    check.exit_missing(exc)

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
    ("animate", "--animate", False, "Animation"),  # a flag without a value
)

#: Ancestors under which an image is not drawn where it stands (a selected group may hold one).
NOT_RENDERED = {"defs", "clipPath", "mask", "pattern", "symbol", "marker"}
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
        pars.add_argument("--keep_bitmap", type=inkex.Boolean, default=False,
                          help="keep the bitmap, hidden, below the shapes")
        pars.add_argument("--animate", type=inkex.Boolean, default=False,
                          help="every frame of an animated bitmap, a layer each")
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
        "animate": bool(options.animate),
    }
    flags = []
    for option, flag, default, _ in FLAGS:
        value = values[option]
        if isinstance(value, bool):
            flags += [flag] if value else []
        elif value != default:
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
        "Depixelize: the depixel program was not found. Install it from its source folder "
        "(pip install /path/to/depixel, or a wheel built there) and run 'depixel inkscape install' from "
        "that environment, or give the path of the depixel program "
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


if __name__ == "__main__":
    check.messages_to_inkscape()  # under --batch-process: no dialog waiting for OK
    DepixelizeEffect().run()
