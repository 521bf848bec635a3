"""The Inkscape extension, run as Inkscape runs it: ``python3 SCRIPT --id=ID in.svg > out.svg``.

Each document test runs the script with inkex from PyPI (the test extra) and, where Inkscape
is installed, with Inkscape's own inkex under the Python that imports it. The output is
rendered with cairosvg and sampled at the sprite's pixel centres, mapped into the page by
matrices written out here (and checked on the render of the bitmap itself).
"""
from __future__ import annotations

import base64
import functools
import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES
from lxml import etree
from PIL import Image

from depixel.render.raster import render_rgba
from depixel.svg.writer import DEFAULT_SIMPLIFY
from depixel_cli.inkscape import command as installer
from depixel_cli.main import main
from depixel_cli.options import Exit

SCRIPT = installer.SOURCE / "depixel_inkscape.py"
SVG = "http://www.w3.org/2000/svg"
XLINK = "http://www.w3.org/1999/xlink"
PAGE_W, PAGE_H = 400, 300


# --- running the script ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Runtime:
    """A Python that imports an inkex: PyPI's (in this environment) or Inkscape's own copy."""

    name: str
    python: str
    pythonpath: str | None = None


@functools.cache
def inkscape_runtime() -> Runtime | str:
    """Inkscape's inkex (``inkscape --system-data-directory``/extensions) with the first
    Python that imports it, as Inkscape's own ``python3`` would; without one, why not: what
    is missing, found the way ``depixel inkscape check`` finds it."""
    inkscape = shutil.which("inkscape")
    if inkscape is None:
        return "Inkscape is not installed (no inkscape on PATH)"
    done = subprocess.run([inkscape, "--system-data-directory"], capture_output=True, text=True, timeout=120)
    folder = Path(done.stdout.strip().splitlines()[-1] if done.stdout.strip() else "") / "extensions"
    if not (folder / "inkex" / "__init__.py").is_file():
        return f"Inkscape is installed but its inkex is not in {folder}"
    lacking = []
    for python in dict.fromkeys(("/usr/bin/python3", shutil.which("python3"), sys.executable)):
        if not python or not os.path.isfile(python):
            continue
        env = {**os.environ, "PYTHONPATH": str(folder)}
        if subprocess.run([python, "-c", "import inkex"], env=env, capture_output=True).returncode == 0:
            return Runtime("inkscape", python, str(folder))
        lacking.append(why_not(python, env))
    return f"Inkscape is installed but no Python here imports its inkex: {'; '.join(lacking)}"


def why_not(python: str, env: dict) -> str:
    """What ``python`` lacks to import inkex, and the command that installs it."""
    done = subprocess.run([python, str(installer.SOURCE / "depixel_inkscape_check.py")], env=env,
                          capture_output=True, text=True)
    try:
        report = json.loads(done.stdout)
    except ValueError:
        return f"{python} does not run the check ({done.stderr.strip().splitlines()[-1:]})"
    if report["missing"]:
        return f"{python} lacks {', '.join(report['missing'])} ({report['fix']})"
    return f"{python} imports its modules but not inkex"


def pypi_runtime() -> Runtime:
    try:
        import inkex  # noqa: F401, PLC0415
    except ImportError:
        pytest.skip("inkex is not installed: pip install '.[test]'")
    return Runtime("pypi", sys.executable)


@pytest.fixture(params=["pypi", "inkscape"])
def runtime(request) -> Runtime:
    if request.param == "pypi":
        return pypi_runtime()
    found = inkscape_runtime()
    if isinstance(found, str):
        pytest.skip(found)
    return found


@pytest.fixture(scope="session")
def depixel_program(tmp_path_factory) -> Path:
    """An executable ``depixel`` running this checkout's CLI with this interpreter."""
    folder = tmp_path_factory.mktemp("bin")
    program = folder / "depixel"
    program.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m depixel "$@"\n')
    program.chmod(0o755)
    return program


