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

The text is assembled with whole-array operations (:mod:`depixel.svgtext`): a token table
of every drawing command, and one index array that lists the tokens of the document.
"""
from __future__ import annotations

import numpy as np

from .loops import Loops, trace_loops
from .svgtext import Texts, concat, numbers, stack
from .vector import VectorImage, faces_and_regions

SVG_HEADER = '<?xml version="1.0" encoding="UTF-8"?>\n'


def _xml_text(text: str) -> str:
    """``text`` with every character XML 1.0 forbids (control characters, lone surrogates
    from undecodable file names) replaced by U+FFFD, so the SVG always parses and encodes.
    A character loop, not a regex: compiling that character class costs ~8 ms per process."""
    def allowed(o: int) -> bool:
        return o in (9, 10, 13) or 0x20 <= o <= 0xD7FF or 0xE000 <= o <= 0xFFFD or 0x10000 <= o <= 0x10FFFF

    return "".join(c if allowed(ord(c)) else "\ufffd" for c in text)


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
    h, w = image.shape
    rgba = image.rgba.reshape(-1, 4)
    if per_cell is None:
        per_cell = image.stage == "cells"
    labels, region = faces_and_regions(image.cells, per_cell)
    assert region is not None
    n_faces = int(labels.max()) + 1
    face_pixel = np.zeros(n_faces, np.int64)
    face_pixel[labels[::-1]] = np.arange(labels.size)[::-1]  # first pixel of each face
    face_region = np.zeros(n_faces, np.int64)
    face_region[labels] = region
    rank = draw_order(labels, region)

    loops, tokens, token_of, start_row = _face_outlines(image, labels, rank, rgba[face_pixel, 3], precision)
    face_of_rank = np.empty(n_faces, np.int64)
    face_of_rank[rank] = np.arange(n_faces)
    body = _path_elements(loops, tokens, token_of, start_row, face_of_rank, face_region, rgba[face_pixel])

    width, height = numbers(np.array([w * scale, h * scale]), 3).tolist()
    head = (
        f'{SVG_HEADER}<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{width}" height="{height}" '
        f'viewBox="0 0 {w} {h}">\n'
    )
    if title:
        text = _xml_text(title).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        head += f"<title>{text}</title>\n"
    return head + body.decode("ascii") + "</svg>\n"


def _face_outlines(image: VectorImage, labels: np.ndarray, rank: np.ndarray, face_alpha: np.ndarray,
                   precision: int) -> tuple[Loops, Texts, np.ndarray, np.ndarray]:
    """Outline loops of every drawn face (owner = drawing rank) and the text of each step.

    Each cell is cut into corner pieces, one per polygon node: piece k of a cell is bounded
    by the second half of the edge into node k, the first half of the edge out of it, and
    two spokes to the pixel centre. A face's path covers the pieces of its own cells and,
    as the stacked underlay, every piece of a later opaque cell at a node the face touches.
    So around every node and along every edge, the earliest face present lies fully beneath
    the later ones, and no renderer can leave a partly transparent seam.

    Returns the loops over the boundary half-edges, a table of drawing commands, the row of
    each half-edge's command in it, and per loop the row of "L" + its first point (the
    loop's ``M`` uses that row without the "L").
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

    # faces present at each node, once each: (n_nodes, width) table padded with -1
    own = labels[piece_cell]
    by_node = np.lexsort((own, node))
    node_sorted, face_sorted = node[by_node], own[by_node]
    fresh = np.r_[True, (node_sorted[1:] != node_sorted[:-1]) | (face_sorted[1:] != face_sorted[:-1])]
    node_sorted, face_sorted = node_sorted[fresh], face_sorted[fresh]
    group_start = np.flatnonzero(np.r_[True, node_sorted[1:] != node_sorted[:-1]])
    group_of = np.repeat(np.arange(group_start.size), np.diff(np.r_[group_start, node_sorted.size]))
    slot = np.arange(node_sorted.size) - group_start[group_of]
    table = np.full((n_nodes, int(slot.max()) + 1), -1, np.int64)
    table[node_sorted, slot] = face_sorted

    # four half-edges per piece k of cell q (midpoint of edge e is point n_nodes + e, the
    # centre of q is point n_nodes + n_edges + q), with the piece across each:
    #   0: mid(edge into k) -> node k      across: the other cell's piece at this node
    #   1: node k -> mid(edge out of k)    across: the piece after the twin position
    #   2: mid(edge out of k) -> centre    across: k_next
    #   3: centre -> mid(edge into k)      across: k_prev
    edge_in, edge_out = cells.cell_edges[k_prev], cells.cell_edges
    mid_in, mid_out = n_nodes + edge_in, n_nodes + edge_out
    centre = n_nodes + n_edges + piece_cell
    twin_out = twin[k]
    across = np.stack([twin[k_prev], np.where(twin_out >= 0, k_next[np.maximum(twin_out, 0)], -1), k_next, k_prev],
                      axis=1)
    # Only a piece at a node shared by several faces, or on the image border, can have a
    # boundary half-edge: elsewhere the pieces across all four sides (at the same node or
    # in the same cell) belong to its own face, and no other face can use it as underlay.
    shared = table[:, 1] >= 0 if table.shape[1] > 1 else np.zeros(n_nodes, bool)
    ks = np.flatnonzero(shared[node] | (across < 0).any(axis=1))

    # membership (face, piece): own pieces, plus underlay pieces of later opaque cells
    drawn = face_alpha > 0
    opaque_own = face_alpha[own] == 255
    own_s = own[ks]
    candidate = table[node[ks]]  # (len(ks), width)
    cand = np.maximum(candidate, 0)
    under = (candidate >= 0) & (rank[cand] < rank[own_s][:, None]) & opaque_own[ks][:, None] & drawn[cand]
    member_key = np.sort(np.concatenate([
        own_s[drawn[own_s]] * n_piece + ks[drawn[own_s]],
        candidate[under] * n_piece + np.broadcast_to(ks[:, None], under.shape)[under],
    ]))
    member_face, member_piece = np.divmod(member_key, n_piece)

    def holds(face: np.ndarray, piece: np.ndarray) -> np.ndarray:
        """Whether (face, piece) is a membership, for member faces and pieces (-1: none)."""
        inside = piece >= 0
        piece = np.maximum(piece, 0)
        other = own[piece]
        result = inside & (other == face)
        maybe = np.flatnonzero(inside & ~result & opaque_own[piece] & (rank[face] < rank[other]))
        result[maybe] = (table[node[piece[maybe]]] == face[maybe, None]).any(axis=1)
        return result

    boundary = np.empty((member_key.size, 4), bool)
    for side in range(4):
        boundary[:, side] = ~holds(member_face, across[member_piece, side])
    which, part = np.nonzero(boundary)  # in (member, part) order, as the loops expect
    face_b, piece_b = member_face[which], member_piece[which]
    hu = np.stack([mid_in, node, mid_out, centre], axis=1)[piece_b, part]
    hv = np.stack([node, mid_out, centre, mid_in], axis=1)[piece_b, part]
    loops = trace_loops(rank[face_b], hu, hv)

    # drawing command of each boundary half-edge, as a command id: "L" + point i is id i;
    # half j of the c-th curved edge is id n_points + 4c + j (see _command_texts)
    n_points = n_nodes + n_edges + n_px
    curve_id = np.full(n_edges, -1, np.int64)
    curve_id[image.curved] = n_points + 4 * np.arange(int(image.curved.sum()))
    ein, eout, at = edge_in[piece_b], edge_out[piece_b], node[piece_b]
    into = np.where(image.curved[ein], curve_id[ein] + np.where(cells.edges[ein, 1] == at, 1, 3), at)
    out_of = np.where(image.curved[eout], curve_id[eout] + np.where(cells.edges[eout, 0] == at, 0, 2), mid_out[piece_b])
    command = np.choose(part, [into, out_of, centre[piece_b], mid_in[piece_b]])
    start = hu[loops.halfedges[loops.ptr[:-1]]]  # "L" + the first point of each loop, for its "M"
    used, row = np.unique(np.concatenate([command, start]), return_inverse=True)  # format only these
    return loops, _command_texts(image, used, precision), row[: command.size], row[command.size :]


