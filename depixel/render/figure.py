"""A picture of every pipeline stage, like the paper's Figure 3, to see why a result looks
the way it does.

Panels, each the image magnified ``zoom`` times:

0. input as given — only when preparing it changed something (an upscaled image, JPEG
   noise, a backdrop made transparent): the original laid over the grid of the art pixels;
1. input — the pixels (transparency as a checkerboard); "prepared 1x" after panel 0;
2. similarity graph — links between similar neighbours; crossing diagonals in flat 2×2
   blocks in blue, ambiguous crossings (decided by the heuristics) in red;
3. crossings resolved — the planar graph; at ambiguous blocks the kept diagonal is thick
   green and the removed one dashed red;
4. reshaped cells — the cell polygons filled with their colours;
5. splines, 6. optimized splines — the curves over the faded cells, with each B-spline's
   control polygon and control points in orange (only when the run reached these stages);
7. final render — the SVG as cairosvg draws it.

Everything is drawn with Pillow's ImageDraw, except the final render. The figure takes the
products a run made (:class:`Stages`: a :class:`depixel.pipeline.Result` is one); its caller
(``depixel inspect``, or a user of the API) runs the pipeline, which this module, below it,
does not import.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..curves.bspline import flatten_edges
from ..errors import RenderError
from ..limits import DEFAULT_MAX_OUTPUT_PIXELS
from ..svg.writer import to_svg
from ..vector import VectorImage, linked_edges

if TYPE_CHECKING:  # Pillow is imported where it draws; the products only name types
    from PIL.Image import Image

    from ..curves.splines import SplineSet
    from ..graph.cells import CellGraph
    from ..graph.crossings import CrossingResolution
    from ..graph.similarity import SimilarityGraph
    from ..optimize.stage import OptimizedSplines


class Stages(Protocol):
    """The products of one run that the figure draws (a :class:`depixel.pipeline.Result`)."""

    @property
    def similarity(self) -> SimilarityGraph: ...
    @property
    def resolution(self) -> CrossingResolution: ...
    @property
    def cells(self) -> CellGraph: ...
    @property
    def vector(self) -> VectorImage: ...
    @property
    def splines(self) -> SplineSet | None: ...  # when the run reached the "splines" stage
    @property
    def optimized(self) -> OptimizedSplines | None: ...  # when it reached "optimized"

GAP = 8  # pixels around and between panels
TITLE_HEIGHT = 18  # strip above each panel for its name
PAPER = (255, 255, 255)
INK = (40, 40, 40)
FLAT_BLUE = (40, 90, 230)
AMBIGUOUS_RED = (220, 30, 30)
KEPT_GREEN = (20, 160, 60)
CONTROL_ORANGE = (240, 130, 0)


def default_zoom(shape: tuple[int, int]) -> int:
    """Magnification that makes a panel about 400 pixels on its long side (2 to 32)."""
    return int(min(32, max(2, 400 // max(shape))))


def grid_shape(n_panels: int) -> tuple[int, int]:
    """(rows, columns) of the figure: one row up to four panels, else two rows."""
    cols = n_panels if n_panels <= 4 else math.ceil(n_panels / 2)
    return math.ceil(n_panels / cols), cols


def figure(result: Stages, zoom: int | None = None, prepared=None, original: np.ndarray | None = None):
    """All stage panels of one run, composed into one PIL image."""
    return compose(stage_panels(result, zoom, prepared, original))


def compose(panels: list[tuple[str, Image]]):
    """Lay titled panels (all the same size) out in a grid → one RGB PIL image."""
    from PIL import Image, ImageDraw  # noqa: PLC0415

    pw, ph = panels[0][1].size
    rows, cols = grid_shape(len(panels))
    sheet = Image.new("RGB", (cols * pw + (cols + 1) * GAP, rows * (ph + TITLE_HEIGHT) + (rows + 1) * GAP), PAPER)
    draw = ImageDraw.Draw(sheet)
    for i, (title, panel) in enumerate(panels):
        r, c = divmod(i, cols)
        x = GAP + c * (pw + GAP)
        y = GAP + r * (ph + TITLE_HEIGHT + GAP)
        draw.text((x, y + 2), f"{i + 1}. {title}", fill=INK)
        sheet.paste(panel, (x, y + TITLE_HEIGHT))
    return sheet


def panel_count(stage: str) -> int:
    """Panels of the figure of a run that stops at ``stage``."""
    return {"cells": 5, "splines": 6}.get(stage, 7)


def check_figure_size(shape: tuple[int, int], zoom: int | None, n_panels: int,
                      max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS) -> None:
    """Refuse a figure of more than ``max_output_pixels`` pixels (all panels together);
    callable before the pipeline runs, from the image's shape."""
    h, w = shape
    z = zoom or default_zoom(shape)
    if max_output_pixels is not None and n_panels * h * w * z * z > max_output_pixels:
        raise RenderError(f"{n_panels} panels of {w * z}x{h * z} are {n_panels * h * w * z * z} pixels, over the "
                          f"limit of {max_output_pixels} (a smaller zoom, or raise it with max_output_pixels)",
                          parameter="max_output_pixels")