def run_script(runtime: Runtime, document: Path, ids: list[str], *options: str, depixel: Path | None = None,
               script: Path = SCRIPT, path: str | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "DEPIXEL", "DOCUMENT_PATH")}
    if runtime.pythonpath:
        env["PYTHONPATH"] = runtime.pythonpath
    if depixel is not None:
        env["DEPIXEL"] = str(depixel)
    if path is not None:
        env["PATH"] = path
    argv = [runtime.python, str(script), *[f"--id={i}" for i in ids], *options, str(document)]
    return subprocess.run(argv, capture_output=True, env=env, timeout=300)


def converted(runtime, document, ids, *options, depixel) -> bytes:
    done = run_script(runtime, document, ids, *options, depixel=depixel)
    assert done.returncode == 0, done.stderr.decode()
    assert done.stdout.lstrip().startswith(b"<"), done.stdout[:200]
    return done.stdout


# --- documents ------------------------------------------------------------------------------------

def data_uri(name: str) -> str:
    return "data:image/png;base64," + base64.b64encode((FIXTURES / name).read_bytes()).decode()


#: Content that must come out exactly as it went in: defs, metadata, an unselected image,
#: shapes, text, a clone, all in the page's lower right corner, away from the sprites.
OTHER_CONTENT = f"""
<sodipodi:namedview id="namedview1" pagecolor="#ffffff" inkscape:zoom="2"/>
<metadata id="metadata1"><title>kept</title></metadata>
<defs id="defs1"><linearGradient id="grad1">
  <stop offset="0" stop-color="#f00"/><stop offset="1" stop-color="#00f"/></linearGradient></defs>
<g id="others" inkscape:label="Others" inkscape:groupmode="layer">
  <rect id="rect1" x="330" y="240" width="30" height="20" fill="url(#grad1)"/>
  <path id="path1" d="M370 240 l20 0 l-10 20 z" style="fill:#0a0;stroke:#000"/>
  <text id="text1" x="330" y="290" style="font-size:8px">label</text>
  <image id="unselected" x="370" y="270" width="20" height="20" xlink:href="{data_uri('heart.png')}"/>
  <use id="clone1" xlink:href="#rect1" transform="translate(0,-30)"/>
</g>
"""


def write_document(folder: Path, body: str, name: str = "in.svg") -> Path:
    path = folder / name
    path.write_text(
        f'<svg xmlns="{SVG}" xmlns:xlink="{XLINK}" '
        'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
        'xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd" '
        f'width="{PAGE_W}" height="{PAGE_H}" viewBox="0 0 {PAGE_W} {PAGE_H}">'
        f"{OTHER_CONTENT}{body}</svg>\n")
    return path


def image(id_: str, href: str, x: float, y: float, w: float, h: float, extra: str = "") -> str:
    return (f'<image id="{id_}" x="{x}" y="{y}" width="{w}" height="{h}" preserveAspectRatio="none" '
            f'style="image-rendering:optimizeSpeed" xlink:href="{href}" {extra}/>')


# --- checks ---------------------------------------------------------------------------------------

def sprite(name: str) -> np.ndarray:
    with Image.open(FIXTURES / name) as img:
        return np.asarray(img.convert("RGBA"), dtype=np.int64)


def affine(*matrices) -> np.ndarray:
    """Product of 3×3 affine matrices given as (a, b, c, d, e, f) like SVG's matrix()."""
    out = np.eye(3)
    for a, b, c, d, e, f in matrices:
        out = out @ np.array([[a, c, e], [b, d, f], [0, 0, 1]], dtype=np.float64)
    return out


def rotate(degrees: float, cx: float, cy: float) -> tuple:
    t = np.radians(degrees)
    cos, sin = np.cos(t), np.sin(t)
    return (cos, sin, -sin, cos, cx - cos * cx + sin * cy, cy - sin * cx - cos * cy)


