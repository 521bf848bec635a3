"""The exported SVG is plain SVG 1.1 that editors open: every element, child and attribute
value passes svgwrite's SVG 1.1 Full validator (which, e.g., refuses ``rgba()`` fills that
Inkscape and Illustrator read as black), and nothing references an external resource (the
smooth shading's filter is referenced by ``url(#smooth)``, inside the file, and its masks' copies
of shapes by ``xlink:href="#id"``).

Path data is checked against the grammar of SVG 1.1 §8.3.9 itself (tests/svgpath.py):
svgwrite's checker refuses two forms the specification allows and depixel writes to keep
files small — a minus sign as the separator ("1-2") and a second decimal point starting a
new number ("0.6.5", the specification's own example)."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
import svgpath
from conftest import fixture_pngs
from svgwrite.validator2 import get_validator

from depixel import Params, depixelize, load_image, to_svg

SVG_NS = "{http://www.w3.org/2000/svg}"


def local(tag: str) -> str:
    return tag.replace(SVG_NS, "")


FILTER = {"defs", "filter", "feGaussianBlur", "feComponentTransfer", "feFuncA", "feComposite", "mask", "rect", "use"}
XLINK_HREF = "{http://www.w3.org/1999/xlink}href"


@pytest.mark.parametrize("shading", ["smooth", "flat"])
@pytest.mark.parametrize("stage", ["cells", "splines", "optimized"])
@pytest.mark.parametrize("path", [p for p in fixture_pngs() if p.name in ("ghost_rgba.png", "potion_rgba.png", "orb.png")],
                         ids=lambda p: p.name)
def test_svg_passes_the_svg11_full_validator(path, stage, shading):
    svg = to_svg(depixelize(load_image(path), Params(), stage=stage).vector, scale=4, title=path.name, shading=shading)
    root = ET.fromstring(svg)
    ids = {element.get("id") for element in root.iter()}
    validator = get_validator("full", debug=True)
    seen = set()
    for element in root.iter():
        name = local(element.tag)
        seen.add(name)
        for child in element:
            assert validator.is_valid_children(name, local(child.tag)), (name, local(child.tag))
        for attribute, value in element.attrib.items():
            if attribute.startswith("{"):
                continue
            if name == "path" and attribute == "d":
                assert svgpath.parse(value)  # SVG 1.1 path grammar; raises on a bad value
            else:
                validator.check_svg_attribute_value(name, attribute, value)  # raises on a bad value
            assert "rgba(" not in value
            assert "url(" not in value or (value.startswith("url(#") and value[5:-1] in ids)
        assert not any("href" in a for a in element.attrib if not (name == "use" and a == XLINK_HREF))
        if name == "use":  # (a mask's copy of a shape drawn above a smooth group)
            assert element.get(XLINK_HREF)[0] == "#" and element.get(XLINK_HREF)[1:] in ids
    assert seen <= {"svg", "title", "g", "path"} | (FILTER if shading == "smooth" else set())
    assert ("filter" in seen) == (shading == "smooth" and path.name == "orb.png")  # (the orb is shaded)
    assert ("mask" in seen) == ("filter" in seen)  # (its highlight lies on its bands)
    assert root.get("viewBox") == "0 0 {} {}".format(*load_image(path).shape[1::-1])
