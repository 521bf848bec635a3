"""Every size a caller chooses has a bound (issue 35, findings 5, 6, 10, 11 and 12).

Parameters, arrays, page sizes, numbers in messages and ``<use>`` fan-outs: each is refused
with one line before the work it would cost, and what is accepted stays within memory (the
parameters at their bounds run under ``resource.setrlimit``).
"""
from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES, ROOT

import depixel
from depixel import api
from depixel.errors import InputError, ParameterError, RenderError
from depixel.limits import MAX_SVG_REFERENCES, PDF_PAGE_POINTS, SVG_SIDE_PIXELS
from depixel.params import LIMITS, Params
from depixel.render.references import references
from depixel_cli.main import main
from depixel_cli.options import Exit

HEART = FIXTURES / "heart.png"  # 16 x 16
#: address space of the subprocess trying each parameter at its bound (as tests/test_limits.py)
LIMIT = 1536 * 2**20


def one_line(err: str) -> str:
    found = [line for line in err.splitlines() if line.strip()]
    assert len(found) == 1 and "Traceback" not in err and "internal error" not in err, err
    return found[0]


# --- finding 5: every parameter bounded ---------------------------------------------------------

NUMERIC = [f.name for f in dataclasses.fields(Params) if not isinstance(f.default, bool)]


def test_every_numeric_parameter_has_a_range_with_an_upper_bound():
    assert sorted(LIMITS) == sorted(NUMERIC)
    assert [name for name in NUMERIC if LIMITS[name].high is None] == []


@pytest.mark.parametrize("name", NUMERIC)
def test_bounds_are_checked_on_construction_and_replace(name):
    rule = LIMITS[name]
    assert getattr(Params(**{name: rule.high}), name) == rule.high
    above = rule.high + 1 if rule.integer else rule.high * 1.01
    for make in (lambda: Params(**{name: above}), lambda: Params().replace(**{name: above})):
        with pytest.raises(ParameterError, match=rf"^{name} must be between .* and .*, not ") as caught:
            make()
        assert caught.value.parameter == name


def test_each_documented_with_its_range():
    """docs/limits.md and the field's comment in params.py (on its line or just above) give
    the range of every field."""
    docs = (ROOT / "docs" / "limits.md").read_text().splitlines()
    source = (ROOT / "depixel" / "params.py").read_text().split("class Params")[1].splitlines()

    def text(value: float) -> str:
        return "2⁶³-1" if value >= 2**40 else f"{value:g}".replace("e-06", "e-6")

    for name in NUMERIC:
        shown = f"[{text(LIMITS[name].low)}, {text(LIMITS[name].high)}]"
        assert any(line.startswith(f"| `{name}` |") and shown in line for line in docs), name
        at = next(i for i, line in enumerate(source) if line.startswith(f"    {name}: "))
        above = at
        while source[above - 1].startswith("    #"):
            above -= 1
        assert shown in "\n".join(source[above:at + 1]), name


def test_each_parameter_at_its_bound_stays_in_memory():
    """A small image (3-colour noise with a long bar, 24 x 24) converted to SVG and to an 8x
    smooth PNG with each field at its upper bound, one at a time, under a 1.5 GiB address
    space: ``shading_radius=1e9`` was accepted and reached 24 GB on a 17 x 15 sprite."""
    body = f"""
import numpy as np, depixel
from depixel.params import LIMITS, Params
rng = np.random.default_rng(3)
palette = np.array([(20, 20, 20, 255), (230, 60, 60, 255), (250, 250, 250, 255)], np.uint8)
image = palette[rng.integers(0, 3, (24, 24))]
image[11:13] = palette[0]
for name in {NUMERIC!r}:
    params = Params().replace(**{{name: LIMITS[name].high}})
    depixel.convert(image, params)
    depixel.convert_bytes(image, "png", params, scale=8)
    print(name)
"""
    code = f"import resource; resource.setrlimit(resource.RLIMIT_AS, ({LIMIT}, {LIMIT}))\n" + body
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-600:]
    assert run.stdout.split() == NUMERIC


# --- finding 6: arrays ------------------------------------------------------------------------