def centre_match(svg: bytes, pixels: np.ndarray, to_page: np.ndarray, scale: float = 2.0) -> float:
    """Fraction of the sprite's pixel centres (mapped into the page by ``to_page``) whose
    colour the render reproduces: alpha within 24, colour within 16 where not transparent."""
    h, w = pixels.shape[:2]
    cx, cy = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    x = to_page[0, 0] * cx + to_page[0, 1] * cy + to_page[0, 2]
    y = to_page[1, 0] * cx + to_page[1, 1] * cy + to_page[1, 2]
    render = render_rgba(svg, scale=scale).astype(np.int64)
    got = render[np.floor(y * scale).astype(int), np.floor(x * scale).astype(int)]
    alpha_ok = np.abs(got[..., 3] - pixels[..., 3]) <= 24
    colour_ok = (np.abs(got[..., :3] - pixels[..., :3]).max(axis=-1) <= 16) | (pixels[..., 3] == 0)
    return float((alpha_ok & colour_ok).mean())


def tree(svg: bytes) -> etree._Element:
    return etree.fromstring(svg)


def by_id(root: etree._Element, id_: str) -> etree._Element | None:
    found = root.xpath("//*[@id=$id]", id=id_)
    return found[0] if found else None


def without(svg: bytes, ids: list[str]) -> bytes:
    """The document with the elements of ``ids`` taken out, canonicalized."""
    root = tree(svg)
    for id_ in ids:
        element = by_id(root, id_)
        if element is not None:
            element.getparent().remove(element)
    return etree.tostring(root, method="c14n")


def assert_replaced(before: bytes, after: bytes, ids: list[str]) -> None:
    """Each image became a group with its id, holding drawing; nothing else changed."""
    root = tree(after)
    for id_ in ids:
        group = by_id(root, id_)
        assert group is not None and group.tag == f"{{{SVG}}}g", f"{id_} is not a group"
        assert len(group.xpath(".//svg:path", namespaces={"svg": SVG})) >= 2
    assert without(before, ids) == without(after, ids), "the rest of the document changed"
    assert len(root.xpath("//svg:image", namespaces={"svg": SVG})) == 1  # the unselected one
    ids_after = root.xpath("//@id")
    assert len(ids_after) == len(set(ids_after)), "duplicate ids"
    referenced = set(re.findall(r"url\(#([^)]+)\)", after.decode()))
    referenced |= {h[1:] for h in root.xpath("//@xlink:href", namespaces={"xlink": XLINK}) if h.startswith("#")}
    assert referenced <= set(ids_after), f"dangling references: {referenced - set(ids_after)}"


# --- the documents of the issue -------------------------------------------------------------------

def test_embedded_sprite_at_an_offset_and_scale(runtime, tmp_path, depixel_program):
    body = ('<g id="layer1" inkscape:label="Sprites" transform="translate(10,5)">'
            + image("ghost", data_uri("ghost.png"), 30, 40, 180, 160) + "</g>")
    doc = write_document(tmp_path, body)
    to_page = affine((1, 0, 0, 1, 10, 5), (10, 0, 0, 10, 30, 40))
    assert centre_match(doc.read_bytes(), sprite("ghost.png"), to_page) == 1.0  # the matrix is right

    out = converted(runtime, doc, ["ghost"], depixel=depixel_program)
    assert centre_match(out, sprite("ghost.png"), to_page) >= 0.99
    assert_replaced(doc.read_bytes(), out, ["ghost"])
    assert by_id(tree(out), "ghost").get("{http://www.inkscape.org/namespaces/inkscape}label") == "ghost (depixel)"


