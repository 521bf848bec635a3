"""EPS output (issue 43, docs/cli.md "EPS"): EPSF-3.0 through cairosvg, vector only, a
bounding box at the output's size, byte-stable and stamped; semi-transparent colours refused
unless flattened; Ghostscript draws it like the flat SVG."""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from conftest import FIXTURES
from PIL import Image

import depixel
from depixel.errors import RenderError
from depixel.files import stamp as stamps
from depixel.render.raster import render_rgba
from depixel_cli.main import main
from depixel_cli.options import Exit

MUSHROOM = np.asarray(Image.open(FIXTURES / "mushroom.png").convert("RGBA"))  # opaque, 16 x 14
POTION = np.asarray(Image.open(FIXTURES / "potion_rgba.png").convert("RGBA"))  # alpha 128 inside
#: PostScript operators that draw a raster image (cairo's prolog defines them, a page uses them)
IMAGE_OPERATORS = re.compile(rb"\b(image|imagemask|colorimage|cairo_image|cairo_imagemask)\b")


def page(eps: bytes) -> bytes:
    """What an EPS draws: everything after its prolog."""
    return eps.split(b"%%EndProlog", 1)[1]


def test_an_eps_is_epsf_3_with_its_bounding_box_at_the_output_size():
    eps = depixel.convert_bytes(MUSHROOM, "eps", scale=8)
    assert eps.startswith(b"%!PS-Adobe-3.0 EPSF-3.0\n")
    head = eps.split(b"%%EndComments\n", 1)[0].decode("ascii")
    # 16 x 14 pixels at 8x, a CSS pixel 3/4 pt as the PDF's page: 96 x 84 pt
    assert "%%BoundingBox: 0 0 96 84" in head.splitlines()
    assert b"%%PageBoundingBox: 0 0 96 84" in eps
    width = depixel.convert_bytes(MUSHROOM, "eps", width=640)
    assert b"%%BoundingBox: 0 0 480 420\n" in width
    assert b"%%CreationDate: 1970-01-01T00:00:00Z\n" in eps  # not the clock's: the same bytes every run
    assert depixel.convert_bytes(MUSHROOM, "eps", scale=8) == eps


@pytest.mark.parametrize("shading", ["smooth", "flat"])
def test_opaque_art_stays_vector(shading):
    eps = depixel.convert_bytes(MUSHROOM, "eps", scale=8, shading=shading)
    assert IMAGE_OPERATORS.search(page(eps)) is None
    assert b" f\n" in page(eps) or b" f*\n" in page(eps)  # filled paths
    assert eps == depixel.convert_bytes(MUSHROOM, "eps", scale=8, shading="flat")  # flat bands, as the PDF


def test_a_semi_transparent_colour_is_refused_or_flattened_over_the_background(tmp_path, capsys):
    with pytest.raises(RenderError) as caught:
        depixel.convert_bytes(POTION, "eps")
    assert caught.value.parameter == "background" and "semi-transparent" in str(caught.value)
    source = tmp_path / "potion.png"
    Image.fromarray(POTION).save(source)
    assert main(["convert", str(source), "-o", str(tmp_path / "p.eps")]) == Exit.FAILED
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--background" in err and "Traceback" not in err, err
    assert not (tmp_path / "p.eps").exists()
    assert main(["convert", str(source), "-o", str(tmp_path / "p.eps"), "--background", "white"]) == Exit.OK
    assert IMAGE_OPERATORS.search(page((tmp_path / "p.eps").read_bytes())) is None


def test_cairo_would_have_drawn_translucent_overlaps_as_images():
    """Why they are refused: the same art, let through, puts a raster image in the file."""
    from depixel.api import encode

    svg = depixel.convert(POTION, shading="flat")
    assert IMAGE_OPERATORS.search(page(encode(svg, "eps"))) is not None


def test_an_eps_is_stamped_and_up_to_date_in_a_batch(tmp_path, capsys):
    source = tmp_path / "m.png"
    Image.fromarray(MUSHROOM).save(source)
    assert main(["convert", str(source), "--format", "eps", "-q"]) == Exit.OK
    out = tmp_path / "m.eps"
    eps = out.read_bytes()
    assert stamps.parse(eps) is not None and stamps.intact(eps)
    head, _, rest = eps.partition(b"%%EndComments\n")
    assert rest.startswith(b"%depixel-options:") and b"%%BoundingBox" in head  # the header stays whole
    mtime = out.stat().st_mtime_ns
    assert main(["convert", str(source), "--format", "eps", "-q"]) == Exit.OK
    assert out.stat().st_mtime_ns == mtime and out.read_bytes() == eps  # skipped: up to date


@pytest.mark.skipif(shutil.which("gs") is None, reason="Ghostscript (gs) is not installed: apt install ghostscript")
def test_ghostscript_draws_it_like_the_flat_svg(tmp_path):
    (tmp_path / "m.eps").write_bytes(depixel.convert_bytes(MUSHROOM, "eps", scale=8))
    subprocess.run(["gs", "-q", "-dSAFER", "-dBATCH", "-dNOPAUSE", "-dEPSCrop", "-sDEVICE=png16m",
                    "-dGraphicsAlphaBits=4", "-r96", f"-sOutputFile={tmp_path / 'gs.png'}", str(tmp_path / "m.eps")],
                   check=True, timeout=120)
    drawn = np.asarray(Image.open(tmp_path / "gs.png").convert("RGB")).astype(int)
    svg = render_rgba(depixel.convert(MUSHROOM, scale=8, shading="flat")).astype(float)
    alpha = svg[..., 3:] / 255.0
    expected = (svg[..., :3] * alpha + 255 * (1 - alpha)).round().astype(int)  # gs draws on white paper
    assert drawn.shape == expected.shape == (112, 128, 3)
    difference = np.abs(drawn - expected).max(axis=-1)
    # the two anti-alias the edges differently (measured: mean 1.5 levels, 1.8 % of the
    # pixels over 32), and agree everywhere else
    assert difference.mean() < 3 and (difference > 32).mean() < 0.04
    assert np.percentile(difference, 90) <= 2
