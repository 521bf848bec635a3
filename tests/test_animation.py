"""One animated SVG and one APNG of an animation (depixel/svg/animation.py,
depixel/files/animation.py, depixel/render/animation.py): a layer a frame switched by SMIL in
the file's timing, the first frame drawn by static renderers as its own conversion, shapes the
frames share written once."""
from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import FIXTURES

import depixel
from depixel.api import convert_bytes, load
from depixel.errors import ParameterError
from depixel.prepare.animation import Animation, read_animation
from depixel.render.raster import render_rgba
from depixel.svg.animation import compose, key_times

SVG = "{http://www.w3.org/2000/svg}"
XLINK = "{http://www.w3.org/1999/xlink}href"
INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"
DURATIONS = (120.0, 40.0, 250.0)


def animate(animation, **options) -> str:
    """The animated SVG, as the API makes it."""
    return depixel.convert(animation, animate=True, **options)


def animate_png(animation, **options) -> bytes:
    """The animated PNG, as the API makes it."""
    return depixel.convert_bytes(animation, "png", animate=True, **options)


def blinking(name: str = "chip") -> tuple[np.ndarray, ...]:
    """Three frames of a fixture that differ in one 2×2 patch in its middle (a light on the
    chip: as drawn, red, yellow)."""
    base = load(FIXTURES / f"{name}.png")
    y, x = base.shape[0] // 2 - 1, base.shape[1] // 2 - 1
    frames = [base]
    for colour in ((220, 30, 30, 255), (240, 220, 40, 255)):
        frame = base.copy()
        frame[y : y + 2, x : x + 2] = colour
        frames.append(frame)
    return tuple(frames)


@pytest.fixture(scope="module")
def chip() -> tuple[Animation, str, list[str]]:
    """The blinking chip as an animation, its animated SVG and each frame's own SVG."""
    animation = Animation(blinking(), DURATIONS, 0)
    return animation, animate(animation), [depixel.convert(f) for f in animation.frames]


def layers(svg: str) -> list[ET.Element]:
    root = ET.fromstring(svg)
    return [g for g in root if g.tag == f"{SVG}g"]


def strip_ids(text: str) -> str:
    """``text`` without ids, and without the names of the masks its groups use (named by what
    they hide, per animation: a frame's renders check them)."""
    return re.sub(r'mask="url\(#[^)]*\)"', 'mask="url(#)"', re.sub(r' id="[^"]*"', "", text))


def frame_elements(svg: str, number: int) -> list[str]:
    """The element lines frame ``number`` (from 1) draws, each ``<use>`` replaced by what it
    points to (a shared group by its children), ids left out."""
    defs = svg[svg.index("<defs>\n") + 7 : svg.index("</defs>\n")]
    by_id: dict[str, list[str]] = {}
    stack: list[tuple[str, list[str]]] = []
    for line in defs.splitlines():
        ident = re.match(r'<(?:path|g) id="([^"]*)"', line)
        for _, lines in stack:
            lines.append(line)
        if line.startswith("<g "):
            stack.append((ident.group(1), [line]))
        elif line.startswith("</g>"):
            ident_, lines = stack.pop()
            by_id[ident_] = lines
        elif ident and not stack:
            by_id[ident.group(1)] = [line]
    body = svg[svg.index(f'<g id="frame-{number}"') :].splitlines()[2:]  # after the layer and its <animate>
    out, depth = [], 0
    for line in body:
        if line.startswith("</g>") and depth == 0:
            break
        depth += line.startswith("<g ") - line.startswith("</g>")
        use = re.fullmatch(r'<use xlink:href="#([^"]*)"(?: inkscape:label="([^"]*)")?/>', line)
        if use is None:
            out.append(line)
        elif use.group(1).startswith("shared-"):
            out += by_id[use.group(1)][1:-1]
        else:  # a shape, with the label it has in this frame
            label = use.group(2)
            out += [line if label is None else re.sub(r'inkscape:label="[^"]*"', f'inkscape:label="{label}"', line)
                    for line in by_id[use.group(1)]]
    return [strip_ids(line) for line in out]


