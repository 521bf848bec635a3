"""Helpers of the robustness tests.

Checks of a converted SVG that need no ../shared: it parses, references nothing external,
and renders every pixel centre in the pixel's colour and opacity (the judge's "centre"
figure, with alpha compared too, so a half-transparent pixel must stay half-transparent).
And :func:`png_bytes`, a PNG writer for inputs Pillow will not write (16-bit colour,
hostile headers).
"""
from __future__ import annotations

import io
import re
import struct
import xml.etree.ElementTree as ET
import zlib

import numpy as np

import depixel

#: The stage the robustness tests convert with: the default, the paper's final result.
STAGE = "optimized"
#: Largest per-channel difference (RGB and alpha) accepted at a pixel centre, as the judge's.
TOLERANCE = 16
SVG_NS = "{http://www.w3.org/2000/svg}"
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"


def convert(rgba: np.ndarray, stage: str = STAGE, title: str | None = None) -> str:
    """RGBA image → SVG text through the library API."""
    return depixel.to_svg(depixel.depixelize(rgba, stage=stage).vector, title=title)


def parse(svg: str) -> ET.Element:
    """Parse the SVG, checking it is self-contained: no url() nor href but to an element of
    the file (the smooth shading's filters and masks, a mask's ``<use>`` of a shape), no
    external entity."""
    assert "<!DOCTYPE" not in svg and "<!ENTITY" not in svg
    namespaces = ('xmlns="http://www.w3.org/2000/svg"', 'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"',
                  'xmlns:xlink="http://www.w3.org/1999/xlink"')
    bare = svg
    for declaration in namespaces:  # names of vocabularies, not references to anything
        bare = bare.replace(declaration, "")
    assert "://" not in bare
    root = ET.fromstring(svg.encode("utf-8"))
    assert root.tag == SVG_NS + "svg"
    ids = {element.get("id") for element in root.iter()}
    for element in root.iter():
        for key, value in element.attrib.items():
            if key == XLINK_HREF and element.tag == SVG_NS + "use":
                assert value.startswith("#") and value[1:] in ids, f"{element.tag} {key}={value!r}"
                continue
            assert "href" not in key, f"{element.tag} has {key}"
            for target in re.findall(r"url\s*\(([^)]*)\)", value):
                assert target.startswith("#") and target[1:] in ids, f"{element.tag} {key}={value!r}"
        assert element.tag.split("}")[-1] not in {"image", "style", "script", "foreignObject"}
    return root


def paths(root: ET.Element) -> list[ET.Element]:
    return list(root.iter(SVG_NS + "path"))


def render(svg: str, width: int, height: int, scale: int = 9) -> np.ndarray:
    """Rasterize with cairosvg at ``scale`` pixels per input pixel → ``(H*s, W*s, 4) int``."""
    import cairosvg
    from PIL import Image

    png = cairosvg.svg2png(bytestring=svg.encode("utf-8"), output_width=width * scale,
                           output_height=height * scale)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"), dtype=np.int64)


def centre_errors(rgba: np.ndarray, svg: str) -> np.ndarray:
    """``(H, W) bool``: pixel centres whose rendered colour or opacity is off by more than
    TOLERANCE (the colour of a fully transparent pixel does not matter)."""
    h, w = rgba.shape[:2]
    s = 9  # odd: output pixel s // 2 of each block sits on the input pixel centre
    got = render(svg, w, h, s)[s // 2 :: s, s // 2 :: s]
    want = rgba.astype(np.int64)
    alpha_bad = np.abs(got[..., 3] - want[..., 3]) > TOLERANCE
    colour_bad = (np.abs(got[..., :3] - want[..., :3]).max(axis=2) > TOLERANCE) & (want[..., 3] > 0)
    return alpha_bad | colour_bad


def assert_centres_kept(rgba: np.ndarray, svg: str) -> None:
    bad = centre_errors(rgba, svg)
    assert not bad.any(), f"{int(bad.sum())} of {bad.size} pixel centres off, first at (row, col) " \
                          f"{tuple(int(i) for i in np.argwhere(bad)[0])}"


def fills(root: ET.Element) -> set[tuple[str, float]]:
    """(fill colour, fill-opacity) of every path."""
    return {(p.get("fill"), float(p.get("fill-opacity", "1"))) for p in paths(root)}


def visible_colours(rgba: np.ndarray) -> set[tuple[str, float]]:
    """(fill colour, opacity) of every pixel colour that is not fully transparent."""
    out = set()
    for r, g, b, a in np.unique(rgba.reshape(-1, 4), axis=0).tolist():
        if a:
            out.add((f"#{r:02x}{g:02x}{b:02x}", round(a / 255.0, 3)))
    return out


def png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_bytes(width: int, height: int, depth: int, colour_type: int, pixels: bytes = b"",
              extra: bytes = b"") -> bytes:
    """A PNG with the given IHDR; ``pixels`` are the raw rows without filter bytes (each
    row gets filter 0), ``extra`` are chunks placed before IDAT (tRNS, PLTE)."""
    row = len(pixels) // height if height and pixels else 0
    raw = b"".join(b"\0" + pixels[i * row : (i + 1) * row] for i in range(height)) if pixels else b""
    header = struct.pack(">IIBBBBB", width, height, depth, colour_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", header) + extra
            + png_chunk(b"IDAT", zlib.compress(raw)) + png_chunk(b"IEND", b""))
