"""Draw docs/img/svg_threads.png: sma_toad's cap at 8x, before and after the stacked outlines
were pulled back from the edges of the faces above them (docs/svg.md, "Threads").

    python docs/img/threads_figure.py            # needs ../shared/corpus/paper/sma_toad.png

Top row: the default SVG drawn by cairosvg at 8x, without the insets (``MARGIN`` 0: what
the writer drew before) and with them; bottom row: the same with every pixel that the shared
judge counts in ``conflation_px`` (more than 32 levels from the exact coverage) in magenta.
Each render pixel is shown as 2 x 2.
"""
from __future__ import annotations

import io
import re
import sys
from pathlib import Path

import cairosvg
import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from depixel import depixelize, load_image, to_svg  # noqa: E402
from depixel.svg import insets  # noqa: E402

SPRITE = ROOT.parent / "shared" / "corpus" / "paper" / "sma_toad.png"
OUT = Path(__file__).resolve().parent / "svg_threads.png"
ZOOM, FINE = 8, 8
CROP = (1, 0, 17, 12)  # the cap: x0, y0, x1, y1 in art pixels


def _render(svg: str, w: int, h: int, crisp: bool = False) -> np.ndarray:
    if crisp:
        svg = re.sub(r"<svg\b", '<svg shape-rendering="crispEdges"', svg, count=1)
    png = cairosvg.svg2png(bytestring=svg.encode(), output_width=w, output_height=h)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)


def panels(margin: float) -> tuple[np.ndarray, np.ndarray]:
    """The render at 8x and the same with the judge's conflation pixels marked."""
    old, insets.MARGIN = insets.MARGIN, margin
    try:
        image = load_image(SPRITE)
        svg = to_svg(depixelize(image).vector)
    finally:
        insets.MARGIN = old
    h, w = image.shape[:2]
    aa = _render(svg, w * ZOOM, h * ZOOM)
    exact = _render(svg, w * ZOOM * FINE, h * ZOOM * FINE, crisp=True)
    exact = exact.reshape(h * ZOOM, FINE, w * ZOOM, FINE, 3).mean(axis=(1, 3))
    marked = aa.copy()
    marked[np.abs(aa - exact).max(axis=-1) > 32] = (255, 0, 255)  # (the art is opaque: no alpha to weigh)
    x0, y0, x1, y1 = (v * ZOOM for v in CROP)
    return aa[y0:y1, x0:x1], marked[y0:y1, x0:x1]


def main() -> int:
    if not SPRITE.is_file():
        print(f"threads_figure: {SPRITE} not found", file=sys.stderr)
        return 2
    before, after = panels(0.0), panels(insets.MARGIN)
    gap = np.full((before[0].shape[0], 8, 3), 255.0)
    rows = [np.concatenate((before[i], gap, after[i]), axis=1) for i in range(2)]
    picture = np.concatenate((rows[0], np.full((8, rows[0].shape[1], 3), 255.0), rows[1]), axis=0)
    img = Image.fromarray(picture.astype(np.uint8))
    img.resize((img.width * 2, img.height * 2), Image.NEAREST).save(OUT, optimize=True)
    print(OUT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
