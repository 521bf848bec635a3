"""Hostile and broken inputs and outputs, through the library and through the command line.

Every case must give one clear line naming the file, the right exit code, no traceback,
no output file (not even a partial or temporary one), and never touch the input.
"""
from __future__ import annotations

import errno
import io
import os
import stat
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from conftest import FIXTURES
from robust import STAGE, convert, parse, png_bytes, png_chunk

import depixel
from depixel.errors import InputError, OutputError, ParameterError
from depixel.files.output import write_atomic
from depixel.prepare.image import load_image


def _permissions_enforced() -> bool:
    """False for root (or any process that may override file permissions)."""
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / "probe"
        probe.write_bytes(b"x")
        probe.chmod(0)
        try:
            probe.read_bytes()
        except PermissionError:
            return True
        return False


needs_non_root = pytest.mark.skipif(not _permissions_enforced(), reason="running as root: permissions not enforced")
SPRITE = FIXTURES / "potion_rgba.png"


def _corrupt_idat() -> bytes:
    header = png_bytes(4, 4, 8, 2, bytes(48))
    at = header.index(b"IDAT") - 4
    return header[:at] + png_chunk(b"IDAT", b"this is not zlib data") + png_chunk(b"IEND", b"")


def _tiff(corrupt: bool) -> bytes:
    """An LZW TIFF, cut in half or with its compressed strip (right after the header) garbled:
    libtiff prints to file descriptor 2 itself and Pillow warns, which must not show."""
    from PIL import Image

    buf = io.BytesIO()
    Image.open(SPRITE).save(buf, "TIFF", compression="tiff_lzw")
    data = bytearray(buf.getvalue())
    if not corrupt:
        return bytes(data[: len(data) // 2])
    data[20:60] = bytes(b ^ 0x55 for b in data[20:60])
    return bytes(data)


# name: (file content, or None for no file, or "dir"; the message fragment the user sees)
BAD_INPUTS = {
    "text-named-png": (b"just some notes, not a picture\n", "not an image"),
    "truncated-png": (SPRITE.read_bytes()[:100], "truncated or corrupt image data"),
    "corrupt-idat": (_corrupt_idat(), "truncated or corrupt image data"),
    "corrupt-tiff": (_tiff(corrupt=True), "truncated or corrupt image data"),
    "truncated-tiff": (_tiff(corrupt=False), "not an image"),
    "empty-file": (b"", "empty file"),
    "random-bytes": (bytes(np.random.default_rng(5).integers(0, 256, 400, dtype=np.uint8)), "not an image"),
    "zero-width": (png_bytes(0, 5, 8, 2), "not an image"),
    "missing": (None, "no such file"),
    "directory": ("dir", "is a directory"),
    # a 65-byte PNG whose header claims 100000 x 100000 pixels (30 GB decoded)
    "decompression-bomb": (png_bytes(100_000, 100_000, 8, 2), "decompression bomb guard"),
    # over Pillow's MAX_IMAGE_PIXELS (~89 M) but under twice it, where Pillow only warns
    "decompression-bomb-warning": (png_bytes(10_000, 10_000, 8, 2), "decompression bomb guard"),
    "over-max-pixels": (png_bytes(3000, 3000, 8, 2), "9000000 pixels, over the limit of 1048576"),
    "absurd-strip": (png_bytes(1, 2_000_000, 8, 0), "over the limit"),
}


def make_input(tmp_path: Path, case: str) -> Path:
    content, _ = BAD_INPUTS[case]
    path = tmp_path / f"{case}.png"
    if content == "dir":
        path.mkdir()
    elif content is not None:
        path.write_bytes(content)
    return path


def files_in(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_input_gives_one_line_input_error(case, tmp_path):
    path = make_input(tmp_path, case)
    with pytest.raises(InputError) as info:
        load_image(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and BAD_INPUTS[case][1] in message
    assert "\n" not in message


def test_bad_bytes_and_file_objects_are_named_as_such():
    with pytest.raises(InputError, match=r"^<bytes>: not an image"):
        load_image(b"GIF89a")
    with open(os.devnull, "rb") as fh, pytest.raises(InputError, match=r"^<stdin>: empty file$"):
        load_image(fh)
    with pytest.raises(InputError, match=r"^<bytes>: empty file$"):
        load_image(bytearray())
    with pytest.raises(TypeError, match="expected a path, bytes or a binary file object"):
        load_image(np.zeros((2, 2, 4)))  # an array is an image already: depixelize takes it


def test_device_is_refused_without_reading_it():
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    with pytest.raises(InputError, match="is a device"):
        load_image("/dev/zero")


def test_path_with_nul_byte():
    with pytest.raises(InputError, match="cannot read"):
        load_image("bad\0name.png")


def test_file_over_the_byte_limit_is_refused_before_decoding(tmp_path, monkeypatch):
    import depixel.prepare.image

    monkeypatch.setattr(depixel.prepare.image, "MAX_FILE_BYTES", 100)
    path = tmp_path / "big.png"
    path.write_bytes(SPRITE.read_bytes())
    with pytest.raises(InputError, match="too large for pixel art"):
        load_image(path)


def test_bad_frame_numbers():
    with pytest.raises(InputError, match="has 2 frame"):
        load_image(FIXTURES / "heart_beat.gif", frame=2)
    with pytest.raises(ParameterError, match="frame must be at least 0"):
        load_image(FIXTURES / "heart_beat.gif", frame=-1)


def test_hostile_file_name_stays_on_one_line(tmp_path):
    path = tmp_path / "two\nlines\x1b[31m.png"
    with pytest.raises(InputError) as info:
        load_image(path)
    assert "\n" not in str(info.value) and "\x1b" not in str(info.value)
    assert "two\\nlines\\x1b[31m.png: no such file" in str(info.value)


def test_bad_arrays_are_input_errors():
    for bad in (np.zeros((0, 3, 4)), np.zeros((2, 2, 5)), np.zeros((2, 2, 2, 2)), np.array([["a"]])):
        with pytest.raises(InputError):
            depixel.depixelize(bad, stage=STAGE)


@needs_non_root
def test_unreadable_file(tmp_path):
    path = tmp_path / "secret.png"
    path.write_bytes(SPRITE.read_bytes())
    path.chmod(0)
    with pytest.raises(InputError, match=r"secret\.png: permission denied$"):
        load_image(path)


# --- output -----------------------------------------------------------------------------


def test_missing_output_folder(tmp_path):
    with pytest.raises(OutputError, match="output folder .*nowhere does not exist"):
        write_atomic(tmp_path / "nowhere" / "out.svg", "<svg/>")
    assert files_in(tmp_path) == set()


def test_output_inside_a_file(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="parent of it is a file"):
        write_atomic(tmp_path / "file" / "out.svg", "<svg/>")


def test_output_is_a_directory(tmp_path):
    (tmp_path / "out.svg").mkdir()
    with pytest.raises(OutputError, match=r"out\.svg: is a directory"):
        write_atomic(tmp_path / "out.svg", "<svg/>")


@pytest.mark.parametrize("how", ["same path", "relative path", "symlink", "hard link"])
def test_output_equal_to_input_is_refused(tmp_path, monkeypatch, how):
    source = tmp_path / "sprite.png"
    source.write_bytes(SPRITE.read_bytes())
    target = {"same path": source, "relative path": Path("sprite.png"),
              "symlink": tmp_path / "link.png", "hard link": tmp_path / "hard.png"}[how]
    monkeypatch.chdir(tmp_path)
    if how == "symlink":
        target.symlink_to(source)
    elif how == "hard link":
        os.link(source, target)
    with pytest.raises(OutputError, match="is the input file; refusing to overwrite it"):
        write_atomic(target, "<svg/>", protect=(source,))
    assert source.read_bytes() == SPRITE.read_bytes()


@needs_non_root
def test_read_only_output_folder(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.raises(OutputError, match="permission denied"):
            write_atomic(folder / "out.svg", "<svg/>")
        assert files_in(folder) == set()
    finally:
        folder.chmod(stat.S_IRWXU)


@needs_non_root
def test_read_only_output_file(tmp_path):
    target = tmp_path / "out.svg"
    target.write_text("old")
    target.chmod(stat.S_IRUSR)
    with pytest.raises(OutputError, match="file is read-only"):
        write_atomic(target, "<svg/>")
    assert target.read_text() == "old"


def test_unwritable_folder_error_is_reported(tmp_path, monkeypatch):
    # what a read-only folder does for a normal user, also checked when running as root
    real_open = os.open

    def refuse(path, flags, *args, **kwargs):  # creating a file in the folder is refused
        if flags & os.O_CREAT:
            raise PermissionError(errno.EACCES, "Permission denied")
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    with pytest.raises(OutputError, match=r"out\.svg: permission denied"):
        write_atomic(tmp_path / "out.svg", "<svg/>")


@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()])
def test_failure_while_writing_leaves_no_partial_file(tmp_path, monkeypatch, failure):
    target = tmp_path / "out.svg"
    target.write_text("previous result")

    def fail(*args, **kwargs):
        raise failure

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OutputError if isinstance(failure, OSError) else KeyboardInterrupt):
        write_atomic(target, "<svg>new</svg>")
    assert files_in(tmp_path) == {"out.svg"}  # the temporary file is gone
    assert target.read_text() == "previous result"


def test_symlinked_output_keeps_the_link(tmp_path):
    real = tmp_path / "real.svg"
    real.write_text("old")
    link = tmp_path / "link.svg"
    link.symlink_to(real)
    write_atomic(link, "new")
    assert link.is_symlink() and real.read_text() == "new"


def test_existing_output_keeps_its_permissions(tmp_path):
    target = tmp_path / "out.svg"
    target.write_text("old")
    target.chmod(0o640)
    write_atomic(target, "new")
    assert stat.S_IMODE(target.stat().st_mode) == 0o640 and target.read_text() == "new"


def test_devices_are_written_in_place_not_replaced():
    if not os.path.exists(os.devnull):
        pytest.skip("no /dev/null")
    write_atomic(os.devnull, "<svg/>")
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


# --- SVG safety -----------------------------------------------------------------------------

# file name → the <title> a parser reads back (characters XML forbids become U+FFFD)
NASTY_NAMES = {
    'a<b>&"c".png': 'a<b>&"c".png',
    "x]]><!--y-->.png": "x]]><!--y-->.png",
    "ctl\x01\x7f.png": "ctl\ufffd\x7f.png",
    "bad\udcff.png": "bad\ufffd.png",
    "tab\tand\nline.png": "tab\tand\nline.png",
}


@pytest.mark.parametrize("name", sorted(NASTY_NAMES))
def test_nasty_title_is_escaped(name):
    svg = convert(load_image(SPRITE), title=name)
    svg.encode("utf-8")  # no lone surrogate survives
    assert parse(svg).find("{http://www.w3.org/2000/svg}title").text == NASTY_NAMES[name]


# --- the same through the command line ----------------------------------------------------

def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    from depixel_cli.main import main

    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_clean_line(err: str, *fragments: str) -> None:
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1, err
    assert lines[0].startswith("depixel") and "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], err


# cases where the command line answers differently from the library: (exit code, fragment)
CLI_ANSWERS = {"directory": (2, "no images in this folder")}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_cli_bad_input(case, tmp_path, capfd):
    # capfd, not capsys: what C libraries print on file descriptor 2 counts too
    path = make_input(tmp_path, case)
    out = tmp_path / "out" / "result.svg"
    out.parent.mkdir()
    code, stdout, err = run_cli(capfd, "convert", str(path), "-o", str(out), "--stage", STAGE)
    want_code, fragment = CLI_ANSWERS.get(case, (1, BAD_INPUTS[case][1]))
    assert code == want_code
    assert_one_clean_line(err, path.name, fragment)
    assert files_in(out.parent) == set() and stdout == ""


@needs_non_root
def test_cli_unreadable_input(tmp_path, capsys):
    path = tmp_path / "secret.png"
    path.write_bytes(SPRITE.read_bytes())
    path.chmod(0)
    code, _, err = run_cli(capsys, "convert", str(path), "-o", str(tmp_path / "out.svg"))
    assert code == 1
    assert_one_clean_line(err, "secret.png", "permission denied")
    assert not (tmp_path / "out.svg").exists()


def test_cli_missing_output_folder(tmp_path, capsys):
    code, _, err = run_cli(capsys, "convert", str(SPRITE), "-o", str(tmp_path / "nowhere" / "out.svg"),
                           "--stage", STAGE)
    assert code == 1
    assert_one_clean_line(err, "out.svg", "does not exist")
    assert files_in(tmp_path) == set()


@needs_non_root
def test_cli_read_only_output_folder(tmp_path, capsys):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        code, _, err = run_cli(capsys, "convert", str(SPRITE), "-o", str(folder / "out.svg"), "--stage", STAGE)
        assert code == 1
        assert_one_clean_line(err, "out.svg", "permission denied")
        assert files_in(folder) == set()
    finally:
        folder.chmod(stat.S_IRWXU)


def test_cli_output_is_a_folder(tmp_path, capsys):
    (tmp_path / "out.svg").mkdir()
    code, _, err = run_cli(capsys, "convert", str(SPRITE), "-o", str(tmp_path / "out.svg"), "--stage", STAGE)
    assert code == 1
    assert_one_clean_line(err, "out.svg", "is a directory")


@pytest.mark.parametrize("how", ["same path", "symlink"])
def test_cli_output_equal_to_input(tmp_path, capsys, how):
    source = tmp_path / "sprite.svg"  # an image with an .svg name, so -o can name it
    source.write_bytes(SPRITE.read_bytes())
    target = source if how == "same path" else tmp_path / "link.svg"
    if how == "symlink":
        target.symlink_to(source)
    code, _, err = run_cli(capsys, "convert", str(source), "-o", str(target), "--stage", STAGE)
    assert code == 1
    assert_one_clean_line(err, "refusing to overwrite")
    assert source.read_bytes() == SPRITE.read_bytes()
    assert files_in(tmp_path) == ({"sprite.svg"} if how == "same path" else {"sprite.svg", "link.svg"})


def test_cli_nasty_file_name_is_escaped_in_the_svg(tmp_path, capsys):
    name = 'a<b>&"c".png'
    source = tmp_path / name
    source.write_bytes(SPRITE.read_bytes())
    code, _, err = run_cli(capsys, "convert", str(source), "-o", str(tmp_path / "out.svg"), "--stage", STAGE)
    assert code == 0, err
    root = parse((tmp_path / "out.svg").read_text(encoding="utf-8"))
    assert root.find("{http://www.w3.org/2000/svg}title").text == name


@pytest.mark.skipif(sys.platform != "linux", reason="Linux file systems take any bytes as a name")
def test_cli_undecodable_file_name(tmp_path, capsys):
    source = Path(os.fsdecode(bytes(tmp_path) + b"/bad\xff.png"))
    source.write_bytes(SPRITE.read_bytes())
    code, _, err = run_cli(capsys, "convert", str(source), "-o", str(tmp_path / "out.svg"), "--stage", STAGE)
    assert code == 0, err
    parse((tmp_path / "out.svg").read_text(encoding="utf-8"))
