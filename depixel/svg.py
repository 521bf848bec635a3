"""Stage 6 — SVG export — VectorImage → SVG text.

Each face (linked cells of one colour; one per cell for the cells stage) becomes one
``<path>``; faces are grouped per region (``<g id="region-N">``). Curved edges are written
exactly as quadratic Béziers (``Q``), straight ones as ``L``.

Seams (docs/design.md, "Seams"): two shapes that abut along a shared curve are each
anti-aliased, and the pixels on the curve end up partly transparent (conflation). To avoid
this, faces are drawn in a fixed order (larger regions first) and each opaque face's path
also covers the cells of the opaque faces drawn after it that share an edge with it — the
"stacked" layout. Every boundary then has an opaque underlay beneath it, in every renderer,
while each face still shows exactly its own cells.
"""
from __future__ import annotations

import re

import numpy as np

from .loops import trace_loops
from .vector import VectorImage, faces as face_labels, regions as region_labels

SVG_HEADER = '<?xml version="1.0" encoding="UTF-8"?>\n'
#: Characters XML 1.0 forbids (control characters, lone surrogates from undecodable file
#: names); a title has them replaced by U+FFFD so the SVG always parses and encodes.
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def format_numbers(values: np.ndarray, precision: int) -> np.ndarray:
    """Fixed-precision decimal strings without trailing zeros (byte-stable, no "-0")."""
    scaled = np.round(np.asarray(values, dtype=np.float64) * 10**precision).astype(np.int64)
    uniq, inverse = np.unique(scaled, return_inverse=True)
    texts = []
    for q in uniq.tolist():
        sign = "-" if q < 0 else ""
        whole, frac = divmod(abs(q), 10**precision)
        if frac and precision:
            texts.append(f"{sign}{whole}.{frac:0{precision}d}".rstrip("0"))
        else:
            texts.append(f"{sign}{whole}")
    return np.array(texts, dtype=object)[inverse.reshape(scaled.shape)]


def hex_colour(rgb) -> str:
    return "#{:02x}{:02x}{:02x}".format(*(int(c) for c in rgb[:3]))


def draw_order(labels: np.ndarray, region: np.ndarray) -> np.ndarray:
    """Rank of every face in drawing order: larger regions first, then larger faces, then
    scanline order of the first pixel (labels are already numbered that way)."""
    n_faces = int(labels.max()) + 1
    face_size = np.bincount(labels, minlength=n_faces)
    region_size = np.bincount(region)
    face_region = np.zeros(n_faces, np.int64)
    face_region[labels] = region
    order = np.lexsort((np.arange(n_faces), -face_size, face_region, -region_size[face_region]))
    rank = np.empty(n_faces, np.int64)
    rank[order] = np.arange(n_faces)
    return rank


def to_svg(image: VectorImage, scale: float = 1.0, precision: int = 3, per_cell: bool | None = None,
           title: str | None = None) -> str:
    """Write a VectorImage as SVG text; ``scale`` sets width/height, the viewBox stays W×H."""
    from xml.sax.saxutils import escape, quoteattr

    h, w = image.shape
    rgba = image.rgba.reshape(-1, 4)
    if per_cell is None:
        per_cell = image.stage == "cells"
    labels = face_labels(image.cells, per_cell=per_cell)
    region = region_labels(image.cells)
    n_faces = int(labels.max()) + 1
    face_pixel = np.zeros(n_faces, np.int64)
    face_pixel[labels[::-1]] = np.arange(labels.size)[::-1]  # first pixel of each face
    face_alpha = rgba[face_pixel, 3]
    rank = draw_order(labels, region)

    paths = _face_paths(image, labels, rank, face_alpha, precision)
    face_of_rank = np.empty(n_faces, np.int64)
    face_of_rank[rank] = np.arange(n_faces)

    parts = []
    width, height = format_number(w * scale), format_number(h * scale)
    parts.append(SVG_HEADER)
    parts.append(
        f'<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{width}" height="{height}" '
        f'viewBox="0 0 {w} {h}">\n'
    )
    if title:
        parts.append(f"<title>{escape(_NOT_XML.sub(chr(0xFFFD), title))}</title>\n")
    face_region = np.zeros(n_faces, np.int64)
    face_region[labels] = region
    open_region = None
    for r in sorted(paths):
        f = int(face_of_rank[r])
        reg = int(face_region[f])
        if reg != open_region:
            if open_region is not None:
                parts.append("</g>\n")
            parts.append(f'<g id="region-{reg}">\n')
            open_region = reg
        colour = rgba[face_pixel[f]]
        opacity = "" if colour[3] == 255 else f' fill-opacity="{format_number(colour[3] / 255.0)}"'
        parts.append(f'<path id="face-{f}" fill="{hex_colour(colour)}"{opacity} d={quoteattr(paths[r])}/>\n')
    if open_region is not None:
        parts.append("</g>\n")
    parts.append("</svg>\n")
    return "".join(parts)


