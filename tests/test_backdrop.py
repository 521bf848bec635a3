"""The backdrop (depixel/prepare/backdrop.py): its colour removed from the border inwards.

``--transparent`` is a flood fill from the image's border (4-connected), so a sprite's
eye-whites or teeth in the backdrop's colour stay; ``transparent_everywhere`` is the colour
key that removes every pixel of that colour.
"""
from __future__ import annotations

from collections import deque

import numpy as np
import pytest
from conftest import art
from hypothesis import given, settings
from hypothesis import strategies as st

import depixel
from depixel.errors import ParameterError
from depixel.prepare.backdrop import border_connected, make_transparent
from depixel.prepare.inputs import prepare

WHITE = (255, 255, 255)

#: a frog on a white backdrop: its eye-whites (3 pixels) and its mouth (3) are white too, inside
#: the black outline; the white between its eyes reaches the border (the backdrop)
FROG = """
    ..........
    .####.###.
    .#..#.#.#.
    .####.###.
    .#gggggg#.
    .#g#..#g#.
    .#gg.ggg#.
    .########.
    ..........
"""


def reference_border_connected(mask: np.ndarray) -> np.ndarray:
    """Slow, obviously correct: a breadth-first flood fill from every border pixel of ``mask``."""
    h, w = mask.shape
    seen = np.zeros_like(mask)
    queue = deque((y, x) for y in range(h) for x in range(w) if mask[y, x] and (y in (0, h - 1) or x in (0, w - 1)))
    for y, x in queue:
        seen[y, x] = True
    while queue:
        y, x = queue.popleft()
        for ny, nx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
            if 0 <= ny < h and 0 <= nx < w and mask[ny, nx] and not seen[ny, nx]:
                seen[ny, nx] = True
                queue.append((ny, nx))
    return seen


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.integers(1, 12), st.integers(1, 12), st.floats(0.2, 0.9), st.integers(0, 2**32 - 1))
def test_border_connected_is_a_flood_fill_from_the_border(h, w, density, seed):
    mask = np.random.default_rng(seed).random((h, w)) < density
    assert np.array_equal(border_connected(mask), reference_border_connected(mask))


def test_a_spiral_corridor_is_followed_to_its_end():
    """One turn a round: a corridor that winds inwards is still reached to its centre."""
    n = 21
    wall = np.zeros((n, n), bool)
    for k in range(0, n // 2, 2):  # square rings of wall, each with a gap on a rotating side
        wall[k, k:n - k] = wall[n - 1 - k, k:n - k] = wall[k:n - k, k] = wall[k:n - k, n - 1 - k] = True
        side = (k // 2) % 4
        gap = (k, n // 2) if side == 0 else (n // 2, n - 1 - k) if side == 1 else \
            (n - 1 - k, n // 2) if side == 2 else (n // 2, k)
        wall[gap] = False
    mask = ~wall
    mask[0, :] = mask[:, 0] = True  # an open border to start from
    assert border_connected(mask)[n // 2, n // 2] == reference_border_connected(mask)[n // 2, n // 2]
    assert np.array_equal(border_connected(mask), reference_border_connected(mask))


def test_the_frog_keeps_its_eye_whites_and_teeth():
    frog = art(FROG)
    white = (frog[..., :3] == WHITE).all(axis=2)
    outside = reference_border_connected(white)
    prepared = prepare(frog, transparent="auto")
    assert prepared.transparent == WHITE
    assert prepared.transparent_pixels == outside.sum() and prepared.transparent_kept == (white & ~outside).sum() == 6
    assert (prepared.rgba[outside, 3] == 0).all() and (prepared.rgba[~outside, 3] == 255).all()
    assert "made #ffffff transparent (" + str(outside.sum()) + " pixels; 6 of that colour inside kept)" in \
        prepared.describe("frog.png")
    assert prepared.summary()["transparent_kept"] == 6


def test_transparent_everywhere_is_the_colour_key():
    frog = art(FROG)
    white = (frog[..., :3] == WHITE).all(axis=2)
    prepared = prepare(frog, transparent="white", transparent_everywhere=True)
    assert prepared.transparent_pixels == white.sum() and prepared.transparent_kept == 0
    assert (prepared.rgba[white, 3] == 0).all() and (prepared.rgba[~white, 3] == 255).all()
    assert "kept" not in prepared.describe("frog.png")


def test_diagonal_contact_does_not_join_the_backdrop():
    """4-connected: the inside pixel touches the backdrop only at a corner."""
    sprite = art("""
    ....
    .#..
    #.#.
    .#..
    """)
    made = make_transparent(sprite, WHITE)
    assert made.kept == 1 and made.rgba[2, 1, 3] == 255 and made.rgba[0, 0, 3] == 0


def test_a_colour_only_inside_makes_nothing_transparent():
    sprite = art("""
    ####
    #..#
    ####
    """)
    prepared = prepare(sprite, transparent="white")
    assert prepared.transparent is None and not prepared.changed and prepared.transparent_kept == 2
    assert "none of the 2 pixels of #ffffff reaches the border, so nothing was made transparent" in prepared.notes[0]


def test_the_api_takes_the_same_choice():
    frog = art(FROG)
    border = depixel.prepare_input(frog, transparent="auto")
    key = depixel.prepare_input(frog, transparent="auto", transparent_everywhere=True)
    assert key.transparent_pixels - border.transparent_pixels == border.transparent_kept == 6
    svg_border, svg_key = (depixel.convert(frog, transparent="auto", transparent_everywhere=e) for e in (False, True))
    assert svg_border != svg_key and svg_border.count('fill="#ffffff"') > 0 == svg_key.count('fill="#ffffff"')
    with pytest.raises(ParameterError, match="transparent_everywhere must be True or False"):
        depixel.convert(frog, transparent="auto", transparent_everywhere="yes")


def test_the_command_notes_what_it_kept_and_how_to_remove_it(tmp_path, capsys):
    from PIL import Image

    from depixel_cli.main import main

    Image.fromarray(art(FROG)).save(tmp_path / "frog.png")
    assert main(["convert", str(tmp_path / "frog.png"), "-o", str(tmp_path / "frog.svg"), "--transparent", "auto"]) == 0
    assert capsys.readouterr().err == (f"depixel: note: {tmp_path / 'frog.png'}: made #ffffff transparent (37 pixels; "
                                       "6 of that colour inside kept: --transparent-everywhere removes them too)\n")
    assert main(["convert", str(tmp_path / "frog.png"), "-o", str(tmp_path / "frog.svg"), "--transparent", "auto",
                 "--transparent-everywhere"]) == 0
    assert capsys.readouterr().err.endswith("made #ffffff transparent (43 pixels)\n")
