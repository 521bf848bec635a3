"""Draw the figures of docs/svg.md from the fixtures.

    python docs/img/svg_figures.py                      # the layer views and node views
    python docs/img/svg_figures.py --before ../old      # also before/after, with an older
                                                        # checkout's depixel (git worktree)

svg_layers_*.png: every shape of the stacked and the cutout layout drawn alone, in drawing
order, over a checkerboard (a hole shows the checkerboard). svg_nodes.png: the outline
nodes (segment ends) an editor shows, before (the older checkout), with the exact spline and
with the default simplification. svg_bands.png: before and after at 12x. svg_smooth.png:
the smooth shading (docs/svg.md), flat against smooth (rendered by resvg, which applies SVG
filters) against the PNG renderer, on the orb and a tone chain (a dark and a light grey
joined by a middle one at one end of the contour between them).
"""
from __future__ import annotations

import argparse
import io
import os
import re
import subprocess
import sys
from pathlib import Path

import cairosvg
import numpy as np
from PIL import Image, ImageDraw

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from depixel import depixelize, load_image, to_svg  # noqa: E402
from depixel.svg.outlines import build_outlines  # noqa: E402
from depixel.svg.writer import DEFAULT_SIMPLIFY, path_data  # noqa: E402

OUT = Path(__file__).resolve().parent
INK = (40, 40, 40, 255)


def render(svg: str, zoom: int, shape: tuple[int, int]) -> Image.Image:
    h, w = shape
    png = cairosvg.svg2png(bytestring=svg.encode(), output_width=w * zoom, output_height=h * zoom)
    return Image.open(io.BytesIO(png)).convert("RGBA")


