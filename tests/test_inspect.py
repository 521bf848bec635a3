"""``depixel inspect`` and the stage figure (depixel.render.figure)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES, art
from PIL import Image

import depixel
from depixel.prepare.image import load_image
from depixel.render import figure
from depixel_cli.main import main
from depixel_cli.options import Exit

ALL_STAGES = ["input", "similarity graph", "crossings resolved", "reshaped cells", "splines",
              "optimized splines", "final render"]


def expected_size(n_panels: int, width: int, height: int, zoom: int) -> tuple[int, int]:
    rows, cols = figure.grid_shape(n_panels)
    pw, ph = width * zoom, height * zoom
    return (cols * pw + (cols + 1) * figure.GAP,
            rows * (ph + figure.TITLE_HEIGHT) + (rows + 1) * figure.GAP)


@pytest.fixture(scope="module")
def ghost_result():
    return depixel.depixelize(load_image(FIXTURES / "ghost.png"))


def test_cli_writes_one_picture_sized_by_the_stages(tmp_path):
    out, folder = tmp_path / "stages.png", tmp_path / "stages"
    code = main(["inspect", str(FIXTURES / "heart.png"), "-o", str(out), "--out-dir", str(folder), "--zoom", "6"])
    assert code == Exit.OK
    files = sorted(p.name for p in folder.iterdir())
    assert files == [f"{i:02d}-{t.replace(' ', '-')}.png" for i, t in enumerate(ALL_STAGES, start=1)]
    with Image.open(out) as img:
        assert img.size == expected_size(len(ALL_STAGES), 10, 10, 6)  # heart.png is 10×10
    for name in files:
        with Image.open(folder / name) as panel:
            assert panel.size == (60, 60)


def test_cli_earlier_stage_has_fewer_panels(tmp_path):
    out = tmp_path / "cells.png"
    assert main(["inspect", str(FIXTURES / "heart.png"), "-o", str(out), "--zoom", "5", "--stage", "cells"]) == Exit.OK
    with Image.open(out) as img:
        assert img.size == expected_size(5, 10, 10, 5)  # no spline panels


def test_cli_needs_an_output_and_reports_bad_input(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["inspect", str(FIXTURES / "heart.png")])
    assert exit_info.value.code == Exit.USAGE
    capsys.readouterr()
    assert main(["inspect", str(tmp_path / "missing.png"), "-o", str(tmp_path / "x.png")]) == Exit.FAILED
    assert capsys.readouterr().err.count("\n") == 1
    assert not (tmp_path / "x.png").exists()


def count(panel, colour) -> int:
    return int(np.all(np.asarray(panel) == colour, axis=2).sum())


def test_diagonals_are_coloured_by_what_happened_to_them(ghost_result):
    panels = dict(figure.stage_panels(ghost_result, zoom=8))
    assert list(panels) == ALL_STAGES
    res = ghost_result.resolution
    assert res.flat.any() and res.ambiguous.any()  # the ghost has both kinds of crossing
    assert count(panels["similarity graph"], figure.FLAT_BLUE) > 0
    assert count(panels["similarity graph"], figure.AMBIGUOUS_RED) > 0
    assert count(panels["crossings resolved"], figure.KEPT_GREEN) > 0
    assert count(panels["crossings resolved"], figure.AMBIGUOUS_RED) > 0  # removed, dashed
    assert count(panels["crossings resolved"], figure.FLAT_BLUE) == 0
    assert count(panels["splines"], figure.CONTROL_ORANGE) > 0


def test_no_crossings_no_crossing_colours():
    plain = art("""
        #.#.
        #.#.
        #.#.
    """)  # stripes: no 2×2 block has a diagonal link
    result = depixel.depixelize(plain, stage="cells")
    panels = dict(figure.stage_panels(result, zoom=10))
    for title in ("similarity graph", "crossings resolved"):
        for colour in (figure.FLAT_BLUE, figure.AMBIGUOUS_RED, figure.KEPT_GREEN):
            assert count(panels[title], colour) == 0


def test_input_panel_is_the_magnified_image():
    img = art("#r\n.b")
    result = depixel.depixelize(img, stage="cells")
    panel = np.asarray(figure.stage_panels(result, zoom=3)[0][1])
    assert panel.shape == (6, 6, 3)
    assert np.array_equal(panel[::3, ::3], img[..., :3])
    assert np.array_equal(panel, img[..., :3].repeat(3, axis=0).repeat(3, axis=1))


def test_default_zoom_and_grid():
    assert figure.default_zoom((16, 18)) == 22 and figure.default_zoom((224, 256)) == 2
    assert figure.grid_shape(3) == (1, 3) and figure.grid_shape(5) == (2, 3) and figure.grid_shape(7) == (2, 4)