def test_rotated_sprite_in_a_scaled_layer(runtime, tmp_path, depixel_program):
    body = ('<g id="layer1" transform="scale(1.25,1)">'
            + image("heart", data_uri("heart.png"), 100, 50, 120, 120, 'transform="rotate(30 160 110)"') + "</g>")
    doc = write_document(tmp_path, body)
    to_page = affine((1.25, 0, 0, 1, 0, 0), rotate(30, 160, 110), (12, 0, 0, 12, 100, 50))
    assert centre_match(doc.read_bytes(), sprite("heart.png"), to_page) == 1.0

    out = converted(runtime, doc, ["heart"], depixel=depixel_program)
    assert centre_match(out, sprite("heart.png"), to_page) >= 0.99
    assert_replaced(doc.read_bytes(), out, ["heart"])


@pytest.mark.parametrize("link", ["relative", "file-uri"])
def test_linked_file(runtime, tmp_path, depixel_program, link):
    (tmp_path / "art").mkdir()
    shutil.copy(FIXTURES / "leaf.png", tmp_path / "art" / "leaf.png")
    href = "art/leaf.png" if link == "relative" else (tmp_path / "art" / "leaf.png").as_uri()
    doc = write_document(tmp_path, image("leaf", href, 20, 30, 120, 120))

    out = converted(runtime, doc, ["leaf"], depixel=depixel_program)
    assert centre_match(out, sprite("leaf.png"), affine((10, 0, 0, 10, 20, 30))) >= 0.99
    assert_replaced(doc.read_bytes(), out, ["leaf"])


def test_two_selected_images_get_unique_ids(runtime, tmp_path, depixel_program):
    # the same sprite twice: every id of the second drawing collides with the first's
    body = image("a", data_uri("heart.png"), 10, 10, 100, 100) + image("b", data_uri("heart.png"), 150, 60, 50, 50)
    doc = write_document(tmp_path, body)

    out = converted(runtime, doc, ["b", "a"], depixel=depixel_program)
    assert centre_match(out, sprite("heart.png"), affine((10, 0, 0, 10, 10, 10))) >= 0.99
    assert centre_match(out, sprite("heart.png"), affine((5, 0, 0, 5, 150, 60))) >= 0.99
    assert_replaced(doc.read_bytes(), out, ["a", "b"])  # includes: no duplicate ids, no dangling reference
    root = tree(out)
    ids_a = [e.get("id") for e in by_id(root, "a").iter() if e.get("id")]
    ids_b = [e.get("id") for e in by_id(root, "b").iter() if e.get("id")]
    assert len(ids_a) == len(ids_b) > 2 and not set(ids_a) & set(ids_b)


def test_an_animated_bitmap_comes_as_layers_showing_its_first_frame(runtime, tmp_path, depixel_program):
    from test_animate_cli import rgba, walk_gif

    href = "data:image/gif;base64," + base64.b64encode(walk_gif()).decode()
    # twice, so the second's ids (its frames' shared shapes and their uses) are renamed
    body = ('<g id="layer1" inkscape:label="Sprites" inkscape:groupmode="layer">'
            + image("walk", href, 10, 10, 60, 60) + "</g>"
            + '<g id="plain">' + image("again", href, 100, 10, 30, 30) + "</g>")
    doc = write_document(tmp_path, body)
    out = converted(runtime, doc, ["walk", "again"], "--animate=true", depixel=depixel_program)
    assert_replaced(doc.read_bytes(), out, ["walk", "again"])  # no duplicate id, no dangling xlink:href
    root = tree(out)
    mode, label = "{http://www.inkscape.org/namespaces/inkscape}groupmode", \
        "{http://www.inkscape.org/namespaces/inkscape}label"
    for id_, outer in (("walk", "layer"), ("again", None)):  # a layer where the bitmap was in one
        group = by_id(root, id_)
        assert group.get(mode) == outer
        frames = [g for g in group if g.get(mode) == "layer"]
        assert [g.get(label) for g in frames] == ["frame 1 (120 ms)", "frame 2 (40 ms)", "frame 3 (250 ms)"]
        assert [g.get("display") for g in frames] == [None, "none", "none"]
        # each drawing's uses point into its own shared shapes, not the other's
        own = {e.get("id") for e in group.iter() if e.get("id")}
        uses = [e.get(f"{{{XLINK}}}href")[1:] for e in group.iter(f"{{{SVG}}}use")]
        assert uses and set(uses) <= own, id_
    first = rgba(1).astype(np.int64)
    assert centre_match(out, first, affine((10, 0, 0, 10, 10, 10))) == 1.0  # frame 1 drawn
    assert centre_match(out, first, affine((5, 0, 0, 5, 100, 10))) == 1.0


