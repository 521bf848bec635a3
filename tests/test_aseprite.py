"""The Aseprite reader (depixel/prepare/aseprite*.py) on files written by tests/aseprite_writer.py,
on real files from Aseprite's own test sprites (fixtures/aseprite/), and on damaged files."""
from __future__ import annotations

import io
import re
import struct
import zlib

import numpy as np
import pytest
from aseprite_writer import (
    GROUPS_APART,
    OPACITY_VALID,
    CelSpec,
    FrameSpec,
    LayerSpec,
    aseprite_bytes,
    old_palette_chunk,
    one_layer,
    palette_chunk,
    rgba_cel,
    slice_chunk,
    tags_chunk,
)
from conftest import FIXTURES, art
from PIL import Image

import depixel
from depixel.errors import InputError
from depixel.prepare.aseprite import read_aseprite
from depixel.prepare.image import frame_count, load_frames, load_image

SPRITE = art("""
_##_
#rr#
#ry#
_##_
""", {"_": (0, 0, 0, 0)})


def random_rgba(seed: int, shape=(6, 5)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rgba = rng.integers(0, 256, shape + (4,)).astype(np.uint8)
    rgba[..., 3] = rng.choice([0, 40, 128, 255], shape)
    return rgba


def reference_normal(backdrop: np.ndarray, src: np.ndarray, opacity: int) -> np.ndarray:
    """Aseprite's rgba_blender_normal pixel by pixel, as the C code reads (the slow reference)."""
    def mul(a: int, b: int) -> int:
        t = a * b + 0x80
        return ((t >> 8) + t) >> 8

    out = backdrop.copy()
    for y in range(src.shape[0]):
        for x in range(src.shape[1]):
            b = [int(v) for v in backdrop[y, x]]
            s = [int(v) for v in src[y, x]]
            if s == [0, 0, 0, 0]:  # the mask colour is not drawn
                continue
            if b[3] == 0:
                out[y, x] = s[:3] + [mul(s[3], opacity)]
                continue
            if s[3] == 0:
                continue
            sa = mul(s[3], opacity)
            ra = sa + b[3] - mul(b[3], sa)
            out[y, x] = [b[c] + int((s[c] - b[c]) * sa / ra) for c in range(3)] + [ra]  # int(): toward zero
    return out


# ---------------------------------------------------------------- colour modes

def test_rgba_frame_is_the_pixels_and_converts_like_the_same_png():
    data = one_layer(SPRITE)
    assert np.array_equal(load_image(data), SPRITE)
    png = io.BytesIO()
    Image.fromarray(SPRITE, "RGBA").save(png, format="PNG")
    assert depixel.convert(load_image(data)) == depixel.convert(load_image(png.getvalue()))


def test_grayscale_is_value_and_alpha():
    grey = np.array([[[0, 0], [90, 255], [200, 128]]], np.uint8)
    data = aseprite_bytes(3, 1, [LayerSpec("g")], [FrameSpec([CelSpec(0, grey)])], depth=16)
    rgba = load_image(data)
    assert rgba.tolist() == [[[0, 0, 0, 0], [90, 90, 90, 255], [200, 200, 200, 128]]]


def test_indexed_uses_the_palette_and_leaves_the_transparent_index_out():
    colours = np.array([[0, 0, 0, 255], [255, 0, 0, 255], [0, 255, 0, 128], [9, 9, 9, 255]], np.uint8)
    index = np.array([[1, 2, 3, 0]], np.uint8)
    data = aseprite_bytes(4, 1, [LayerSpec("i")], [FrameSpec([CelSpec(0, index)])], depth=8, transparent_index=3,
                          first_chunks=[palette_chunk(colours, {1: "Red", 2: "half green"})])
    rgba = load_image(data)
    assert rgba.tolist() == [[[255, 0, 0, 255], [0, 255, 0, 128], [0, 0, 0, 0], [0, 0, 0, 255]]]
    palette = read_aseprite(data).palette
    assert [entry.name for entry in palette] == [None, "Red", "half green", None]
    assert palette[2].rgba == (0, 255, 0, 128)


def test_indexed_background_shows_the_transparent_index_as_its_colour():
    colours = np.array([[10, 20, 30, 255], [255, 0, 0, 255]], np.uint8)
    index = np.array([[0, 1]], np.uint8)
    data = aseprite_bytes(2, 1, [LayerSpec("Background", background=True)], [FrameSpec([CelSpec(0, index)])],
                          depth=8, first_chunks=[palette_chunk(colours)])
    assert load_image(data).tolist() == [[[10, 20, 30, 255], [255, 0, 0, 255]]]


@pytest.mark.parametrize("six_bit", [False, True])
def test_old_palette_chunks(six_bit):
    rgb = np.array([[0, 0, 0], [63, 32, 1]] if six_bit else [[0, 0, 0], [250, 128, 4]], np.uint8)
    data = aseprite_bytes(1, 1, [LayerSpec("i")], [FrameSpec([CelSpec(0, np.array([[1]], np.uint8))])], depth=8,
                          first_chunks=[old_palette_chunk(rgb, six_bit)])
    expected = [255, 130, 4, 255] if six_bit else [250, 128, 4, 255]  # 6-bit v → v << 2 | v >> 4
    assert load_image(data)[0, 0].tolist() == expected


def test_the_new_palette_chunk_wins_over_the_old_one():
    new = palette_chunk(np.array([[0, 0, 0, 255], [1, 2, 3, 255]], np.uint8))
    old = old_palette_chunk(np.array([[0, 0, 0], [200, 200, 200]], np.uint8))
    data = aseprite_bytes(1, 1, [LayerSpec("i")], [FrameSpec([CelSpec(0, np.array([[1]], np.uint8))])], depth=8,
                          first_chunks=[new, old])
    assert load_image(data)[0, 0].tolist() == [1, 2, 3, 255]


# ---------------------------------------------------------------- layers and cels

@pytest.mark.parametrize("seed", range(4))
def test_layers_blend_as_aseprite_normal_with_cel_and_layer_opacity(seed):
    below, above = random_rgba(seed), random_rgba(seed + 100)
    layers = [LayerSpec("below"), LayerSpec("above", opacity=200)]
    data = aseprite_bytes(5, 6, layers, [FrameSpec([rgba_cel(0, below), rgba_cel(1, above, opacity=150)])])
    opacity = ((150 * 200 + 128 >> 8) + 150 * 200 + 128) >> 8
    expected = reference_normal(reference_normal(np.zeros_like(below), below, 255), above, opacity)
    assert np.array_equal(load_image(data), expected)


def test_layer_opacity_counts_only_with_the_header_flag():
    pixel = np.array([[[200, 0, 0, 255]]], np.uint8)
    layers = [LayerSpec("a", opacity=100)]
    with_flag = aseprite_bytes(1, 1, layers, [FrameSpec([rgba_cel(0, pixel)])])
    without = aseprite_bytes(1, 1, layers, [FrameSpec([rgba_cel(0, pixel)])], flags=0)
    assert load_image(with_flag)[0, 0, 3] == 100
    assert load_image(without)[0, 0, 3] == 255


def test_hidden_layers_hidden_groups_and_reference_layers_are_left_out():
    red, blue = np.full((1, 1, 4), (255, 0, 0, 255), np.uint8), np.full((1, 1, 4), (0, 0, 255, 255), np.uint8)
    for layers in ([LayerSpec("base"), LayerSpec("top", visible=False)],
                   [LayerSpec("base"), LayerSpec("top", reference=True)],
                   [LayerSpec("base"), LayerSpec("group", kind=1, visible=False), LayerSpec("top", level=1)]):
        top = len(layers) - 1
        data = aseprite_bytes(1, 1, layers, [FrameSpec([rgba_cel(0, red), rgba_cel(top, blue)])])
        assert load_image(data)[0, 0].tolist() == [255, 0, 0, 255], [layer.name for layer in layers]
    shown = [LayerSpec("base"), LayerSpec("group", kind=1), LayerSpec("top", level=1)]
    data = aseprite_bytes(1, 1, shown, [FrameSpec([rgba_cel(0, red), rgba_cel(2, blue)])])
    assert load_image(data)[0, 0].tolist() == [0, 0, 255, 255]


def test_other_blend_modes_are_refused_naming_the_mode_and_the_layer():
    layers = [LayerSpec("base"), LayerSpec("Shadow", blend=1)]
    cels = [rgba_cel(0, SPRITE), rgba_cel(1, SPRITE)]
    with pytest.raises(InputError, match=r"layer 'Shadow' uses the Multiply blend mode") as info:
        load_image(aseprite_bytes(4, 4, layers, [FrameSpec(cels)]))
    assert "\n" not in str(info.value)
    layers[1].visible = False  # a hidden one draws nothing: no refusal
    assert np.array_equal(load_image(aseprite_bytes(4, 4, layers, [FrameSpec(cels)])), SPRITE)


def test_groups_apart_take_their_opacity_flattened_groups_do_not():
    below, above = random_rgba(1, (3, 3)), random_rgba(2, (3, 3))
    layers = [LayerSpec("g", kind=1, opacity=120), LayerSpec("a", level=1), LayerSpec("b", level=1)]
    frames = [FrameSpec([rgba_cel(1, below), rgba_cel(2, above)])]
    group = reference_normal(reference_normal(np.zeros_like(below), below, 255), above, 255)
    apart = aseprite_bytes(3, 3, layers, frames, flags=OPACITY_VALID | GROUPS_APART)
    assert np.array_equal(load_image(apart), reference_normal(np.zeros_like(group), group, 120))
    assert np.array_equal(load_image(aseprite_bytes(3, 3, layers, frames)), group)


def test_cels_are_placed_and_clipped_to_the_canvas():
    data = aseprite_bytes(3, 3, [LayerSpec("a")], [FrameSpec([rgba_cel(0, SPRITE, x=-2, y=1)])])
    expected = np.zeros((3, 3, 4), np.uint8)
    expected[1:3, 0:2] = SPRITE[0:2, 2:4]
    assert np.array_equal(load_image(data), expected)


def test_z_index_reorders_cels():
    red, blue = np.full((1, 1, 4), (255, 0, 0, 255), np.uint8), np.full((1, 1, 4), (0, 0, 255, 255), np.uint8)
    layers = [LayerSpec("a"), LayerSpec("b")]
    assert load_image(aseprite_bytes(1, 1, layers, [FrameSpec([rgba_cel(0, red), rgba_cel(1, blue)])]))[0, 0, 2] == 255
    raised = aseprite_bytes(1, 1, layers, [FrameSpec([rgba_cel(0, red, z=1), rgba_cel(1, blue)])])
    assert load_image(raised)[0, 0].tolist() == [255, 0, 0, 255]


def test_raw_and_compressed_cels_read_alike():
    for kind in ("raw", "compressed"):
        data = aseprite_bytes(4, 4, [LayerSpec("a")], [FrameSpec([rgba_cel(0, SPRITE, kind=kind)])])
        assert np.array_equal(load_image(data), SPRITE), kind


def test_linked_cels_share_the_pixels_at_their_own_place():
    frames = [FrameSpec([rgba_cel(0, SPRITE)]), FrameSpec([CelSpec(0, kind="linked", link=0, x=1)]),
              FrameSpec([CelSpec(0, kind="linked", link=5)])]  # a link to no earlier cel: dropped, as Aseprite does
    data = aseprite_bytes(5, 4, [LayerSpec("a")], frames)
    got = dict(load_frames(data))
    assert np.array_equal(got[1][:, 1:], SPRITE) and not got[1][:, 0].any()
    assert not got[2].any()


# ---------------------------------------------------------------- frames, tags, slices

def test_frames_durations_tags_and_slices():
    frames = [FrameSpec([rgba_cel(0, SPRITE)], duration=80), FrameSpec([rgba_cel(0, SPRITE[::-1])], duration=0),
              FrameSpec([], duration=250)]
    tags = tags_chunk([("walk", 0, 1, 0, 0), ("back", 1, 2, 1, 3), ("bounce", 0, 2, 2, 0), ("rb", 2, 2, 3, 1)])
    data = aseprite_bytes(4, 4, [LayerSpec("a")], frames, speed=120,
                          first_chunks=[tags, slice_chunk("head", [(0, 1, 0, 2, 2), (2, 0, 0, 4, 1)])])
    ase = read_aseprite(data)
    assert ase.durations == (80, 120, 250)  # 0: the header's speed
    assert [(t.name, t.first, t.last, t.direction, t.repeat) for t in ase.tags] == [
        ("walk", 0, 1, "forward", 0), ("back", 1, 2, "reverse", 3), ("bounce", 0, 2, "pingpong", 0),
        ("rb", 2, 2, "pingpong reverse", 1)]
    assert [(k.frame, k.x, k.y, k.width, k.height) for k in ase.slices[0].keys] == [(0, 1, 0, 2, 2), (2, 0, 0, 4, 1)]
    assert np.array_equal(ase.frames[1], SPRITE[::-1]) and not ase.frames[2].any()
    assert not ase.frames[0].flags.writeable
    assert frame_count(data) == 3
    assert np.array_equal(load_image(data, frame=1), SPRITE[::-1])
    assert [i for i, _ in load_frames(data)] == [0, 1, 2]


def test_the_old_chunk_count_alone_is_read():
    data = aseprite_bytes(4, 4, [LayerSpec("a")], [FrameSpec([rgba_cel(0, SPRITE)])], old_count=True)
    assert np.array_equal(load_image(data), SPRITE)


def test_told_apart_by_its_magic_number_not_its_name(tmp_path):
    path = tmp_path / "sprite.png"
    path.write_bytes(one_layer(SPRITE))
    assert np.array_equal(load_image(path), SPRITE)
    assert np.array_equal(load_image(io.BytesIO(one_layer(SPRITE))), SPRITE)


def test_the_command_converts_an_aseprite_file(tmp_path, capsys):
    from depixel_cli.main import main  # noqa: PLC0415
    from depixel_cli.options import Exit  # noqa: PLC0415

    source, png = tmp_path / "sprite.aseprite", tmp_path / "sprite.png"
    source.write_bytes(one_layer(SPRITE))
    Image.fromarray(SPRITE, "RGBA").save(png)
    assert main(["convert", str(source), "-o", str(tmp_path / "a.svg")]) == Exit.OK
    assert main(["convert", str(png), "-o", str(tmp_path / "b.svg")]) == Exit.OK
    assert capsys.readouterr().err == ""
    unstamped = [re.sub(r"<!--.*?-->\n?|<title>.*?</title>", "", (tmp_path / name).read_text())
                 for name in ("a.svg", "b.svg")]
    assert unstamped[0] == unstamped[1] and "<path" in unstamped[0]


# ---------------------------------------------------------------- real files (Aseprite's tests, MIT)

def test_real_files_from_aseprites_own_tests():
    groups = read_aseprite(FIXTURES / "aseprite" / "groups3abc.aseprite")
    assert (groups.width, groups.height, groups.mode) == (9, 11, "rgba")
    hidden = {"/".join(filter(None, [groups.layers[layer.parent].name if layer.parent >= 0 else "", layer.name]))
              for layer in groups.layers if not layer.visible}
    assert hidden == {"b/b", "c", "c/a", "c/b"}  # as tests/sprites/README.md of aseprite says
    tags = read_aseprite(FIXTURES / "aseprite" / "tags3.aseprite")
    assert [(t.name, t.direction) for t in tags.tags] == [("forward", "forward"), ("reverse", "reverse"),
                                                         ("pingpong", "pingpong")]
    assert len(tags.frames) == 12
    indexed = read_aseprite(FIXTURES / "aseprite" / "bg-index-3.aseprite")
    assert indexed.mode == "indexed" and [layer.name for layer in indexed.layers] == ["bg", "fg"]
    for ase in (groups, tags, indexed):
        assert all(frame.shape == (ase.height, ase.width, 4) for frame in ase.frames)


def test_a_real_file_converts():
    svg = depixel.convert(load_image(FIXTURES / "aseprite" / "groups3abc.aseprite"))
    assert svg.count("<path") > 3


# ---------------------------------------------------------------- damaged files and limits

def test_every_truncation_is_one_input_error_line():
    data = aseprite_bytes(4, 4, [LayerSpec("a"), LayerSpec("b")],
                          [FrameSpec([rgba_cel(0, SPRITE), rgba_cel(1, SPRITE, kind="raw")]),
                           FrameSpec([CelSpec(0, kind="linked", link=0)])],
                          first_chunks=[tags_chunk([("t", 0, 1, 0, 0)]), palette_chunk(SPRITE[0], {0: "n"})])
    for cut in range(6, len(data)):
        with pytest.raises(InputError) as info:
            list(load_frames(data[:cut]))
        assert "\n" not in str(info.value)


def _damage(data: bytes, offset: int, fmt: str, value: int) -> bytes:
    out = bytearray(data)
    struct.pack_into("<" + fmt, out, offset, value)
    return bytes(out)


FIRST_CHUNK = 128 + 16  # the header, then frame 0's header


@pytest.mark.parametrize("damage, message", [
    (lambda d: _damage(d, 6, "H", 0), "declares no frames"),
    (lambda d: _damage(d, 8, "H", 0), "zero size"),
    (lambda d: _damage(d, 12, "H", 24), "colour depth 24"),
    (lambda d: _damage(d, 128 + 4, "H", 0x1234), "no 0xF1FA magic"),
    (lambda d: _damage(d, 128, "I", 2**31), "frame 0 declares"),
    (lambda d: _damage(d, FIRST_CHUNK, "I", 3), "declares 3 bytes"),
    (lambda d: _damage(d, FIRST_CHUNK, "I", 2**30), "past its frame"),
    (lambda d: _damage(d, 6, "H", 2), "truncated or corrupt"),
])
def test_damaged_headers_and_chunks(damage, message):
    data = one_layer(SPRITE)
    with pytest.raises(InputError, match=message):
        load_image(damage(data))


def _cel_file(width: int, height: int, payload: bytes, kind: int = 2) -> bytes:
    """One layer, one cel declared ``width`` × ``height`` with ``payload`` as its data."""
    cel = struct.pack("<HhhBHh5xHH", 0, 0, 0, 255, kind, 0, width, height) + payload
    data = one_layer(SPRITE)
    layer_end = FIRST_CHUNK + struct.unpack_from("<I", data, FIRST_CHUNK)[0]
    chunk = struct.pack("<IH", 6 + len(cel), 0x2005) + cel
    body = data[128 + 16:layer_end] + chunk
    frame = struct.pack("<IHHHxxI", 16 + len(body), 0xF1FA, 2, 100, 2) + body
    return data[:128] + frame


def test_a_zlib_bomb_stops_at_the_cels_declared_size():
    bomb = zlib.compress(bytes(64 * 2**20), 9)  # 64 MiB of zeros in ~64 KB
    with pytest.raises(InputError, match="decompresses past its declared size"):
        load_image(_cel_file(4, 4, bomb))


def test_absurd_cel_sizes_and_corrupt_data():
    with pytest.raises(InputError, match="decode to over 256 MiB"):
        load_image(_cel_file(65535, 65535, zlib.compress(b"")))
    with pytest.raises(InputError, match="corrupt compressed data"):
        load_image(_cel_file(2, 2, b"not zlib at all"))
    with pytest.raises(InputError, match=r"cut short \(3 of its 16 bytes\)"):
        load_image(_cel_file(2, 2, zlib.compress(b"abc")))
    with pytest.raises(InputError, match="unknown Aseprite cel type 7"):
        load_image(_cel_file(2, 2, b"", kind=7))


def test_limits_on_pixels_and_frames():
    big = aseprite_bytes(2000, 1000, [LayerSpec("a")], [FrameSpec()])
    with pytest.raises(InputError, match="over the limit of 1048576") as info:
        load_image(big)
    assert info.value.parameter == "max_pixels"
    assert load_image(big, max_pixels=None).shape == (1000, 2000, 4)
    many = aseprite_bytes(4, 4, [LayerSpec("a")], [FrameSpec([rgba_cel(0, SPRITE)]) for _ in range(6)])
    with pytest.raises(InputError, match="declares 6 frames, over the limit of 5") as info:
        list(load_frames(many, max_frames=5))
    with pytest.raises(InputError, match="6 frames are 96 pixels in all"):
        list(load_frames(many, max_pixels=90))
    with pytest.raises(InputError, match="frame 5 is past the limit of 5 frames"):
        load_image(many, frame=5, max_frames=5)
    with pytest.raises(InputError, match="has 6 frame"):
        load_image(many, frame=6)
    with pytest.raises(InputError, match="declares 6 frames"):
        frame_count(many, max_frames=5)


def test_tilemaps_and_unknown_layers_are_refused_in_one_line():
    tilemap = aseprite_bytes(4, 4, [LayerSpec("tiles", kind=2)], [FrameSpec([rgba_cel(0, SPRITE)])])
    with pytest.raises(InputError, match="layer 'tiles' in frame 0 is a tilemap"):
        load_image(tilemap)
    unknown = aseprite_bytes(4, 4, [LayerSpec("odd", kind=5)], [FrameSpec()])
    with pytest.raises(InputError, match="unknown Aseprite layer type 5"):
        load_image(unknown)


def test_the_two_magic_number_checks_agree():
    from depixel.prepare.aseprite_format import is_aseprite  # noqa: PLC0415
    from depixel.prepare.image import _is_aseprite  # noqa: PLC0415

    for data in (one_layer(SPRITE), b"\x89PNG\r\n\x1a\n" + bytes(20), bytes(3), b"1234\xe0\xa5"):
        assert is_aseprite(data) == _is_aseprite(data)