def _face_paths(image: VectorImage, labels: np.ndarray, rank: np.ndarray, face_alpha: np.ndarray,
                precision: int) -> dict[int, str]:
    """Path data of every drawn face, keyed by drawing rank.

    Each cell is cut into corner pieces, one per polygon node: piece k of a cell is bounded
    by the second half of the edge into node k, the first half of the edge out of it, and
    two spokes to the pixel centre. A face's path covers the pieces of its own cells and,
    as the stacked underlay, every piece of a later opaque cell at a node the face touches.
    So around every node and along every edge, the earliest face present lies fully beneath
    the later ones, and no renderer can leave a partly transparent seam.
    """
    cells = image.cells
    n_px = labels.size
    n_nodes, n_edges = len(image.points), len(cells.edges)
    n_piece = cells.cell_nodes.size
    piece_cell = np.repeat(np.arange(n_px), np.diff(cells.cell_ptr))
    k = np.arange(n_piece)
    last = cells.cell_ptr[1:][piece_cell] - 1
    first = cells.cell_ptr[:-1][piece_cell]
    k_next = np.where(k == last, first, k + 1)
    k_prev = np.where(k == first, last, k - 1)
    node = cells.cell_nodes
    # the polygon position of the same edge in the cell on its other side (-1 on the border)
    by_edge = np.argsort(cells.cell_edges, kind="stable")
    sorted_edges = cells.cell_edges[by_edge]
    twin = np.full(n_piece, -1, np.int64)
    pair = np.flatnonzero(sorted_edges[1:] == sorted_edges[:-1])
    twin[by_edge[pair]] = by_edge[pair + 1]
    twin[by_edge[pair + 1]] = by_edge[pair]

    # membership (face, piece): own pieces, plus underlay pieces of later opaque cells
    own = labels[piece_cell]
    by_node = np.lexsort((own, node))
    node_sorted, face_sorted = node[by_node], own[by_node]
    group_start = np.flatnonzero(np.r_[True, node_sorted[1:] != node_sorted[:-1]])
    group_of = np.repeat(np.arange(group_start.size), np.diff(np.r_[group_start, n_piece]))
    slot = np.arange(n_piece) - group_start[group_of]
    width = int(slot.max()) + 1
    table = np.full((n_nodes, width), -1, np.int64)
    table[node_sorted, slot] = face_sorted
    candidate = table[node]  # (n_piece, width) faces present at each piece's node
    valid = candidate >= 0
    cand = np.maximum(candidate, 0)
    under = valid & (cand != own[:, None]) & (rank[cand] < rank[own][:, None])
    under &= (face_alpha[own] == 255)[:, None] & (face_alpha[cand] > 0)
    member_face = np.concatenate([own, candidate[under]])
    member_piece = np.concatenate([k, np.broadcast_to(k[:, None], under.shape)[under]])
    drawn = face_alpha[member_face] > 0
    member_key = np.unique(member_face[drawn] * n_piece + member_piece[drawn])
    member_face, member_piece = np.divmod(member_key, n_piece)

    # four half-edges per member piece k of cell q (midpoint of edge e is node n_nodes + e,
    # the centre of q is node n_nodes + n_edges + q):
    #   0: mid(edge into k) -> node k      1: node k -> mid(edge out of k)
    #   2: mid(edge out of k) -> centre    3: centre -> mid(edge into k)
    edge_in, edge_out = cells.cell_edges[k_prev], cells.cell_edges
    mf = np.repeat(member_face, 4)
    mp = np.repeat(member_piece, 4)
    part = np.tile(np.arange(4), member_piece.size)
    mid_in, mid_out = n_nodes + edge_in[mp], n_nodes + edge_out[mp]
    centre = n_nodes + n_edges + piece_cell[mp]
    hu = np.choose(part, [mid_in, node[mp], mid_out, centre])
    hv = np.choose(part, [node[mp], mid_out, centre, mid_in])
    # the piece on the other side: across the edge into k it is the other cell's piece at
    # the same node (the one after the twin position), across the edge out of k the twin
    twin_in, twin_out = twin[k_prev[mp]], twin[mp]
    across_in = np.where(twin_in >= 0, twin_in, -1)
    across_out = np.where(twin_out >= 0, k_next[np.maximum(twin_out, 0)], -1)
    neighbour = np.choose(part, [across_in, across_out, k_next[mp], k_prev[mp]])
    edge_of = np.where(part == 0, edge_in[mp], edge_out[mp])
    boundary = (neighbour < 0) | ~np.isin(mf * n_piece + neighbour, member_key)
    mf, part, hu, hv, edge_of = mf[boundary], part[boundary], hu[boundary], hv[boundary], edge_of[boundary]
    loops = trace_loops(rank[mf], hu, hv)

    point_text, half_text = _half_edge_strings(image, precision)
    code = np.choose(part, [
        4 * edge_of + np.where(cells.edges[edge_of, 1] == hv, 1, 3),  # second half, forward / backward
        4 * edge_of + np.where(cells.edges[edge_of, 0] == hu, 0, 2),  # first half, forward / backward
        -1, -1,
    ])
    code_list, hu_list, hv_list = code.tolist(), hu.tolist(), hv.tolist()
    order, loop_ptr = loops.halfedges.tolist(), loops.ptr.tolist()
    paths: dict[int, list[str]] = {}
    for li, r in enumerate(loops.owner.tolist()):
        seg = order[loop_ptr[li] : loop_ptr[li + 1]]
        text = ["M" + point_text[hu_list[seg[0]]]]
        for x in seg:
            c = code_list[x]
            text.append(half_text[c] if c >= 0 else "L" + point_text[hv_list[x]])
        text.append("Z")
        paths.setdefault(r, []).append("".join(text))
    return {r: "".join(parts) for r, parts in paths.items()}


