"""One resource policy at every entry (issue 17.1, 4-10): each oversized request is refused
with one line naming the limit and its flag/parameter, before the memory is spent.

The tests that would exhaust memory if a limit regressed run in a subprocess under
``resource.setrlimit(RLIMIT_AS)``, so a regression fails the test instead of taking the
machine down.
"""
from __future__ import annotations

import gzip
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES, drop_summary
from PIL import Image

import depixel
from depixel import api
from depixel.errors import InputError, OutputError, ParameterError
from depixel.files.output import write_atomic
from depixel.prepare.image import load_image
from depixel_cli.main import main
from depixel_cli.options import Exit

#: address space of a limited subprocess: enough for Python, numpy and cairo, far less than any bomb
LIMIT = 1536 * 2**20


def run_limited(*argv: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``python -m depixel ARGV`` with its address space capped at LIMIT."""
    code = ("import resource, sys, runpy; "
            f"resource.setrlimit(resource.RLIMIT_AS, ({LIMIT}, {LIMIT})); "
            "sys.argv = ['depixel'] + sys.argv[1:]; runpy.run_module('depixel', run_name='__main__')")
    return subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=300,
                          cwd=cwd)


def python_limited(body: str) -> str:
    """Run the Python ``body`` with its address space capped at LIMIT; its stdout (it must succeed)."""
    code = f"import resource; resource.setrlimit(resource.RLIMIT_AS, ({LIMIT}, {LIMIT}))\n" + body
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-400:]
    return run.stdout


def one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err and "internal error" not in err, err
    return lines[0]


def two_page_tiff(path: Path) -> None:
    """Page 0 is 1x1, page 1 is 3000x3000 (9 Mpixels; compressed, the file is small)."""
    small = Image.new("RGB", (1, 1), (255, 0, 0))
    big = Image.new("RGB", (3000, 3000), (0, 0, 255))
    small.save(path, "TIFF", save_all=True, append_images=[big], compression="tiff_deflate")


def test_every_page_of_a_tiff_is_checked(tmp_path):
    """17.1: the limit applies to the page decoded, not to page 0."""
    tiff = tmp_path / "pages.tif"
    two_page_tiff(tiff)
    with pytest.raises(InputError, match="3000x3000 is 9000000 pixels, over the limit of 100"):
        load_image(tiff, frame=1, max_pixels=100)
    assert load_image(tiff, frame=0, max_pixels=100).shape == (1, 1, 4)
    for frames in ("1", "all"):  # with all, page 1 fails: no page is written (all or none, issue 35)
        run = run_limited("convert", str(tiff), "-o", str(tmp_path / "x.svg"), "--frames", frames)
        assert run.returncode == 1
        assert "over the limit of 1048576" in one_line(run.stderr) and "--max-pixels" in run.stderr
    assert [p.name for p in tmp_path.glob("x*.svg")] == []


def test_diff_is_bounded(tmp_path):
    """17.4: a huge --scale, and an SVG declaring 32000x32000, are refused before rendering."""
    small = tmp_path / "a.svg"
    small.write_text(depixel.convert(np.zeros((10, 10, 3), np.uint8), stage="cells"))
    run = run_limited("diff", str(small), str(small), "--scale", "1200")
    assert run.returncode == 2
    assert "over the limit" in one_line(run.stderr) and "--max-pixels" in run.stderr
    huge = tmp_path / "huge.svg"
    huge.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="32000" height="32000"/>')
    run = run_limited("diff", str(huge), str(huge))
    assert run.returncode == 2 and "32000x32000" in one_line(run.stderr)
    # a PNG input too: it loads under the same limit
    big_png = tmp_path / "big.png"
    Image.new("RGB", (5000, 4000)).save(big_png)
    run = run_limited("diff", str(big_png), str(big_png))
    assert run.returncode == 2 and "20000000 pixels" in one_line(run.stderr)


def test_compressed_svg_bomb_is_refused(tmp_path):
    """17.5: the size bound applies after decompression, while decompressing."""
    bomb = tmp_path / "bomb.svgz"
    body = b'<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><!--' + b" " * (300 * 2**20)
    bomb.write_bytes(gzip.compress(body + b"--></svg>", compresslevel=1))
    assert bomb.stat().st_size < 2 * 2**20
    run = run_limited("render", str(bomb), "-o", str(tmp_path / "bomb.png"))
    assert run.returncode == 1 and "once decompressed" in one_line(run.stderr)
    assert not (tmp_path / "bomb.png").exists()
    # an ordinary .svgz renders
    ok = tmp_path / "ok.svgz"
    ok.write_bytes(gzip.compress(depixel.convert(api.load(FIXTURES / "heart.png"), stage="cells").encode()))
    assert main(["render", str(ok), "-o", str(tmp_path / "ok.png")]) == Exit.OK


@pytest.mark.parametrize("argv,fragment", [
    (["inspect", "{big}", "-o", "{out}/i.png", "--zoom", "64"], "7 panels of 32768x32768"),
    (["convert", "{heart}", "-o", "{out}/f.png", "--shading", "flat", "--scale", "3000"], "heart.png: a 30000x30000"),
    (["convert", "{heart}", "-o", "{out}/s.png", "--scale", "3000"], "heart.png: a 30000x30000"),
    (["render", "{svg}", "-o", "{out}/r.png", "--width", "100000"], "heart.svg: a 100000x100000"),
])
def test_rendered_outputs_are_bounded(tmp_path, argv, fragment):
    """17.6: every raster output is checked before it is allocated, naming the file."""
    big = tmp_path / "big.png"
    Image.fromarray(np.random.default_rng(0).integers(0, 2, (512, 512), dtype=np.uint8) * 255).save(big)
    svg = tmp_path / "heart.svg"
    svg.write_text(depixel.convert(api.load(FIXTURES / "heart.png"), stage="cells"))
    args = [a.format(big=big, heart=FIXTURES / "heart.png", svg=svg, out=tmp_path) for a in argv]
    run = run_limited(*args)
    line = one_line(run.stderr)
    assert run.returncode == 1 and "over the limit" in line and "--max-output-pixels" in line
    assert fragment in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.png", "heart.svg"]


def test_arrays_have_a_pixel_limit():
    """17.9: depixel.convert of a 5000x5000 array is refused before any copy (it took 24 GB)."""
    code = (f"import resource; resource.setrlimit(resource.RLIMIT_AS, ({LIMIT}, {LIMIT})); "
            "import numpy as np, depixel\n"
            "a = np.zeros((5000, 5000), np.uint8)\n"
            "try:\n    depixel.convert(a)\nexcept depixel.InputError as e:\n    print(e.parameter, e)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.stdout.startswith("max_pixels <image>: 5000x5000 is 25000000 pixels, over the limit"), run.stderr
    assert depixel.convert(np.zeros((5000, 5000), np.uint8)[:10, :10]).startswith("<?xml")


@pytest.mark.parametrize("change,match", [
    ({"sparse_window": 0}, "sparse_window must be between 2 and 64"),
    ({"seed": 0}, "seed no longer does anything"),
    ({"candidates": 8}, "candidates no longer does anything"),
    ({"threshold_y": float("nan")}, "threshold_y must be a finite number"),
    ({"iterations": 2.5}, "iterations must be an integer"),
    ({"curve_weight": "1"}, "curve_weight must be a number"),
    ({"tie_break": 1}, "tie_break must be True or False"),
])
def test_params_validate_themselves(change, match):
    """17.9: Params checks itself on construction and on replace, naming the field."""
    name = next(iter(change))
    with pytest.raises(ParameterError, match=match) as info:
        depixel.Params().replace(**change)
    assert info.value.parameter == name
    with pytest.raises(ParameterError, match=match):
        depixel.Params(**change)
    assert depixel.Params(iterations=3.0).iterations == 3 and isinstance(depixel.Params(iterations=3.0).iterations, int)


def test_pdf_is_byte_identical_and_dated_reproducibly(tmp_path, monkeypatch):
    """17.10: the creation date is fixed (or SOURCE_DATE_EPOCH), so runs give the same bytes."""
    from depixel.render.raster import render

    svg = depixel.convert(api.load(FIXTURES / "heart.png"), stage="cells")
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    fixed = render(svg, "pdf")
    assert b"/CreationDate (19700101000000Z)" in fixed or b"/CreationDate (D:19700101000000Z)" in fixed
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")  # 2023-11-14 22:13:20 UTC
    dated = render(svg, "pdf")
    assert b"20231114221320Z)" in dated
    # two whole runs of the command: the same bytes
    outs = [tmp_path / f"h{i}.pdf" for i in range(2)]
    for out in outs:
        subprocess.run([sys.executable, "-m", "depixel", "convert", str(FIXTURES / "heart.png"), "-o", str(out)],
                       check=True, timeout=120)
    assert outs[0].read_bytes() == outs[1].read_bytes()


def test_new_files_follow_the_umask(tmp_path):
    """17.7: umask 077 gives 0600 (it was always 0644)."""

    def mode_under(mask: int, path) -> int:
        old = os.umask(mask)
        try:
            write_atomic(path, "x")
        finally:
            os.umask(old)
        return stat.S_IMODE(path.stat().st_mode)

    assert mode_under(0o077, tmp_path / "private.svg") == 0o600
    assert mode_under(0o022, tmp_path / "public.svg") == 0o644


def test_over_long_names_are_one_line(tmp_path, capsys):
    """17.8: -o with 260 characters, and --frames all of a long GIF name."""
    long_name = tmp_path / ("a" * 260 + ".svg")
    assert main(["convert", str(FIXTURES / "heart.png"), "-o", str(long_name)]) == Exit.FAILED
    assert "cannot write (File name too long)" in one_line(capsys.readouterr().err)
    gif = tmp_path / ("b" * 250 + ".gif")
    gif.write_bytes((FIXTURES / "heart_beat.gif").read_bytes())
    assert main(["convert", str(gif), "--out-dir", str(tmp_path / "out"), "--frames", "all"]) == Exit.FAILED
    assert "File name too long" in one_line(drop_summary(capsys.readouterr().err))
    with pytest.raises(OutputError, match="File name too long"):
        depixel.convert_file(FIXTURES / "heart.png", long_name)


def test_frames_all_reads_the_file_once(tmp_path, monkeypatch):
    """17.12: every frame decoded once, in order, from one read of the file."""
    from depixel.options import ConvertOptions
    from depixel.prepare import image
    from depixel_cli.convert.batch import Job, Options, run_job

    frames = [Image.new("RGB", (8, 8), (8 * i, 255 - 8 * i, 0)) for i in range(30)]
    gif = tmp_path / "many.gif"
    frames[0].save(gif, save_all=True, append_images=frames[1:], duration=50)
    reads = []
    original = image.read_source
    monkeypatch.setattr(image, "read_source", lambda source: reads.append(source) or original(source))
    options = Options(ConvertOptions.build(stage="cells", max_pixels=None), ("svg",), "all", force=False)
    (tmp_path / "out").mkdir()
    outcome = run_job(Job(gif, tmp_path / "out" / "many.svg", options, 30))
    assert outcome.error is None and len(outcome.written) == 30
    assert len(reads) == 1  # it was one read (and one decode from frame 0) per frame
    assert [i for i, _ in image.load_frames(gif)] == list(range(30))


def test_auto_jobs_fit_the_memory(tmp_path):
    """17 (memory-aware -j auto): the largest pending image decides how many workers fit."""
    from depixel.limits import PEAK_BYTES_PER_PIXEL, WORKER_BASELINE_BYTES
    from depixel_cli.convert import batch
    from depixel_cli.convert import run as batch_run

    big = tmp_path / "big.png"
    Image.new("RGB", (1000, 1000)).save(big)
    jobs = [batch.Job(big, tmp_path / "a.svg", None)] + [batch.Job(FIXTURES / "heart.png", tmp_path / f"{i}.svg", None)
                                                           for i in range(7)]
    per_worker = WORKER_BASELINE_BYTES + PEAK_BYTES_PER_PIXEL * 1_000_000
    cores = min(batch_run.cores(), 8)
    count, note = batch_run.auto_jobs(jobs, memory=per_worker * 100)
    assert count == cores and note is None
    count, note = batch_run.auto_jobs(jobs, memory=int(per_worker * 1.5))
    assert count == 1 or cores == 1
    if cores > 1:
        assert "big.png (1000000 pixels)" in note and "-j auto: 1 worker, not" in note


def test_out_dir_that_is_a_file_is_one_error(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    with pytest.raises(SystemExit) as info:
        main(["convert", str(FIXTURES / "heart.png"), str(FIXTURES / "leaf.png"), "--out-dir", str(tmp_path / "file")])
    assert info.value.code == Exit.USAGE
    assert "is a file, not a folder" in one_line(capsys.readouterr().err)


@pytest.mark.parametrize("kind", ["checkerboard", "noise"])
def test_peak_memory_per_pixel(kind):
    """17.11: one conversion's peak RSS above the import baseline stays within
    PEAK_BYTES_PER_PIXEL a pixel (plus the fixed-size batches of the crossings, outlines and
    path text), on the worst inputs: a checkerboard (every pixel its own shape, every block
    a crossing) and RGB noise. It took 8.4 KB a pixel on a checkerboard, then 2.5 KB."""
    from depixel.limits import PEAK_BYTES_PER_PIXEL

    size = 192
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, ({limit}, {limit}))\n"
            "import numpy as np, depixel\n"
            "size = {size}\n"
            "if '{kind}' == 'checkerboard':\n"
            "    image = (np.indices((size, size)).sum(axis=0) % 2 * 255).astype(np.uint8)\n"
            "else:\n"
            "    image = np.random.default_rng(0).integers(0, 256, (size, size, 3), dtype=np.uint8)\n"
            "base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
            "depixel.convert(image)\n"
            "print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) * 1024)\n"
            ).format(limit=2 * LIMIT, size=size, kind=kind)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    grown = int(run.stdout)
    assert grown <= PEAK_BYTES_PER_PIXEL * size * size + 24 * 2**20, f"{grown / size**2:.0f} bytes a pixel"


def test_holes_with_transparent_pixels_cost_linear_memory():
    """17.11 (found while measuring): the stacked layout's hole test was quadratic in the
    holes × transparent faces (a loops × faces table): a lattice of 3x3 rings with
    transparent centres took 32 KB a pixel (4.8 GB) at 384x384. Converted here under the
    address-space cap of the other limited tests."""
    paths = python_limited("import numpy as np, depixel\n"
                           "tile = np.zeros((3, 3, 4), np.uint8)\n"
                           "tile[..., 0], tile[..., 3], tile[1, 1, 3] = 200, 255, 0\n"
                           "svg = depixel.convert(np.tile(tile, (96, 96, 1)))\n"
                           "print(svg.count('<path'))\n")
    assert int(paths) >= 1


def test_images_beyond_32_bit_indices_are_refused():
    """The pipeline indexes in 32 bits: an image it cannot address is refused with one line,
    even with the pixel limit lifted, before anything is copied (a broadcast view costs
    nothing). Under the address-space cap: without the check the conversion runs out of it."""
    lines = python_limited(
        "import numpy as np, depixel\n"
        "from PIL import Image\n"
        "from depixel.errors import InputError\n"
        "from depixel.limits import MAX_INDEXED_PIXELS\n"
        "side = int(MAX_INDEXED_PIXELS**0.5) + 1\n"
        "huge = np.broadcast_to(np.zeros((1, 1, 4), np.uint8), (side, side, 4))\n"
        "for call in (lambda: depixel.convert(huge, max_pixels=None), lambda: depixel.depixelize(huge),\n"
        "             lambda: depixel.depixelize(Image.new('1', (side, side)))):\n"
        "    try:\n"
        "        call()\n"
        "    except InputError as error:\n"
        "        print(error)\n").splitlines()
    assert len(lines) == 3 and all("32-bit indices can address" in line for line in lines), lines


@pytest.mark.parametrize("width, height", [(12, 10), (120, 1), (1, 120)])
def test_the_pixel_limit_accepts_an_image_of_exactly_the_limit_and_refuses_one_more(width, height, tmp_path):
    """max_pixels is inclusive: width × height == max_pixels converts, one pixel more is
    refused (file, array and command line)."""
    limit = width * height
    exact = np.zeros((height, width, 4), np.uint8)
    exact[..., 3] = 255
    over = np.zeros((height, width + 1, 4), np.uint8)
    path, bigger = tmp_path / "exact.png", tmp_path / "over.png"
    Image.fromarray(exact).save(path)
    Image.fromarray(over).save(bigger)
    assert load_image(path, max_pixels=limit).shape == (height, width, 4)
    assert depixel.convert(exact, max_pixels=limit).startswith("<?xml")
    assert main(["convert", str(path), "-o", str(tmp_path / "exact.svg"), "--max-pixels", str(limit)]) == 0
    with pytest.raises(InputError, match="over the limit"):
        load_image(bigger, max_pixels=limit)
    with pytest.raises(InputError, match="over the limit"):
        depixel.convert(over, max_pixels=limit)
    assert main(["convert", str(bigger), "-o", str(tmp_path / "over.svg"), "--max-pixels", str(limit)]) != 0
    assert not (tmp_path / "over.svg").exists()