def test_transparent_sprite_stays_transparent(runtime, tmp_path, depixel_program):
    doc = write_document(tmp_path, image("potion", data_uri("potion_rgba.png"), 40, 20, 144, 144))
    pixels = sprite("potion_rgba.png")
    to_page = affine((12, 0, 0, 12, 40, 20))
    assert centre_match(doc.read_bytes(), pixels, to_page) == 1.0

    out = converted(runtime, doc, ["potion"], depixel=depixel_program)
    assert centre_match(out, pixels, to_page) >= 0.99
    assert_replaced(doc.read_bytes(), out, ["potion"])


@pytest.mark.parametrize("ids, message", [
    (["rect1", "path1"], "the selection holds no bitmap (it has: path, rect)"),
    ([], "nothing is selected"),
])
def test_a_selection_without_a_bitmap_says_so(runtime, tmp_path, depixel_program, ids, message):
    doc = write_document(tmp_path, image("ghost", data_uri("ghost.png"), 30, 40, 180, 160))
    done = run_script(runtime, doc, ids, depixel=depixel_program)
    assert done.returncode != 0 and done.stdout == b""  # Inkscape keeps the document as it was
    err = done.stderr.decode()
    assert message in err and "Traceback" not in err


# --- placement rules ------------------------------------------------------------------------------

def test_keep_bitmap_hides_it_below_the_shapes(tmp_path, depixel_program):
    doc = write_document(tmp_path, image("ghost", data_uri("ghost.png"), 30, 40, 180, 160))
    out = converted(pypi_runtime(), doc, ["ghost"], "--keep_bitmap=true", depixel=depixel_program)

    root = tree(out)
    bitmap, group = by_id(root, "ghost"), by_id(root, "ghost-depixel")
    assert bitmap.tag == f"{{{SVG}}}image" and group.tag == f"{{{SVG}}}g"
    assert group.getprevious() is bitmap
    assert "display:none" in bitmap.get("style") and "image-rendering:optimizeSpeed" in bitmap.get("style")
    assert centre_match(out, sprite("ghost.png"), affine((10, 0, 0, 10, 30, 40))) >= 0.99
    assert without(doc.read_bytes(), ["ghost"]) == without(out, ["ghost", "ghost-depixel"])