def _command_texts(image: VectorImage, ids: np.ndarray, precision: int) -> Texts:
    """Text of the drawing commands with the given (sorted) ids, in that order.

    Points are the nodes, then the edge midpoints (the curve's middle control point when
    curved), then the pixel centres; id i is "L" + point i. The c-th curved edge e
    (u → v, controls c0 c1 c2) has ids ``n_points + 4c + j``: j = 0 "Q c0 mid" (u → mid),
    1 "Q c2 v" (mid → v), 2 "Q c2 mid" (v → mid), 3 "Q c0 u".
    """
    cells = image.cells
    h, w = image.shape
    u, v = cells.edges[:, 0], cells.edges[:, 1]
    pts = image.points
    n_points = len(pts) + len(u) + h * w
    line, quad = ids[ids < n_points], ids[ids >= n_points] - n_points

    def point(i: np.ndarray) -> np.ndarray:
        """(len(i), 2) coordinates of points i."""
        node = np.minimum(i, len(pts) - 1)
        e = np.clip(i - len(pts), 0, len(u) - 1)
        row, col = np.divmod(i - len(pts) - len(u), w)
        mid = np.where(image.curved[e, None], image.controls[e, 1], (pts[u[e]] + pts[v[e]]) / 2.0)
        centre = np.stack([col + 0.5, row + 0.5], axis=1)
        return np.where((i < len(pts))[:, None], pts[node], np.where((i < len(pts) + len(u))[:, None], mid, centre))

    curved = np.flatnonzero(image.curved)
    c, j = np.divmod(quad, 4)
    e = curved[c]
    control = np.where(((j == 0) | (j == 3))[:, None], image.controls[e, 0], image.controls[e, 2])
    end = np.choose(j, [len(pts) + e, v[e], len(pts) + e, u[e]])
    lines = numbers(point(line), precision, prefix="L")
    quads = numbers(np.concatenate([control, point(end)], axis=1), precision, prefix="Q")
    return stack([lines, quads])[0]