def checkerboard(size: tuple[int, int], cell: int = 6) -> Image.Image:
    w, h = size
    y, x = np.mgrid[0:h, 0:w]
    light = ((x // cell + y // cell) % 2 == 0)
    grey = np.where(light, 235, 205).astype(np.uint8)
    return Image.fromarray(np.dstack([grey, grey, grey, np.full_like(grey, 255)]), "RGBA")


def label(image: Image.Image, text: str) -> Image.Image:
    out = Image.new("RGBA", (image.width, image.height + 16), (255, 255, 255, 255))
    out.alpha_composite(image, (0, 16))
    ImageDraw.Draw(out).text((2, 2), text, fill=INK)
    return out


def row(images: list[Image.Image], gap: int = 8) -> Image.Image:
    w = sum(i.width for i in images) + gap * (len(images) - 1)
    h = max(i.height for i in images)
    out = Image.new("RGBA", (w, h), (255, 255, 255, 255))
    x = 0
    for i in images:
        out.alpha_composite(i, (x, 0))
        x += i.width + gap
    return out


def column(images: list[Image.Image], gap: int = 8) -> Image.Image:
    w = max(i.width for i in images)
    h = sum(i.height for i in images) + gap * (len(images) - 1)
    out = Image.new("RGBA", (w, h), (255, 255, 255, 255))
    y = 0
    for i in images:
        out.alpha_composite(i, (0, y))
        y += i.height + gap
    return out


def layers(fixture: str, layout: str, zoom: int = 6) -> Image.Image:
    """Every shape alone in its colour over a checkerboard, in drawing order."""
    rgba = load_image(ROOT / "fixtures" / fixture)
    h, w = rgba.shape[:2]
    out = build_outlines(depixelize(rgba).vector, layout, grid=1e-2, simplify=DEFAULT_SIMPLIFY)
    data = path_data(out, 2)
    ids = re.findall(r'<path id="([^"]*)"', to_svg(depixelize(rgba).vector, layout=layout))
    tiles = []
    for s in range(len(out)):
        r, g, b, a = (int(v) for v in out.rgba[s])
        svg = (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w} {h}" width="{w}" height="{h}">'
               f'<path d="{data[s]}" fill="#{r:02x}{g:02x}{b:02x}" fill-opacity="{a / 255:.3f}"/></svg>')
        tile = checkerboard((w * zoom, h * zoom))
        tile.alpha_composite(render(svg, zoom, (h, w)))
        tiles.append(label(tile, f"{s + 1}. {ids[s] if s < len(ids) else ''}"))
    per_row = 6
    return column([row(tiles[i : i + per_row]) for i in range(0, len(tiles), per_row)])


def node_view(svg: str, shape: tuple[int, int], zoom: int, title: str) -> Image.Image:
    """The render, faded, with every path node (segment end) as a dot."""
    h, w = shape
    base = render(svg, zoom, shape)
    faded = Image.blend(Image.new("RGBA", base.size, (255, 255, 255, 255)), base, 0.45)
    draw = ImageDraw.Draw(faded)
    count = 0
    for d in re.findall(r' d="([^"]*)"', svg):
        for x, y in _nodes(d):
            draw.ellipse((x * zoom - 2, y * zoom - 2, x * zoom + 2, y * zoom + 2), fill=(220, 30, 30, 255))
            count += 1
    return label(faded, f"{title}: {count} nodes")


def _nodes(d: str) -> list[tuple[float, float]]:
    """End points of every segment of path data (absolute or relative, compact or not)."""
    tokens = re.findall(r"[MmLlHhVvQqTtCcZz]|[+-]?(?:\d+\.?\d*|\.\d+)", d)
    arity = {"m": 2, "l": 2, "h": 1, "v": 1, "q": 4, "t": 2, "c": 6, "z": 0}
    points, cur, start, cmd, i = [], np.zeros(2), np.zeros(2), "", 0
    while i < len(tokens):
        if tokens[i].isalpha():
            cmd = tokens[i]
            i += 1
            if cmd in "Zz":
                cur = start
                continue
        n = arity[cmd.lower()]
        v = np.array(tokens[i : i + n], float)
        i += n
        base = cur if cmd.islower() else np.zeros(2)
        if cmd in "Hh":
            cur = np.array([v[0] + base[0], cur[1]])
        elif cmd in "Vv":
            cur = np.array([cur[0], v[0] + base[1]])
        else:
            cur = base + v[-2:]
        if cmd in "Mm":
            start = cur
            cmd = "l" if cmd == "m" else "L"
        points.append((float(cur[0]), float(cur[1])))
    return points


#: the tone chain of tests/test_smooth_svg.py: 60 ~ 105 ~ 150, the dark and the light side
#: touching along a contour, the middle grey at its left end
CHAIN = ["0000000000", "0000000000", "0000000000", "1000000000", "2222222222", "2222222222", "2222222222"]


def resvg_render(svg: str, zoom: int, shape: tuple[int, int]) -> Image.Image:
    import resvg_py  # noqa: PLC0415 (a renderer with SVG filters, in the test extras)

    h, w = shape
    png = resvg_py.svg_to_bytes(svg_string=svg, width=w * zoom, height=h * zoom)
    return Image.open(io.BytesIO(bytes(png))).convert("RGBA")


def smooth_figure() -> Image.Image:
    """Rows of the orb and the tone chain: the flat SVG, the smooth SVG (resvg) and the PNG
    renderer, over a checkerboard."""
    from depixel.render.shading import render_smooth  # noqa: PLC0415

    greys = np.array([[60, 60, 60, 255], [105, 105, 105, 255], [150, 150, 150, 255]], np.uint8)
    chain = greys[np.array([[int(c) for c in line] for line in CHAIN])]
    rows = []
    for rgba, zoom in ((load_image(ROOT / "fixtures" / "orb.png"), 12), (chain, 20)):
        vector = depixelize(rgba).vector
        shape = rgba.shape[:2]
        views = [(resvg_render(to_svg(vector, shading="flat"), zoom, shape), "flat (--shading flat)"),
                 (resvg_render(to_svg(vector), zoom, shape), "smooth SVG (resvg)"),
                 (Image.fromarray(render_smooth(vector, zoom), "RGBA"), "PNG renderer")]
        cells = []
        for image, title in views:
            back = checkerboard(image.size)
            back.alpha_composite(image)
            cells.append(label(back, title))
        rows.append(row(cells))
    return column(rows)


def before_svg(checkout: Path, fixture: str) -> str:
    """The SVG an older checkout's depixel writes for a fixture."""
    code = ("import sys; from depixel import depixelize, load_image, to_svg; "
            f"sys.stdout.write(to_svg(depixelize(load_image({str(ROOT / 'fixtures' / fixture)!r})).vector))")
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=checkout, capture_output=True, text=True,
                          check=True).stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, help="an older checkout of depixel to compare with")
    args = parser.parse_args()
    layers("mushroom.png", "stacked").save(OUT / "svg_layers_stacked.png")
    layers("mushroom.png", "cutout").save(OUT / "svg_layers_cutout.png")
    smooth_figure().save(OUT / "svg_smooth.png")
    views, bands = [], []
    for fixture, zoom in (("mushroom.png", 14), ("ghost.png", 14)):
        rgba = load_image(ROOT / "fixtures" / fixture)
        vector = depixelize(rgba).vector
        shape = rgba.shape[:2]
        row_views = []
        if args.before:
            old = before_svg(args.before, fixture)
            row_views.append(node_view(old, shape, zoom, "before"))
            bands.append(row([label(render(old, 12, shape), f"{fixture} before"),
                              label(render(to_svg(vector), 12, shape), "after")]))
        row_views.append(node_view(to_svg(vector, simplify=0), shape, zoom, "exact spline (--simplify 0)"))
        row_views.append(node_view(to_svg(vector), shape, zoom, f"default (--simplify {DEFAULT_SIMPLIFY:g})"))
        views.append(row(row_views))
    column(views).save(OUT / "svg_nodes.png")
    if bands:
        column(bands).save(OUT / "svg_bands.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
