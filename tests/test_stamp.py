"""The stamp: the options (the same 16 hex digits whichever SHA-256 implementation computes
them), the input as read and the digest of the body, in SVG, PNG and PDF."""
from __future__ import annotations

import hashlib
import json
import os
import struct
import zlib

import pytest
from conftest import FIXTURES

import depixel
from depixel import api
from depixel.files import stamp as stamps
from depixel.files.stamp import options_stamp
from depixel.options import ConvertOptions


def test_options_stamp_is_the_sha256_of_the_sorted_options():
    options = {"fmt": "svg", "scale": 2.0, "background": (1, 2, 3), "params": {"threshold_y": 48}, "width": None}
    text = json.dumps({"version": depixel.__version__, **options}, sort_keys=True, default=str)
    assert options_stamp(**options) == hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    assert options_stamp(**{**options, "scale": 3.0}) != options_stamp(**options)


# --- the stamp of issue 35: options, the input as read, the body's digest -----------------------

IDENTITY = stamps.Identity(190, -5, "0123456789abcdef")


def blob_of(fmt: str, keywords: str | None = None) -> bytes:
    rgba = api.load(FIXTURES / "heart.png")
    options = ConvertOptions.build(stage="cells", precision=3, simplify=0.0, max_pixels=None, max_output_pixels=None)
    return api.conversions(rgba, {fmt: keywords}, options, name="heart")[fmt]


@pytest.mark.parametrize("fmt", ["svg", "png", "pdf"])
@pytest.mark.parametrize("identity", [IDENTITY, None])
def test_embed_then_parse_round_trips_and_the_body_digest_holds(fmt, identity):
    draft = stamps.text("fedcba9876543210", identity)
    stamped = stamps.embed(blob_of(fmt, draft), fmt, "fedcba9876543210", identity)
    found = stamps.parse(stamped)
    assert found is not None and (found.options, found.identity) == ("fedcba9876543210", identity)
    assert found.body != stamps.ZERO and stamps.intact(stamped)
    # any byte changed outside the stamp breaks it; so does a byte inside the digest itself
    at = len(stamped) // 2 if fmt != "png" else 20  # a PNG: inside IHDR's chunk, not the stamp's
    flipped = stamped[:at] + bytes([stamped[at] ^ 1]) + stamped[at + 1:]
    assert stamps.parse(flipped) == found and not stamps.intact(flipped)
    digest_at = stamped.index(b";body=") + 6
    wrong = stamped[:digest_at] + b"f" * 16 + stamped[digest_at + 16:]
    assert not stamps.intact(wrong)


def test_png_stamp_chunk_is_a_valid_chunk():
    stamped = stamps.embed(blob_of("png"), "png", "fedcba9876543210", IDENTITY)
    at, chunks = 8, []
    while at < len(stamped):
        (length,) = struct.unpack(">I", stamped[at:at + 4])
        kind, data = stamped[at + 4:at + 8], stamped[at + 8:at + 8 + length]
        assert struct.unpack(">I", stamped[at + 8 + length:at + 12 + length])[0] == zlib.crc32(kind + data)
        chunks.append(kind)
        at += 12 + length
    assert chunks[-2:] == [b"tEXt", b"IEND"]


def test_an_old_stamp_is_depixels_but_never_current(tmp_path):
    """A stamp from before issue 35 (options only): never up to date, and whether it was
    edited cannot be told (OLD: kept unless forced, issue 45)."""
    source, output = tmp_path / "a.png", tmp_path / "a.svg"
    source.write_bytes((FIXTURES / "heart.png").read_bytes())
    output.write_text("<?xml version='1.0'?>\n<!-- depixel-options:fedcba9876543210 -->\n<svg/>")
    assert stamps.parse(output.read_bytes()) == stamps.Stamp("fedcba9876543210", None, None)
    assert stamps.status(source, output, "fedcba9876543210") == stamps.OLD


def test_identity_matches_by_mtime_else_by_bytes(tmp_path):
    path = tmp_path / "a.png"
    path.write_bytes(b"one")
    st = path.stat()
    same = stamps.Identity(3, st.st_mtime_ns, stamps.digest(b"one"))
    assert same.matches(path)
    os.utime(path, ns=(1, 1))
    assert same.matches(path)  # the mtime moved, the bytes did not
    path.write_bytes(b"two")
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))  # other bytes behind the same size and mtime
    assert same.matches(path)  # (what make would say too: the mtime is trusted when it agrees)
    os.utime(path, ns=(1, 2))
    assert not same.matches(path)
    assert not same.matches(tmp_path / "missing.png")