@pytest.mark.parametrize("aspect, to_page", [
    # a 10×10 bitmap in a 200×100 box: scaled 10×, centred / right-aligned; or 20×, top-aligned and cut
    ("xMidYMid meet", (10, 0, 0, 10, 70, 20)),
    ("xMaxYMax meet", (10, 0, 0, 10, 120, 20)),
    ("xMidYMin slice", (20, 0, 0, 20, 20, 20)),
])
def test_preserve_aspect_ratio(tmp_path, depixel_program, aspect, to_page):
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 20, 20, 200, 100).replace(
        'preserveAspectRatio="none"', f'preserveAspectRatio="{aspect}"'))
    expected = sprite("heart.png").copy()
    expected[100 // to_page[0]:] = 0  # slice: the rows below the box are cut away
    matrix = affine(to_page)
    assert centre_match(doc.read_bytes(), expected, matrix) == 1.0

    out = converted(pypi_runtime(), doc, ["heart"], depixel=depixel_program)
    assert centre_match(out, expected, matrix) >= 0.99


def test_image_clip_path_stays_in_the_image_space(tmp_path, depixel_program):
    """A clip on a transformed bitmap clips the shapes in the same place."""
    body = ('<defs><clipPath id="clip1" clipPathUnits="userSpaceOnUse"><rect x="0" y="0" width="60" height="200"/>'
            '</clipPath></defs>'
            + image("heart", data_uri("heart.png"), 0, 0, 120, 120,
                    'transform="translate(30,20)" clip-path="url(#clip1)"'))
    doc = write_document(tmp_path, body)
    pixels = sprite("heart.png").copy()
    pixels[:, 5:] = 0  # the right half is clipped away
    to_page = affine((12, 0, 0, 12, 30, 20))
    assert centre_match(doc.read_bytes(), pixels, to_page) == 1.0

    out = converted(pypi_runtime(), doc, ["heart"], depixel=depixel_program)
    assert centre_match(out, pixels, to_page) >= 0.99
    group = by_id(tree(out), "heart")
    assert group.get("clip-path") == "url(#clip1)" and group.get("transform") == "translate(30,20)"


def test_images_inside_a_selected_group_are_converted(tmp_path, depixel_program):
    body = ('<g id="sprites">' + image("a", data_uri("heart.png"), 10, 10, 100, 100)
            + image("b", data_uri("leaf.png"), 150, 10, 120, 120) + "</g>")
    doc = write_document(tmp_path, body)
    out = converted(pypi_runtime(), doc, ["sprites"], depixel=depixel_program)
    assert_replaced(doc.read_bytes(), out, ["a", "b"])
    assert centre_match(out, sprite("leaf.png"), affine((10, 0, 0, 10, 150, 10))) >= 0.99


# --- finding and running depixel ------------------------------------------------------------------

FAKE_DEPIXEL = """#!{python}
import json, sys
argv = sys.argv[1:]
with open({log!r}, "a") as log:
    log.write(json.dumps(argv) + "\\n")
if {fail!r}:
    sys.stderr.write({fail!r} + "\\n")
    sys.exit(2)
out = argv[argv.index("-o") + 1]
with open(out, "w") as svg:
    svg.write('<svg xmlns="http://www.w3.org/2000/svg" width="8" height="4" viewBox="0 0 4 2"><title>t</title>'
              '<rect id="r" width="4" height="2" fill="#123456"/></svg>')
"""


def fake_depixel(folder: Path, fail: str = "") -> tuple[Path, Path]:
    """A stand-in depixel that logs its arguments (and fails with ``fail`` when given)."""
    log, program = folder / "argv.log", folder / "depixel"
    program.write_text(FAKE_DEPIXEL.format(python=sys.executable, log=str(log), fail=fail))
    program.chmod(0o755)
    return program, log


@pytest.mark.parametrize("options, flags", [
    ([], []),  # the defaults pass no flag: works with a depixel that lacks the newer ones
    (["--stage=cells", "--layout=cutout", "--simplify=0.5", "--pixel_size=4x3", "--backdrop=auto"],
     ["--stage", "cells", "--layout", "cutout", "--simplify", "0.5", "--pixel-size", "4x3",
      "--transparent", "auto"]),
    (["--backdrop=colour", "--backdrop_colour=#5c94fc", "--pixel_size=1"],
     ["--pixel-size", "1", "--transparent", "#5c94fc"]),
    (["--backdrop_colour=#5c94fc", "--tab=program"], []),  # a colour alone removes nothing
    (["--animate=true", "--simplify=0"], ["--simplify", "0", "--animate"]),
    (["--animate=false"], []),
])
def test_dialog_options_become_flags(tmp_path, options, flags):
    program, log = fake_depixel(tmp_path)
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 10, 10, 40, 20))
    out = converted(pypi_runtime(), doc, ["heart"], *options, depixel=program)
    argv = json.loads(log.read_text())
    assert argv[0] == "convert" and argv[2] == "-o" and argv[3].endswith(".svg") and argv[4:] == flags
    group = by_id(tree(out), "heart")
    # the 4×2 viewBox onto the SVG's 8×4 size (an upscaled input), that onto the 40×20 image
    assert group.get("transform") == "translate(10,10) scale(10,10)"
    assert [e.get("id") for e in group] == ["r"]  # the <title> is left out


