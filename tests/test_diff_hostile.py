"""``depixel diff`` and ``depixel render`` on files made to hurt: an SVG drawing one embedded
PNG a thousand times or holding a 16000×16000 one, sizes like ``1e400``, folder trees 1,200
levels deep, file names that are not UTF-8 or 250 bytes long, unreadable rasters, and a
Ctrl-C while an embedded picture is drawn. Each answer is a verdict or one clear line,
never "internal error". Each test runs the command on real files."""
from __future__ import annotations

import base64
import io
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image

from depixel_cli.main import main
from depixel_cli.options import Exit


def run(*argv: str, capsys) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def depixel(*argv: str, timeout: float = 120) -> tuple[int, str, str, float]:
    """The ``depixel`` program: exit code, stdout, stderr and seconds."""
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "depixel", *argv], capture_output=True, text=True, timeout=timeout)
    return proc.returncode, proc.stdout, proc.stderr, time.monotonic() - start


def png_bytes(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, "PNG", optimize=True)
    return buffer.getvalue()


def used_picture_svg(png: bytes, uses: int, size: int = 64) -> str:
    """An SVG that defines one embedded PNG and draws it ``uses`` times with ``<use>``."""
    href = "data:image/png;base64," + base64.b64encode(png).decode()
    drawn = "".join(f'<use xlink:href="#p" x="{i % 40}" y="{i // 40}"/>' for i in range(uses))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="{size}" '
            f'height="{size}"><defs><image id="p" width="{size}" height="{size}" xlink:href="{href}"/></defs>'
            f"{drawn}</svg>")


