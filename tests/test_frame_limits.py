"""Animations: their total work bounded before it is spent, their frames written all or
none (issue 35, finding 1).

The 131-byte APNG of the finding (4 × 4 RGB, one frame's data, ``acTL`` declaring 2³¹ − 1
frames) ran past 20 s and 1 GB with ``--frames all``; it is refused from its header, here
under a 1 GiB address-space limit.
"""
from __future__ import annotations

import struct
import subprocess
import sys
import zlib
from pathlib import Path

import pytest
from conftest import drop_summary
from PIL import Image

from depixel.errors import InputError
from depixel.files import convert as files
from depixel.prepare.image import frame_count, load_frames, load_image
from depixel_cli.main import main
from depixel_cli.options import Exit

LIMIT = 1 << 30


def chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def declared_apng(frames: int = 2**31 - 1) -> bytes:
    """4 × 4 RGB with the data of one frame, whose ``acTL`` declares ``frames`` frames."""
    raw = b"".join(b"\0" + bytes([200, 30, 30] * 4) for _ in range(4))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 4, 4, 8, 2, 0, 0, 0))
            + chunk(b"acTL", struct.pack(">II", frames, 0))
            + chunk(b"fcTL", struct.pack(">IIIIIHHBB", 0, 4, 4, 0, 0, 1, 10, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def run_limited(*argv: str, stdin: bytes | None = None) -> subprocess.CompletedProcess:
    """``depixel ARGV`` with its address space capped at 1 GiB."""
    code = (f"import resource, sys; resource.setrlimit(resource.RLIMIT_AS, ({LIMIT}, {LIMIT})); "
            f"from depixel_cli.main import main; sys.exit(main({list(argv)!r}))")
    return subprocess.run([sys.executable, "-c", code], input=stdin, capture_output=True, timeout=120)


def gif(path: Path, frames: int, side: int) -> None:
    images = [Image.new("RGB", (side, side), (40 * i, 200 - 40 * i, 90)) for i in range(frames)]
    for i, image in enumerate(images):
        image.putpixel((i, i), (255, 255, 255))
    images[0].save(path, save_all=True, append_images=images[1:], duration=100)


def test_the_declared_apng_is_131_bytes_and_declares_what_it_says(tmp_path):
    path = tmp_path / "bomb.png"
    path.write_bytes(declared_apng())
    assert len(declared_apng()) == 131
    with Image.open(path) as img:
        assert img.n_frames == 2**31 - 1 and img.size == (4, 4)


@pytest.mark.parametrize("how", ["out-dir", "-o", "stdin"])
def test_an_apng_declaring_2_31_frames_is_refused_from_its_header(tmp_path, how):
    path = tmp_path / "bomb.png"
    path.write_bytes(declared_apng())
    out = tmp_path / "out"
    argv = {"out-dir": ["convert", str(path), "--out-dir", str(out)],
            "-o": ["convert", str(path), "-o", str(out / "x.svg")],
            "stdin": ["convert", "-", "-o", str(out / "x.svg")]}[how]
    out.mkdir()
    run = run_limited(*argv, "--frames", "all", stdin=path.read_bytes() if how == "stdin" else None)
    err = run.stderr.decode()
    assert run.returncode == 1, err
    lines = (drop_summary(err) if how == "out-dir" else err).strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "declares 2147483647 frames, over the limit of 5000 (raise it with --max-frames)" in lines[0]
    assert list(out.iterdir()) == []


def test_the_library_refuses_before_decoding(tmp_path):
    data = declared_apng()
    with pytest.raises(InputError, match="declares 2147483647 frames, over the limit of 5000"):
        next(load_frames(data))
    with pytest.raises(InputError, match="declares 2147483647 frames"):
        frame_count(data, max_frames=5000)
    # counting alone is free: the frames the file holds (depixel's APNG reader walks the chunks;
    # Pillow's n_frames is what acTL declares)
    assert frame_count(data) == 1
    with pytest.raises(InputError, match="frame 6000 is past the limit of 5000 frames"):
        load_image(data, frame=6000)
    assert load_image(data, frame=0).shape == (4, 4, 4)  # the first frame is still a 4 x 4 image


def test_the_pixel_limit_counts_every_frame(tmp_path, capsys):
    """Three 20 × 20 frames are 1200 pixels: over --max-pixels 1000 although each frame is
    400; --max-frames 2 refuses them too; raised, they convert."""
    anim = tmp_path / "anim.gif"
    gif(anim, 3, 20)
    argv = ["convert", str(anim), "-o", str(tmp_path / "a.svg"), "--frames", "all", "--stage", "cells"]
    assert main(argv + ["--max-pixels", "1000"]) == Exit.FAILED
    err = capsys.readouterr().err
    assert "3 frames are 1200 pixels in all, over the limit of 1000" in err and "--max-pixels" in err
    assert main(argv + ["--max-frames", "2"]) == Exit.FAILED
    assert "declares 3 frames, over the limit of 2 (raise it with --max-frames)" in capsys.readouterr().err
    assert not list(tmp_path.glob("a*.svg"))
    assert main(argv + ["--max-pixels", "1200", "--max-frames", "3"]) == Exit.OK
    assert sorted(p.name for p in tmp_path.glob("a*.svg")) == ["a-000.svg", "a-001.svg", "a-002.svg"]


def test_the_output_pixel_limit_counts_every_png_frame(tmp_path, capsys):
    """Three 20 × 20 frames at --scale 2 are three 40 × 40 PNGs, 4800 pixels: over
    --max-output-pixels 4000 although each is 1600."""
    anim = tmp_path / "anim.gif"
    gif(anim, 3, 20)
    argv = ["convert", str(anim), "-o", str(tmp_path / "a.png"), "--frames", "all", "--stage", "cells",
            "--scale", "2", "--shading", "flat"]
    assert main(argv + ["--max-output-pixels", "4000"]) == Exit.FAILED
    err = capsys.readouterr().err
    assert "3 PNG frames are 4800 pixels in all, over the limit of 4000" in err and "--max-output-pixels" in err
    assert not list(tmp_path.glob("a*.png"))
    assert main(argv + ["--max-output-pixels", "4800"]) == Exit.OK
    assert len(list(tmp_path.glob("a-*.png"))) == 3


def test_a_failure_in_frame_k_leaves_no_partial_frame_set(tmp_path, monkeypatch, capsys):
    """Frame 1 of 3 fails: no new frame is written (not frame 0 either), no temporary file
    is left, and the frame set of an earlier run stays whole."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    gif(src / "anim.gif", 3, 12)
    argv = ["convert", str(src), "--out-dir", str(out), "--frames", "all", "--stage", "cells", "-j", "1"]
    assert main(argv) == Exit.OK
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(before) == ["anim-000.svg", "anim-001.svg", "anim-002.svg"]
    gif(src / "anim.gif", 3, 14)  # a new version of the animation
    real, calls = files.conversions, []

    def fails_on_frame_1(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise InputError("anim.gif: frame 1 is broken")
        return real(*args, **kwargs)

    monkeypatch.setattr(files, "conversions", fails_on_frame_1)
    assert main(argv) == Exit.FAILED
    assert "frame 1 is broken" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # old set whole, no .tmp
    monkeypatch.undo()
    assert main(argv) == Exit.OK
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(after) == sorted(before) and all(after[n] != before[n] for n in after)


def test_the_frame_limit_is_a_flag_of_convert():
    from depixel_cli.main import build_parser

    args = build_parser("convert").parse_args(["convert", "x.png", "-o", "x.svg"])
    assert args.max_frames == 5000
    assert build_parser("convert").parse_args(["convert", "x.png", "-o", "x.svg", "--max-frames", "7"]).max_frames == 7


@pytest.mark.skipif(not hasattr(__import__("signal"), "pthread_sigmask"), reason="no signal masks")
def test_a_ctrl_c_during_the_renames_comes_after_the_last_frame(tmp_path, monkeypatch):
    """A real SIGINT sent while the first of three frames is renamed into place is held
    until the third is in place: the set is whole, then KeyboardInterrupt."""
    import os
    import signal

    from depixel.files import output

    staged = [output.stage(tmp_path / f"f-{i}.svg", f"<svg>{i}</svg>") for i in range(3)]
    real, renamed = os.replace, []

    def replace(src, dst):
        if not renamed:
            os.kill(os.getpid(), signal.SIGINT)
        real(src, dst)
        renamed.append(Path(dst).name)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        output.commit([s for s in staged if s is not None])
    assert renamed == ["f-0.svg", "f-1.svg", "f-2.svg"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f-0.svg", "f-1.svg", "f-2.svg"]