@pytest.mark.parametrize("image, reason", [
    ([[1, 2, 3], [4, 5]], "rows of different lengths"),
    ([[[1, 2, 3]], [[4, 5]]], "rows of different lengths"),
    (np.full((4, 4, 3), np.nan), "NaN or infinite"),
    (np.array([[0.5, np.inf], [0.1, 0.2]]), "NaN or infinite"),
    (np.array([[0.5, -np.inf]], np.float32), "NaN or infinite"),
])
@pytest.mark.parametrize("call", ["convert", "convert_bytes", "flatten", "prepare_input", "depixelize"])
def test_arrays_that_are_no_picture_raise_input_error(image, reason, call):
    run = {"convert": lambda: depixel.convert(image), "convert_bytes": lambda: depixel.convert_bytes(image, "png"),
           "flatten": lambda: depixel.flatten(image, "white"), "prepare_input": lambda: depixel.prepare_input(image),
           "depixelize": lambda: depixel.depixelize(image)}[call]
    with pytest.raises(InputError, match=reason) as caught:
        run()
    assert "\n" not in str(caught.value)


# --- finding 10: page sizes ---------------------------------------------------------------------

@pytest.mark.parametrize("argv, unit", [
    (["--scale", "1e9", "-o", "{d}/x.pdf"], "pt"),
    (["--scale", "1e-15", "-o", "{d}/x.pdf"], "pt"),
    (["--width", "100000", "-o", "{d}/x.pdf"], "pt"),
    (["--scale", "1e6", "-o", "{d}/x.svg"], "px"),
    (["--scale", "1e-300", "-o", "{d}/x.svg"], "px"),
])
def test_vector_pages_out_of_range_are_refused(tmp_path, capsys, argv, unit):
    """Before: a 933-byte PDF with a 36e9 pt page and no drawing, an empty page, an SVG of
    width 0 or one no cairo-based renderer draws (exit 0)."""
    args = [a.format(d=tmp_path) for a in argv]
    assert main(["convert", str(HEART), *args]) == Exit.FAILED
    flag = args[0]
    line = one_line(capsys.readouterr().err)
    assert re.fullmatch(rf"depixel: error: .*heart\.png: a \S+x\S+ {unit} page is outside the .* a side .*; "
                        rf"choose another {flag}", line), line
    assert list(tmp_path.iterdir()) == []


def test_pdf_page_bounds_are_the_formats():
    """The edges: 3 and 14400 pt a side are accepted, a little beyond is refused."""
    low, high = PDF_PAGE_POINTS
    rgba = np.zeros((1, 1, 4), np.uint8)
    rgba[..., 3] = 255
    for points, accepted in ((low, True), (low * 0.99, False), (high, True), (high * 1.01, False)):
        scale = points / 0.75
        if accepted:
            assert api.convert_bytes(rgba, "pdf", scale=scale, stage="cells").startswith(b"%PDF")
        else:
            with pytest.raises(ParameterError, match="outside the 3 to 14400 pt a side"):
                api.convert_bytes(rgba, "pdf", scale=scale, stage="cells")
    low_svg, high_svg = SVG_SIDE_PIXELS
    assert 'width="0.001"' in api.convert(rgba, scale=low_svg, stage="cells")
    with pytest.raises(ParameterError, match="an SVG can have; choose another scale"):
        api.convert(rgba, scale=high_svg * 1.01, stage="cells")


def test_render_to_pdf_refuses_a_page_out_of_range(tmp_path, capsys):
    svg = tmp_path / "x.svg"
    svg.write_text(depixel.convert(depixel.load_image(HEART), stage="cells"))
    for args in (["--scale", "1e6"], ["--width", "30000"]):
        assert main(["render", str(svg), "-o", str(tmp_path / "r.pdf"), *args]) == Exit.FAILED
        assert one_line(capsys.readouterr().err).endswith(f"a side a PDF page can have; choose another {args[0]}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.svg"]
    assert main(["render", str(svg), "-o", str(tmp_path / "r.pdf"), "--scale", "10"]) == Exit.OK


def test_inspect_refuses_a_name_that_says_another_format(tmp_path, capsys):
    """``inspect -o x.svg`` wrote PNG bytes into a .svg name (convert refuses that)."""
    for name in ("x.svg", "x.PDF"):
        with pytest.raises(SystemExit) as exit_:
            main(["inspect", str(HEART), "-o", str(tmp_path / name)])
        assert exit_.value.code == Exit.USAGE
        assert one_line(capsys.readouterr().err) == f"depixel inspect: error: {tmp_path / name}: inspect writes PNG; " \
                                                    "name it .png"
    assert list(tmp_path.iterdir()) == []