def own_elements(svg: str) -> list[str]:
    lines = svg.splitlines()
    start = lines.index("</defs>") + 1 if "</defs>" in lines else 2
    return [strip_ids(line) for line in lines[start:-1]]


def test_every_frame_is_a_layer_and_draws_its_own_conversion(chip):
    animation, svg, singles = chip
    groups = layers(svg)
    assert [g.get(f"{INKSCAPE}groupmode") for g in groups] == ["layer"] * 3
    assert [g.get(f"{INKSCAPE}label") for g in groups] == ["frame 1 (120 ms)", "frame 2 (40 ms)", "frame 3 (250 ms)"]
    assert [g.get("display") for g in groups] == [None, "none", "none"]
    for number, single in enumerate(singles, 1):
        assert frame_elements(svg, number) == own_elements(single), f"frame {number}"


def test_ids_are_unique_and_every_use_points_into_the_defs(chip):
    _, svg, _ = chip
    ids = re.findall(r' id="([^"]*)"', svg)
    assert len(ids) == len(set(ids))
    root = ET.fromstring(svg)
    defined = {e.get("id") for e in root.iter() if e.get("id")}
    uses = [u.get(XLINK) for u in root.iter(f"{SVG}use")]
    assert uses and all(u.startswith("#") and u[1:] in defined for u in uses)
    assert not [u for u in root.iter(f"{SVG}use") if u.get("href")]  # Inkscape 1.2 reads xlink:href only


def test_smil_switches_each_frame_over_the_cycle():
    frames = blinking()
    for plays, repeat in ((0, ("indefinite", None)), (1, ("1", "freeze")), (3, ("3", "freeze"))):
        svg = animate(Animation(frames, DURATIONS, plays))
        got = [g.find(f"{SVG}animate").attrib for g in layers(svg)]
        # starts at 0, 120 and 160 of a 410 ms cycle
        assert [a["values"] for a in got] == ["inline;none", "none;inline;none", "none;inline"]
        assert [a["keyTimes"] for a in got] == ["0;0.2927", "0;0.2927;0.3902", "0;0.3902"]
        assert {(a["attributeName"], a["calcMode"], a["dur"]) for a in got} == {("display", "discrete", "410ms")}
        assert {(a["repeatCount"], a.get("fill")) for a in got} == {repeat}


def test_a_still_is_one_layer_without_animation():
    svg = compose([depixel.convert(blinking()[0])], [100.0])
    assert "<animate" not in svg and 'display="none"' not in svg
    assert [g.get(f"{INKSCAPE}label") for g in layers(svg)] == ["frame 1 (100 ms)"]


def test_animating_a_still_writes_its_one_frame():
    frame = blinking()[0]
    assert animate(Animation.still(frame)) == animate(frame) == depixel.convert(frame)
    assert animate_png(Animation.still(frame), scale=2) == convert_bytes(frame, "png", scale=2)


def test_key_times_keep_the_frames_apart():
    assert key_times([1 / 3, 2 / 3]) == ["0.3333", "0.6667"]
    short = key_times([1e-7, 2e-7])  # a 11 ms frame in a cycle of 30 hours
    assert len(set(short)) == 2 and 0 < float(short[0]) < float(short[1])


@pytest.mark.parametrize("renderer", ["cairosvg", "resvg"])
def test_a_static_renderer_draws_the_first_frame_as_its_own_conversion(chip, renderer):
    _, svg, singles = chip
    if renderer == "cairosvg":
        first, own = render_rgba(svg, width=136), render_rgba(singles[0], width=136)
    else:
        resvg_py = pytest.importorskip("resvg_py")
        from PIL import Image

        def draw(text: str) -> np.ndarray:
            png = bytes(resvg_py.svg_to_bytes(svg_string=text, width=136))
            return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
        first, own = draw(svg), draw(singles[0])
    np.testing.assert_array_equal(first, own)


def assert_shapes_once(svg: str, singles: list[str]) -> None:
    """No shape (fill and path data) twice in ``svg``, and every shape of the frames in it."""
    paths = re.findall(r'<path [^>]*fill="([^"]*)"[^>]*d="([^"]*)"', svg)
    assert len(paths) == len(set(paths))
    for single in singles:
        for shape in re.findall(r'<path [^>]*fill="([^"]*)"[^>]*d="([^"]*)"', single):
            assert shape in paths