def _half_edge_strings(image: VectorImage, precision: int) -> tuple[list[str], list[str]]:
    """Text of every point (nodes, edge midpoints, pixel centres) and of every half edge.

    ``half_text[4e + j]``: j = 0 u → mid, 1 mid → v, 2 v → mid, 3 mid → u.
    """
    cells = image.cells
    h, w = image.shape
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    pts = image.points
    mids = np.where(image.curved[:, None], image.controls[:, 1], (pts[u] + pts[v]) / 2.0)
    rows, cols = np.divmod(np.arange(h * w), w)
    centres = np.stack([cols + 0.5, rows + 0.5], axis=1)
    allpts = format_numbers(np.concatenate([pts, mids, centres]), precision)
    point_text = [f"{x} {y}" for x, y in allpts.tolist()]
    ctl = format_numbers(image.controls, precision).tolist()
    n_nodes = len(pts)
    half_text = []
    for e, (a, b, curved) in enumerate(zip(u.tolist(), v.tolist(), image.curved.tolist())):
        mid = point_text[n_nodes + e]
        if curved:
            (c0x, c0y), _, (c2x, c2y) = ctl[e]
            half_text += [f"Q{c0x} {c0y} {mid}", f"Q{c2x} {c2y} {point_text[b]}",
                          f"Q{c2x} {c2y} {mid}", f"Q{c0x} {c0y} {point_text[a]}"]
        else:
            half_text += ["L" + mid, "L" + point_text[b], "L" + mid, "L" + point_text[a]]
    return point_text, half_text


def format_number(value: float, precision: int = 3) -> str:
    """One number formatted like :func:`format_numbers`."""
    return str(format_numbers(np.array([value]), precision)[0])