def black_png(width: int, height: int) -> bytes:
    """A 1-bit black PNG, compressed row by row: never the whole image in this process's
    memory (a later test's subprocess inherits this process's peak in its ru_maxrss)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    packer = zlib.compressobj(9)
    row = bytes(1 + (width + 7) // 8)  # the filter byte, then the pixels
    body = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body) + chunk(b"IEND", b"")


@pytest.fixture(scope="module")
def many_uses(tmp_path_factory) -> Path:
    """A 25 KB PNG of 1000×1000 pixels (a few rows of detail, the rest flat) drawn 1,000 times
    at its own size (so that drawing it costs what a copy of its pixels costs)."""
    rng = np.random.default_rng(45)
    pixels = np.zeros((1000, 1000, 3), np.uint8)
    pixels[:40, :200] = rng.integers(0, 256, (40, 200, 3))
    png = png_bytes(Image.fromarray(pixels, "RGB"))
    assert 20_000 <= len(png) <= 30_000
    path = tmp_path_factory.mktemp("uses") / "uses.svg"
    path.write_text(used_picture_svg(png, 1000, size=1000))  # drawn at its own size
    return path


# --- an embedded picture: decoded once, counted in the pixel budget ------------------------

def test_one_embedded_png_drawn_a_thousand_times_renders_and_diffs_in_seconds(many_uses, tmp_path):
    code, _, err, seconds = depixel("render", str(many_uses), "-o", str(tmp_path / "uses.png"))
    assert code == 0 and err == "" and seconds < 10, (err, seconds)
    code, out, err, seconds = depixel("diff", str(many_uses), str(many_uses), "--json")
    assert code == 0 and json.loads(out)["same"] and seconds < 10, (err, seconds)
    other = tmp_path / "other.svg"
    other.write_text(many_uses.read_text().replace('x="39"', 'x="38"', 1))
    code, out, err, seconds = depixel("diff", str(many_uses), str(other))
    assert code in (0, 1) and out.startswith(("same", "different")) and seconds < 10, (err, seconds)


def test_a_huge_embedded_png_is_refused_by_the_pixel_budget_at_once(tmp_path):
    png = black_png(16000, 16000)  # 256 million pixels in 31 KB
    path = tmp_path / "bomb.svg"
    href = "data:image/png;base64," + base64.b64encode(png).decode()
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100">'
                    f'<image width="100" height="100" href="{href}"/></svg>')
    assert path.stat().st_size < 50_000
    proc = subprocess.run([sys.executable, "-c", "import resource, sys; from depixel_cli.main import main; "
                           "resource.setrlimit(resource.RLIMIT_AS, (600 << 20, 600 << 20)); "  # far under 1 GB
                           "sys.exit(main(sys.argv[1:]))", "render", str(path), "-o", str(tmp_path / "b.png")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and proc.stderr.count("\n") == 1, proc.stderr
    assert "embedded pictures hold 256000000 pixels" in proc.stderr and "--max-output-pixels" in proc.stderr
    assert not (tmp_path / "b.png").exists()
    code, out, err, _ = depixel("diff", str(path), str(path))
    assert code == 2 and err.count("\n") == 1 and "embedded pictures hold" in err and "--max-pixels" in err, err


def test_ctrl_c_while_an_embedded_png_is_drawn_is_one_line(tmp_path):
    rng = np.random.default_rng(7)
    pixels = np.zeros((2000, 2000, 3), np.uint8)
    pixels[:50, :150] = rng.integers(0, 256, (50, 150, 3))
    path = tmp_path / "slow.svg"
    path.write_text(used_picture_svg(png_bytes(Image.fromarray(pixels, "RGB")), 4000))
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "render", str(path), "-o", str(tmp_path / "s.png")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGINT and err == "depixel: interrupted\n", err
    assert not (tmp_path / "s.png").exists()


# --- sizes and depths: a clear line, never "internal error" -------------------------------

@pytest.mark.parametrize("root", ['width="1e400" height="10"', 'viewBox="0 0 1e400 10" width="10" height="10"',
                                  'viewBox="0 0 10 1e400"', 'width="10" height="-1e999"'])
def test_an_infinite_size_is_one_clear_line(tmp_path, capsys, root):
    bad = tmp_path / "bad.svg"
    bad.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {root}><rect width="5" height="5"/></svg>')
    good = tmp_path / "good.svg"
    good.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><rect width="5" height="5"/></svg>')
    for argv in (["diff", str(bad), str(good)], ["diff", str(good), str(bad)],
                 ["render", str(bad), "-o", str(tmp_path / "out.png")]):
        code, _, err = run(*argv, capsys=capsys)
        assert code in (1, 2) and err.count("\n") == 1, err
        assert "internal error" not in err and "bad.svg" in err and "too large a number" in err, err


def deep_tree(root: Path, levels: int, files: dict[str, Path]) -> Path:
    """``root/d/d/…/d`` (``levels`` folders) holding ``files``: made from the inside, with
    relative paths, as no path of that length could be given at once."""
    here = os.getcwd()
    root.mkdir(parents=True)
    os.chdir(root)
    try:
        for _ in range(levels):
            os.mkdir("d")
            os.chdir("d")
        for name, source in files.items():
            shutil.copy(source, name)
    finally:
        os.chdir(here)
    return root


def remove_tree(root: Path) -> None:
    """Remove a tree of any depth, bottom up (``shutil.rmtree``, pytest's cleanup of old
    temporary folders included, recurses a level at a time and fails on such a tree)."""
    folders, todo = [], [root]
    while todo:
        here = todo.pop()
        folders.append(here)
        for entry in os.scandir(here):
            if entry.is_dir(follow_symlinks=False):
                todo.append(Path(entry.path))
            else:
                os.unlink(entry.path)
    for folder in reversed(folders):
        os.rmdir(folder)


@pytest.fixture
def deep(tmp_path):
    """A folder for trees of any depth, removed after the test (see :func:`remove_tree`)."""
    yield tmp_path / "deep"
    if (tmp_path / "deep").exists():
        remove_tree(tmp_path / "deep")


def test_a_tree_1200_levels_deep_is_compared_updated_and_converted(deep):
    tmp_path = deep
    base = deep_tree(tmp_path / "base", 1200, {"x.png": FIXTURES / "heart.png"})
    cur = deep_tree(tmp_path / "cur", 1200, {"x.png": FIXTURES / "leaf.png", "y.png": FIXTURES / "heart.png"})
    code, out, err, _ = depixel("diff", str(base), str(cur), "--json")
    report = json.loads(out)
    assert code == 1 and err == "" and report["totals"]["new"] == 1 and report["totals"]["same"] == 0, err
    assert not any("internal" in (f["error"] or "") for f in report["files"])
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    code, out, err, _ = depixel("diff", str(fresh), str(cur), "--update")
    assert code == 0 and out.count("added: ") == 2, err
    code, _, err, _ = depixel("convert", "-r", str(cur), "--out-dir", str(tmp_path / "out"), "-q")
    assert code == 0 and err == "", err
    here = tmp_path / "out"  # (os.walk recurses: walked here a level at a time)
    for _ in range(1200):
        assert os.listdir(here) == ["d"]
        here = here / "d"
    assert sorted(os.listdir(here)) == ["x.svg", "y.svg"]


# --- file names: not UTF-8, 250 bytes ------------------------------------------------------

@pytest.fixture
def odd_names(tmp_path) -> tuple[Path, Path]:
    """A baseline and a current folder with one changed file whose name is not UTF-8 (the
    Latin-1 é) and one whose name is 250 bytes long."""
    base, cur = tmp_path / "base", tmp_path / "cur"
    for folder, colour in ((base, (0, 0, 0)), (cur, (255, 0, 0))):
        folder.mkdir()
        pixels = np.zeros((4, 4, 4), np.uint8)
        pixels[..., 3] = 255
        pixels[1, 1, :3] = colour
        for name in (b"caf\xe9.png", b"n" * 246 + b".png"):
            Image.fromarray(pixels, "RGBA").save(os.path.join(os.fsencode(folder), name))
    return base, cur


def test_names_that_are_not_utf8_in_the_html_json_and_junit_reports(odd_names, tmp_path, capsys):
    base, cur = odd_names
    report, junit = tmp_path / "report", tmp_path / "junit.xml"
    code, out, err = run("diff", str(base), str(cur), "--html", str(report), "--junit", str(junit), "--json",
                         capsys=capsys)
    assert code == Exit.FAILED and err == "", err
    out.encode("utf-8")  # no lone surrogate: strict UTF-8 (and strict JSON parsers) take it
    files = {f["name"]: f for f in json.loads(out)["files"]}
    assert set(files) == {"caf\\xe9.png", "n" * 246 + ".png"}  # the undecodable byte shown as \xe9
    assert all(f["verdict"] == "different" for f in files.values())
    page = (report / "index.html").read_text(encoding="utf-8")
    assert "caf\\xe9.png" in page and "%E9" in page  # shown escaped, linked by its real bytes
    pictures = os.listdir(os.fsencode(report / "images"))
    assert b"caf\xe9.png.diff.png" in pictures  # the raw bytes kept where files are written
    ET.parse(junit)
    assert "caf\\xe9.png" in junit.read_text(encoding="utf-8")


def test_a_250_byte_name_stays_different_when_pictures_are_written(odd_names, tmp_path, capsys):
    base, cur = odd_names
    code, out, _ = run("diff", str(base), str(cur), "--json", "--html", str(tmp_path / "r"),
                       "--diff-out", str(tmp_path / "d"), capsys=capsys)
    assert code == Exit.FAILED
    long = next(f for f in json.loads(out)["files"] if f["name"].startswith("nnn"))
    assert long["verdict"] == "different" and long["error"] is None
    assert Path(long["diff_out"]).is_file() and len(Path(long["diff_out"]).name.encode()) <= 255
    pictures = [p for p in (tmp_path / "r" / "images").iterdir() if p.name.startswith("nnn")]
    assert len(pictures) == 3 and len({p.name for p in pictures}) == 3
    page = (tmp_path / "r" / "index.html").read_text()
    assert all(f'src="images/{p.name}"' in page for p in pictures)


def test_an_unreadable_raster_is_named_by_its_file(tmp_path, capsys):
    base, cur = tmp_path / "base", tmp_path / "cur"
    for folder in (base, cur):
        folder.mkdir()
    shutil.copy(FIXTURES / "heart.png", base / "sprite.png")
    (cur / "sprite.png").write_bytes((FIXTURES / "heart.png").read_bytes()[:60])  # cut short
    code, out, _ = run("diff", str(base), str(cur), capsys=capsys)
    assert code == Exit.USAGE or code == Exit.FAILED
    line = next(line for line in out.splitlines() if line.startswith("error:"))
    assert "sprite.png" in line and "<bytes>" not in line, out


# --- the first hour's messages --------------------------------------------------------------

def test_diff_of_two_sizes_names_the_option_that_allows_it(tmp_path, capsys):
    small = FIXTURES / "heart.png"
    big = tmp_path / "big.png"
    with Image.open(small) as img:
        img.resize((img.width * 2, img.height * 3)).save(big)
    code, _, err = run("diff", str(small), str(big), capsys=capsys)
    assert code == Exit.USAGE and err.count("\n") == 1 and "--allow-size-mismatch" in err, err
    assert run("diff", str(small), str(big), "--allow-size-mismatch", capsys=capsys)[0] == Exit.FAILED


def test_render_of_an_image_says_to_use_convert(tmp_path, capsys):
    code, _, err = run("render", str(FIXTURES / "heart.png"), "-o", str(tmp_path / "heart.png"), capsys=capsys)
    assert code != 0 and err.count("\n") == 1, err
    assert "is an image (PNG), not an SVG" in err and "depixel convert" in err and "well-formed" not in err, err