# --- finding 11: numbers in messages --------------------------------------------------------------

@pytest.mark.parametrize("argv", [["convert", str(HEART), "-o", "{d}/x.png", "--scale", "1e300"],
                                  ["convert", str(HEART), "-o", "{d}/x.svg", "--scale", "1e300"],
                                  ["render", "{svg}", "-o", "{d}/x.png", "--scale", "1e300"]])
def test_huge_numbers_in_messages_are_short(tmp_path, capsys, argv):
    """A ``--scale 1e300`` message was 1,339 characters of digits."""
    svg = tmp_path / "in.svg"
    svg.write_text(depixel.convert(depixel.load_image(HEART), stage="cells"))
    assert main([a.format(d=tmp_path, svg=svg) for a in argv]) == Exit.FAILED
    line = one_line(capsys.readouterr().err)
    assert len(line) < 250 and "1e+301" in line and not re.search(r"\d{16}", line), line


def test_shown_numbers():
    from depixel.validate import shown

    values = (10**301, int(1e301), 16 * 10**300 - 1, 1e300, 12, 12.5, 7.5e-15, 123456789012345678, -10**20)
    assert [shown(v) for v in values] == \
        ["1e+301", "1e+301", "1.6e+301", "1e+300", "12", "12.5", "7.5e-15", "1.235e+17", "-1e+20"]


# --- finding 12: <use> fan-out ----------------------------------------------------------------------

def fanout(levels: int, width: int = 10) -> str:
    """``levels`` groups, each ``width`` uses of the one before: width**levels copies of a rect."""
    defs = ['<rect id="l0" width="1" height="1"/>']
    for k in range(1, levels + 1):
        defs.append(f'<g id="l{k}">' + f'<use xlink:href="#l{k - 1}"/>' * width + "</g>")
    return ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="10" '
            f'height="10"><defs>{"".join(defs)}</defs><use xlink:href="#l{levels}"/></svg>')


@pytest.mark.parametrize("svg, expected", [
    (fanout(1), 11), (fanout(2, 3), 1 + 3 + 9), (fanout(4), 1 + 10 + 100 + 1000 + 10000),
    (fanout(11), MAX_SVG_REFERENCES + 1),  # 1.1 * 10**11 copies
    ('<svg xmlns="http://www.w3.org/2000/svg"><g id="a"><use href="#a"/></g></svg>', MAX_SVG_REFERENCES + 1),
    ('<svg xmlns="http://www.w3.org/2000/svg"><use href="#b"/><g id="b"><use href="#c"/></g>'
     '<rect id="c"/></svg>', 2 + 1),  # b drawn where it stands (1) and through the use (2)
    ('<svg xmlns="http://www.w3.org/2000/svg"><use href="#missing"/><use href="other.svg#x"/></svg>', 2),
    ('<svg xmlns="http://www.w3.org/2000/svg"><defs><g id="d"><use href="#e"/></g></defs><rect id="e"/></svg>', 0),
])
def test_references_counted_like_drawn(svg, expected):
    assert references(ET.fromstring(svg), MAX_SVG_REFERENCES) == expected


def test_fanout_refused_before_cairosvg_draws(tmp_path, capsys, monkeypatch):
    """10**11 copies in 3 KB: cairosvg drew 100,000 of them (15-38 s) before its own error;
    now refused before it draws anything, in one line."""
    import cairosvg

    drawn = []
    real_draw = cairosvg.surface.Surface.draw
    monkeypatch.setattr(cairosvg.surface.Surface, "draw",
                        lambda self, node: drawn.append(node) or real_draw(self, node))
    svg = tmp_path / "fanout.svg"
    svg.write_text(fanout(11))
    assert main(["render", str(svg), "-o", str(tmp_path / "f.png")]) == Exit.FAILED
    assert one_line(capsys.readouterr().err) == (f"depixel: error: {svg}: its <use> elements draw over "
                                                 f"{MAX_SVG_REFERENCES} copies (references of references, or one "
                                                 "that contains itself); refusing to render it")
    assert drawn == [] and sorted(p.name for p in tmp_path.iterdir()) == ["fanout.svg"]
    with pytest.raises(RenderError, match="draw over"):
        depixel.render_file(svg, tmp_path / "f.pdf")
    small = tmp_path / "small.svg"
    small.write_text(fanout(3))
    assert main(["render", str(small), "-o", str(tmp_path / "s.png")]) == Exit.OK and drawn