#: two hex digits of every byte value
_HEX = Texts.of([f"{i:02x}" for i in range(256)])


def _path_elements(loops: Loops, tokens: Texts, token_of: np.ndarray, start_row: np.ndarray,
                   face_of_rank: np.ndarray, face_region: np.ndarray, face_rgba: np.ndarray) -> bytes:
    """The ``<g>`` and ``<path>`` elements: every face with loops, in drawing order.

    Each face is ``<path id="face-F" fill="#rrggbb" d="`` + per loop ``M x y`` + its steps
    + ``Z`` + ``"/>``, inside ``<g id="region-R">`` groups of consecutive faces.
    """
    n_loops = len(loops)
    if n_loops == 0:
        return b""
    loop_rank = loops.owner
    new_face = np.r_[True, loop_rank[1:] != loop_rank[:-1]]
    face_first_loop = np.flatnonzero(new_face)
    face_end_loop = np.r_[face_first_loop[1:], n_loops]
    loop_face = np.cumsum(new_face) - 1  # index among the drawn faces

    face = face_of_rank[loop_rank[face_first_loop]]
    n = face.size
    region = face_region[face]
    opens = np.r_[True, region[1:] != region[:-1]]
    closes = np.r_[False, opens[1:]]
    rgba = face_rgba[face]
    translucent = rgba[:, 3] != 255
    # one formatting pass; whole numbers print the same at any precision
    formatted = numbers(np.concatenate([face, region, rgba[:, 3] / 255.0]), 3)
    face_text, region_text, alpha_text = (formatted.take(np.arange(i * n, (i + 1) * n)) for i in range(3))
    header = concat(
        _where(closes, "</g>\n"), _where(opens, '<g id="region-'), _blank(region_text, opens), _where(opens, '">\n'),
        '<path id="face-', face_text, '" fill="#', _HEX.take(rgba[:, 0]), _HEX.take(rgba[:, 1]), _HEX.take(rgba[:, 2]),
        '"', _where(translucent, ' fill-opacity="'), _blank(alpha_text, translucent), _where(translucent, '"'), ' d="',
    )
    points = Texts(tokens.data, tokens.start + 1, tokens.length - 1)  # "L x y" rows without the "L"
    table, (_, point_row, header_row, const_row) = stack([tokens, points, header, Texts.of(['"/>\n', "Z", "M"])])
    closer, close_path, move = const_row, const_row + 1, const_row + 2

    ptr = loops.ptr
    n_steps = ptr[-1]
    stream = np.empty(n_steps + 3 * n_loops + 2 * face.size, np.int64)
    # positions: before step i of loop l of face f come i steps, 3 rows (M, point, Z) per
    # earlier loop, M and point of this loop, and header + closer of each earlier face
    step_loop = np.repeat(np.arange(n_loops), np.diff(ptr))
    stream[np.arange(n_steps) + 3 * step_loop + 2 * loop_face[step_loop] + 3] = token_of[loops.halfedges]
    loop_pos = ptr[:-1] + 3 * np.arange(n_loops) + 2 * loop_face
    stream[loop_pos + 1] = move
    stream[loop_pos + 2] = point_row + start_row
    stream[ptr[1:] + 3 * np.arange(n_loops) + 2 * loop_face + 3] = close_path
    faces = np.arange(face.size)
    stream[ptr[face_first_loop] + 3 * face_first_loop + 2 * faces] = header_row + faces
    stream[ptr[face_end_loop] + 3 * face_end_loop + 2 * faces + 1] = closer
    return table.take(stream).tobytes() + b"</g>\n"


def _where(keep: np.ndarray, text: str) -> Texts:
    """``text`` where ``keep`` is True, else the empty string."""
    return Texts(np.frombuffer(text.encode("ascii"), np.uint8), np.zeros(keep.size, np.int64),
                 np.where(keep, len(text), 0))


def _blank(texts: Texts, keep: np.ndarray) -> Texts:
    """The same strings, emptied where ``keep`` is False."""
    return Texts(texts.data, texts.start, np.where(keep, texts.length, 0))