def test_shapes_the_frames_share_are_written_once(chip):
    _, svg, singles = chip
    assert_shapes_once(svg, singles)


def test_a_patch_that_changes_costs_little_more_than_one_frame(chip):
    _, svg, singles = chip
    assert len(svg) <= 1.6 * len(singles[0]), (len(svg), len(singles[0]))


def test_smooth_groups_keep_their_filter_in_every_frame():
    # the orb is one smooth region of six tones: the patch changes its group, not all its bands
    animation = Animation(blinking("orb"), DURATIONS, 0)
    svg = animate(animation)
    filters = depixel.convert(animation.frames[0]).count("<filter ")  # the blur, and the masks' cover
    assert svg.count('<filter id="smooth"') == 1 and svg.count("<filter ") == filters
    singles = [depixel.convert(frame) for frame in animation.frames]
    for number, own in enumerate(singles, 1):
        assert own.count('filter="url(#smooth)"') > 0
        assert frame_elements(svg, number) == own_elements(own)
    assert_shapes_once(svg, singles)


def test_options_reach_every_frame():
    animation = Animation(blinking(), DURATIONS, 0)
    svg = animate(animation, scale=4, shading="flat", simplify=0)
    for number, frame in enumerate(animation.frames, 1):
        assert frame_elements(svg, number) == own_elements(depixel.convert(frame, scale=4, shading="flat",
                                                                           simplify=0))
    assert 'width="68" height="60"' in svg


def test_compose_refuses_frames_of_other_sizes():
    small = depixel.convert(blinking()[0])
    large = depixel.convert(blinking()[0], scale=2)
    with pytest.raises(ValueError, match="differ in size"):
        compose([small, large], [100.0, 100.0])
    with pytest.raises(ParameterError, match="animate=True"):
        depixel.convert(Animation(blinking(), DURATIONS, 0))


def test_apng_has_the_frames_renders_and_timing():
    from PIL import Image

    animation = Animation(blinking(), DURATIONS, 2)
    data = animate_png(animation, scale=3)
    with Image.open(io.BytesIO(data)) as image:
        assert image.n_frames == 3 and image.info["loop"] == 2
    again = read_animation(data)
    assert again.durations == DURATIONS and again.plays == 2
    for got, frame in zip(again.frames, animation.frames):
        with Image.open(io.BytesIO(convert_bytes(frame, "png", scale=3))) as own:
            np.testing.assert_array_equal(got, np.asarray(own.convert("RGBA")))


def test_apng_counts_the_pixels_of_every_frame():
    from depixel.errors import InputError

    animation = Animation(blinking(), DURATIONS, 0)  # 17 × 15 at scale 2: 1,020 pixels a frame
    with pytest.raises(InputError, match="3 PNG frames are 3060 pixels") as refused:
        animate_png(animation, scale=2, max_output_pixels=3000)
    assert refused.value.parameter == "max_output_pixels"


@pytest.mark.parametrize("name", ["orb", "leaf_la"])
def test_every_frame_draws_as_its_own_conversion_masks_and_all(name):
    """A smooth group under shapes is masked by them (svg/hiding.py); in an animation each
    frame's masks must hide what that frame's shapes hide, wherever the shapes are written."""
    resvg_py = pytest.importorskip("resvg_py")
    from PIL import Image

    def draw(text: str) -> np.ndarray:
        png = bytes(resvg_py.svg_to_bytes(svg_string=text, width=160))
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(int)

    animation = Animation(blinking(name), DURATIONS, 0)
    svg = animate(animation)
    assert "<mask " in svg
    for number, frame in enumerate(animation.frames, 1):
        alone = re.sub(r"<animate [^>]*/>\n", "", svg)
        alone = alone.replace(' display="none"', "")
        for other in range(1, len(animation.frames) + 1):
            if other != number:
                alone = alone.replace(f'<g id="frame-{other}"', f'<g id="frame-{other}" display="none"')
        np.testing.assert_array_equal(draw(alone), draw(depixel.convert(frame)), err_msg=f"frame {number}")