def test_a_flag_this_depixel_lacks_is_named_by_its_dialog_field(tmp_path):
    program, _ = fake_depixel(tmp_path, fail="depixel convert: error: unrecognized arguments: --layout cutout")
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 10, 10, 40, 20))
    done = run_script(pypi_runtime(), doc, ["heart"], "--layout=cutout", depixel=program)
    assert done.returncode != 0 and done.stdout == b""
    assert "too old for the 'Shapes' setting (--layout)" in done.stderr.decode()


def test_a_bitmap_depixel_cannot_read_is_reported_by_id(tmp_path, depixel_program):
    href = "data:image/png;base64," + base64.b64encode(b"\x89PNG\r\n\x1a\nbroken" * 4).decode()
    doc = write_document(tmp_path, image("broken", href, 10, 10, 40, 40))
    done = run_script(pypi_runtime(), doc, ["broken"], depixel=depixel_program)
    err = done.stderr.decode()
    assert done.returncode != 0 and done.stdout == b""
    assert "depixel could not convert image 'broken'" in err and "Traceback" not in err


def test_missing_linked_file_is_reported(tmp_path, depixel_program):
    doc = write_document(tmp_path, image("gone", "missing/sprite.png", 10, 10, 40, 40))
    done = run_script(pypi_runtime(), doc, ["gone"], depixel=depixel_program)
    err = done.stderr.decode()
    assert done.returncode != 0 and "image 'gone' links to a file that was not found: missing/sprite.png" in err


def test_without_depixel_it_says_what_to_do(tmp_path):
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 10, 10, 40, 40))
    done = run_script(pypi_runtime(), doc, ["heart"], path=str(tmp_path))  # no depixel on PATH
    err = done.stderr.decode()
    assert done.returncode != 0 and done.stdout == b""
    assert "the depixel program was not found" in err and "depixel inkscape install" in err

    done = run_script(pypi_runtime(), doc, ["heart"], depixel=tmp_path / "nowhere" / "depixel")
    assert "the DEPIXEL environment variable is set to" in done.stderr.decode()


def test_depixel_on_path_is_found(tmp_path):
    program, log = fake_depixel(tmp_path)
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 10, 10, 40, 40))
    done = run_script(pypi_runtime(), doc, ["heart"], path=f"{program.parent}{os.pathsep}{os.environ['PATH']}")
    assert done.returncode == 0, done.stderr.decode()
    assert log.is_file()


def test_dialog_path_comes_before_the_environment(tmp_path, depixel_program):
    program, log = fake_depixel(tmp_path)
    doc = write_document(tmp_path, image("heart", data_uri("heart.png"), 10, 10, 40, 40))
    done = run_script(pypi_runtime(), doc, ["heart"], f"--depixel={program}", depixel=depixel_program)
    assert done.returncode == 0, done.stderr.decode()
    assert log.is_file()


# --- depixel inkscape install / uninstall ---------------------------------------------------------

def ready_python(profile: Path, monkeypatch) -> None:
    """Inkscape's preferences in ``profile`` name this Python, with stand-ins on PYTHONPATH for
    the modules inkex needs that the test environment lacks (cssselect), so that the check
    ``install`` runs first passes whatever this machine's python3 has (tests/test_inkscape_check.py
    tests the check itself)."""
    profile.mkdir(parents=True, exist_ok=True)
    (profile / "preferences.xml").write_text(
        f'<inkscape><group id="extensions" python-interpreter="{sys.executable}"/></inkscape>')
    stubs = profile / "stubs"
    for module in ("lxml", "cssselect", "numpy"):
        if subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True).returncode:
            (stubs / module).mkdir(parents=True, exist_ok=True)
            (stubs / module / "__init__.py").write_text("")
    monkeypatch.setenv("PYTHONPATH", str(stubs))