def stage_panels(result: Stages, zoom: int | None = None, prepared=None, original: np.ndarray | None = None,
                 max_output_pixels: int | None = DEFAULT_MAX_OUTPUT_PIXELS) -> list[tuple[str, Image]]:
    """(title, PIL image) for every stage the run reached, in pipeline order. Panels that
    would hold more than ``max_output_pixels`` pixels together are refused before drawing.

    With the :class:`depixel.prepare.inputs.PreparedImage` the run converted and the ``original``
    ``(H, W, 4)`` image it came from, the original comes first when preparing changed it.
    """
    z = zoom or default_zoom(result.cells.shape)
    changed = prepared is not None and original is not None and prepared.changed
    n_panels = 5 + changed + (result.splines is not None) + (result.optimized is not None)
    check_figure_size(result.cells.shape, z, n_panels, max_output_pixels)
    before = []
    if changed and original is not None:
        before = [("input as given", _original_panel(original, prepared, z))]
    panels = before + [
        ("prepared 1x" if before else "input", _input_panel(result, z)),
        ("similarity graph", _similarity_panel(result, z)),
        ("crossings resolved", _resolved_panel(result, z)),
        ("reshaped cells", _cells_panel(result, z)),
    ]
    if result.splines is not None:
        panels.append(("splines", _curves_panel(result.splines, result.splines.positions, z)))
    if result.optimized is not None:
        opt = result.optimized
        panels.append(("optimized splines", _curves_panel(opt.splines, opt.positions, z)))
    panels.append(("final render", _render_panel(result, z)))
    return panels


# --- panels ---------------------------------------------------------------------------------

def _checkerboard(h: int, w: int, z: int) -> np.ndarray:
    """(h*z, w*z, 3) uint8 grey checks of half a pixel, to show transparency."""
    size = max(1, z // 2)
    yy, xx = np.indices((h * z, w * z)) // size
    return np.where(((yy + xx) % 2 == 0)[..., None], 204, 255).astype(np.uint8).repeat(3, axis=2)


def _over(rgba: np.ndarray, base: np.ndarray) -> np.ndarray:
    alpha = rgba[..., 3:4].astype(np.float64) / 255.0
    return np.round(rgba[..., :3] * alpha + base * (1.0 - alpha)).astype(np.uint8)


def _pixels(result: Stages, z: int, fade: float = 0.0):
    """The input magnified (nearest neighbour) over a checkerboard, faded towards white."""
    from PIL import Image  # noqa: PLC0415

    rgba = result.similarity.rgba
    h, w = rgba.shape[:2]
    big = rgba.repeat(z, axis=0).repeat(z, axis=1)
    rgb = _over(big, _checkerboard(h, w, z)).astype(np.float64)
    rgb = rgb + (255.0 - rgb) * fade
    return Image.fromarray(np.round(rgb).astype(np.uint8), "RGB")


def _input_panel(result: Stages, z: int):
    return _pixels(result, z)


def _original_panel(original: np.ndarray, prepared, z: int):
    """The image as given, resampled (nearest) onto the panel of the art's grid: each input
    pixel lands where its art pixel is drawn; the partial blocks cut off a crop stay blank."""
    from PIL import Image  # noqa: PLC0415

    gh, gw = prepared.rgba.shape[:2]
    (kx, ky), (ox, oy) = prepared.pixel_size, prepared.offset
    # panel pixel centre → input pixel: art coordinate × k, less the missing part of the first block
    x = np.floor((np.arange(gw * z) + 0.5) * kx / z).astype(np.int64) - (kx - ox) % kx
    y = np.floor((np.arange(gh * z) + 0.5) * ky / z).astype(np.int64) - (ky - oy) % ky
    inside = (y[:, None] >= 0) & (y[:, None] < original.shape[0]) & (x[None, :] >= 0) & (x[None, :] < original.shape[1])
    big = original[np.clip(y, 0, original.shape[0] - 1)][:, np.clip(x, 0, original.shape[1] - 1)]
    rgb = _over(big, _checkerboard(gh, gw, z))
    rgb[~inside] = PAPER
    return Image.fromarray(rgb, "RGB")


def _centre(index: np.ndarray, w: int, z: int) -> np.ndarray:
    """(K, 2) screen positions of the centres of flat pixel indices."""
    r, c = np.divmod(index, w)
    return np.stack([(c + 0.5) * z, (r + 0.5) * z], axis=1)


def _link_segments(graph, w: int, z: int) -> dict[str, np.ndarray]:
    """Screen segments ``(K, 2, 2)`` of every link of a similarity graph, per direction."""
    h = graph.shape[0]
    idx = np.arange(h * w).reshape(h, w)
    pairs = {
        "right": (idx[:, :-1][graph.right], idx[:, 1:][graph.right]),
        "down": (idx[:-1, :][graph.down], idx[1:, :][graph.down]),
        "main": (idx[:-1, :-1][graph.diag_main], idx[1:, 1:][graph.diag_main]),
        "anti": (idx[:-1, 1:][graph.diag_anti], idx[1:, :-1][graph.diag_anti]),
    }
    return {k: np.stack([_centre(a, w, z), _centre(b, w, z)], axis=1) for k, (a, b) in pairs.items()}


def _diagonal_segments(mask: np.ndarray, w: int, z: int, anti: bool) -> np.ndarray:
    """Screen segments of the "\\" (or "/" when ``anti``) diagonal of the 2×2 blocks in ``mask``."""
    r, c = np.nonzero(mask)
    a, b = (r * w + c + 1, (r + 1) * w + c) if anti else (r * w + c, (r + 1) * w + c + 1)
    return np.stack([_centre(a, w, z), _centre(b, w, z)], axis=1)


def _draw_segments(draw, segments: np.ndarray, colour, width: int, dashed: bool = False) -> None:
    for (x0, y0), (x1, y1) in segments.tolist():
        if not dashed:
            draw.line([(x0, y0), (x1, y1)], fill=colour, width=width)
            continue
        n = 7  # dashes per segment
        for k in range(0, n, 2):
            t0, t1 = k / n, (k + 1) / n
            draw.line([(x0 + (x1 - x0) * t0, y0 + (y1 - y0) * t0), (x0 + (x1 - x0) * t1, y0 + (y1 - y0) * t1)],
                      fill=colour, width=width)


def _draw_nodes(draw, result: Stages, z: int) -> None:
    rgba = result.similarity.rgba
    h, w = rgba.shape[:2]
    radius = max(1.5, z * 0.14)
    for (x, y), colour in zip(_centre(np.arange(h * w), w, z).tolist(), rgba.reshape(-1, 4)[:, :3].tolist()):
        draw.ellipse([x - radius, y - radius, x + radius, y + radius], fill=tuple(colour), outline=INK)


def _line_width(z: int) -> int:
    return max(1, z // 10)


def _similarity_panel(result: Stages, z: int):
    from PIL import ImageDraw  # noqa: PLC0415

    img = _pixels(result, z, fade=0.7)
    draw = ImageDraw.Draw(img)
    w = result.cells.shape[1]
    res = result.resolution
    lw = _line_width(z)
    for segs in _link_segments(result.similarity, w, z).values():
        _draw_segments(draw, segs, INK, lw)
    for anti in (False, True):
        _draw_segments(draw, _diagonal_segments(res.flat, w, z, anti), FLAT_BLUE, lw + 1)
        _draw_segments(draw, _diagonal_segments(res.ambiguous, w, z, anti), AMBIGUOUS_RED, lw + 1)
    _draw_nodes(draw, result, z)
    return img


def _resolved_panel(result: Stages, z: int):
    from PIL import ImageDraw  # noqa: PLC0415

    img = _pixels(result, z, fade=0.7)
    draw = ImageDraw.Draw(img)
    w = result.cells.shape[1]
    res = result.resolution
    graph = res.graph
    lw = _line_width(z)
    segs = _link_segments(graph, w, z)
    _draw_segments(draw, np.concatenate([segs["right"], segs["down"]]), INK, lw)
    decided = res.ambiguous
    _draw_segments(draw, _diagonal_segments(graph.diag_main & ~decided, w, z, False), INK, lw)
    _draw_segments(draw, _diagonal_segments(graph.diag_anti & ~decided, w, z, True), INK, lw)
    for anti, kept in ((False, graph.diag_main), (True, graph.diag_anti)):
        _draw_segments(draw, _diagonal_segments(decided & ~kept, w, z, anti), AMBIGUOUS_RED, lw, dashed=True)
        _draw_segments(draw, _diagonal_segments(decided & kept, w, z, anti), KEPT_GREEN, lw + 2)
    _draw_nodes(draw, result, z)
    return img


def _cells_panel(result: Stages, z: int):
    from PIL import Image, ImageDraw  # noqa: PLC0415

    cells = result.cells
    h, w = cells.shape
    img = Image.fromarray(_checkerboard(h, w, z), "RGB")
    draw = ImageDraw.Draw(img, "RGBA")
    pts = cells.nodes.astype(np.float64) * (z / 4.0)
    colours = cells.graph.rgba.reshape(-1, 4).tolist()
    ptr = cells.cell_ptr.tolist()
    for p in range(h * w):
        polygon = [tuple(xy) for xy in pts[cells.cell_nodes[ptr[p] : ptr[p + 1]]].tolist()]
        draw.polygon(polygon, fill=tuple(colours[p]), outline=INK + (255,))
    return img


def _curves_panel(splines, positions: np.ndarray, z: int):
    """Faded cells under the curves: the visible edges as drawn, each B-spline's control
    polygon and control points (``splines`` is a :class:`depixel.curves.splines.SplineSet`)."""
    from PIL import Image, ImageDraw  # noqa: PLC0415

    vector: VectorImage = splines.vector_image(positions)
    cells = vector.cells
    h, w = cells.shape
    img = Image.fromarray(np.full((h * z, w * z, 3), 255, np.uint8), "RGB")
    draw = ImageDraw.Draw(img)
    pts = vector.points * z
    ptr = cells.cell_ptr.tolist()
    colours = cells.graph.rgba.reshape(-1, 4)
    faded = np.round(_over(colours[None], np.full((1, 1, 3), 255.0))[0] * 0.3 + 255 * 0.7).astype(int).tolist()
    for p in range(h * w):  # the cells' colours, faded, as a hint of what the curves separate
        draw.polygon([tuple(xy) for xy in pts[cells.cell_nodes[ptr[p] : ptr[p + 1]]].tolist()], fill=tuple(faded[p]))

    ctrl = splines.controls_for(positions) * z
    curve_ptr = splines.curve_ptr.tolist()
    for c, closed in enumerate(splines.curve_closed.tolist()):
        polygon = [tuple(xy) for xy in ctrl[curve_ptr[c] : curve_ptr[c + 1]].tolist()]
        draw.line(polygon + polygon[:1] if closed else polygon, fill=CONTROL_ORANGE, width=1)

    left, right = cells.edge_pixels[:, 0], cells.edge_pixels[:, 1]
    visible = ~linked_edges(cells) & (left >= 0) & (right >= 0)
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    lw = max(1, z // 8)
    straight = visible & ~vector.curved
    _draw_segments(draw, np.stack([pts[u[straight]], pts[v[straight]]], axis=1), INK, lw)
    curved = np.flatnonzero(visible & vector.curved)
    if curved.size:
        for line in flatten_edges(pts[u[curved]], vector.controls[curved] * z, pts[v[curved]], 8).tolist():
            draw.line([tuple(p) for p in line], fill=INK, width=lw)
    r = max(1.5, z * 0.09)
    for x, y in ctrl.tolist():
        draw.ellipse([x - r, y - r, x + r, y + r], fill=CONTROL_ORANGE)
    return img


def _render_panel(result: Stages, z: int):
    from PIL import Image  # noqa: PLC0415

    from .raster import render_rgba  # noqa: PLC0415

    h, w = result.cells.shape
    rgba = render_rgba(to_svg(result.vector), width=w * z, height=h * z)
    return Image.fromarray(_over(rgba, _checkerboard(h, w, z)), "RGB")