def test_install_then_convert_then_uninstall(tmp_path, capsys, monkeypatch):
    """The acceptance test: install, run the installed script with no DEPIXEL and no
    depixel on PATH (it uses the command install recorded), uninstall."""
    folder = tmp_path / "extensions"
    folder.mkdir()
    ready_python(tmp_path, monkeypatch)
    (folder / "other.inx").write_text("another extension")
    assert main(["inkscape", "install", "--dir", str(folder)]) == Exit.OK
    assert str(folder) in capsys.readouterr().out
    assert sorted(p.name for p in folder.iterdir()) == sorted([*installer.INSTALLED, "other.inx"])
    for name in installer.SHIPPED:
        assert (folder / name).read_bytes() == (installer.SOURCE / name).read_bytes()
    record = json.loads((folder / installer.RECORDED_COMMAND).read_text())
    assert record["command"] == [sys.executable, "-m", "depixel"]

    doc = write_document(tmp_path, image("ghost", data_uri("ghost.png"), 30, 40, 180, 160))
    done = run_script(pypi_runtime(), doc, ["ghost"], script=folder / "depixel_inkscape.py", path=str(tmp_path))
    assert done.returncode == 0, done.stderr.decode()
    assert centre_match(done.stdout, sprite("ghost.png"), affine((10, 0, 0, 10, 30, 40))) >= 0.99
    assert_replaced(doc.read_bytes(), done.stdout, ["ghost"])

    assert main(["inkscape", "uninstall", "--dir", str(folder)]) == Exit.OK
    assert [p.name for p in folder.iterdir()] == ["other.inx"]
    assert "removed" in capsys.readouterr().out
    assert main(["inkscape", "uninstall", "--dir", str(folder)]) == Exit.OK
    assert "nothing removed" in capsys.readouterr().out


def test_install_asks_inkscape_for_its_folder(tmp_path, monkeypatch, capsys):
    data = tmp_path / "config" / "inkscape"
    fake = tmp_path / "bin" / "inkscape"
    fake.parent.mkdir()
    fake.write_text(f'#!/bin/sh\n[ "$1" = --user-data-directory ] && echo "{data}"\n')
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", str(fake.parent))
    ready_python(data, monkeypatch)
    assert main(["inkscape", "install"]) == Exit.OK
    assert sorted(p.name for p in (data / "extensions").iterdir()) == sorted(installer.INSTALLED)
    assert main(["inkscape", "uninstall"]) == Exit.OK
    assert list((data / "extensions").iterdir()) == []


def test_install_without_inkscape_asks_for_dir(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert main(["inkscape", "install"]) == Exit.FAILED
    err = capsys.readouterr().err
    assert "inkscape is not on PATH" in err and "--dir" in err and len(err.strip().splitlines()) == 1


def test_inx_describes_the_script_and_its_options():
    """Every dialog parameter is an option of the script, under Extensions > Raster."""
    inx = etree.parse(str(installer.SOURCE / "depixel_inkscape.inx")).getroot()
    ns = {"i": "http://www.inkscape.org/namespace/inkscape/extension"}
    assert inx.findtext("i:name", namespaces=ns) == "Depixelize (depixel)"
    assert inx.find("i:effect/i:effects-menu/i:submenu", ns).get("name") == "Raster"
    assert inx.findtext("i:script/i:command", namespaces=ns) == SCRIPT.name
    params = {p.get("name"): p for p in inx.iter(f"{{{ns['i']}}}param")}
    script = SCRIPT.read_text()
    for name in params:
        assert f'"--{name}"' in script, name
    assert params["stage"].find("i:option", ns).get("value") == "optimized"  # the CLI's default first
    assert "seed" not in params and float(params["simplify"].text) == DEFAULT_SIMPLIFY and params["pixel_size"].text == "auto"
