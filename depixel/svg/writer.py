"""Stage 7 — SVG export — Outlines → SVG text.

The geometry is decided by :mod:`depixel.svg.outlines`; this module only formats it:

* one ``<path>`` per shape, in drawing order, with ``fill="#rrggbb"`` (plus ``fill-opacity``
  when not opaque — never ``rgba()``, which Inkscape and Illustrator read as black);
* an ``id`` and an ``inkscape:label`` that say what the shape is (``outline-181425`` /
  "outline #181425", ``backdrop-5c94fc``, ``band-e0e0e0``…) so an editor's layers panel reads
  well; consecutive shapes of one region (paper §3.3) in a ``<g>`` when there are several;
* by default the smooth shading of paper §3.5: the bands of each smooth group blurred
  inside the group's outline (:mod:`depixel.svg.markup` writes these elements);
* compact path data: each command in absolute or relative form, whichever is shorter; a
  command letter left out where it repeats; ``H``/``V`` for axis-aligned lines; ``T`` for a
  quadratic whose control point mirrors the previous one (every inner span of a B-spline);
  no separator before a minus sign or before a ".5" that follows a number with a point; the
  last line of a loop left to ``Z``.

The text is assembled with whole-array operations (:mod:`depixel.svg.svgtext`).
"""
from __future__ import annotations

from functools import cache

import numpy as np

from .. import validate
from ..arrays import batch_bounds, nan_to_zero, ranges, set_rows
from ..params import Params
from ..vector import VectorImage
from .boundaries import CUBIC, LINE, QUAD
from .markup import Labels, elements
from .outlines import Outlines, OutlineShapes, outline_shapes
from .svgtext import Decimals, Texts, number, stack

SVG_HEADER = '<?xml version="1.0" encoding="UTF-8"?>\n'
#: default tolerance of the simplification (pixels), like potrace's opttolerance 0.2: fewer,
#: longer curves, every pixel centre and thin diagonal kept (docs/svg.md has the figures);
#: 0 writes the exact spline, one quadratic per span
DEFAULT_SIMPLIFY = 0.25
#: default decimals of the coordinates: a hundredth of a pixel, invisible at any zoom an
#: editor offers, and a fifth less text than thousandths
DEFAULT_PRECISION = 2
#: the largest tolerance accepted: beyond about a pixel a curve could stray over a feature
MAX_SIMPLIFY = 2.0
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
#: the xlink namespace, declared when the masks of the smooth shading refer to shapes
XLINK = ' xmlns:xlink="http://www.w3.org/1999/xlink"'
#: how the SVG shades a region of several tones: "smooth" blends them (paper §3.5, a filter
#: inside the region's outline), "flat" draws each tone as a flat band
SHADINGS = ("smooth", "flat")
#: not in paper: the SVG blur's standard deviation as a fraction of the paper's σ
#: (``Params.shading_sigma``). The paper weighs each cell by a Gaussian (σ = 1) at its
#: centroid, lowered by its value at the radius 2 and cut there: a cell's influence spreads
#: with a variance of 0.544 px² per axis. A blur weighs the cell's whole area, a Gaussian
#: convolved with the pixel's box (variance σ² + 1/12), so the blur of the same spread has
#: σ = √(0.544 − 1/12) = 0.68 (docs/svg.md, "σ")
SIGMA_RATIO = 0.68
#: the blur's standard deviation (pixels) unless told
DEFAULT_SIGMA = SIGMA_RATIO * Params().shading_sigma

# command codes, and their letters (absolute; relative is lower case) and number of arguments
M, L, H, V, Q, T, C, Z = range(8)
_LETTERS = "MLHVQTCZ"
_ARITY = np.array([2, 2, 1, 1, 4, 2, 6, 0])
_W = 6  # argument columns


def _xml_text(text: str) -> str:
    """``text`` with every character XML 1.0 forbids (control characters, lone surrogates
    from undecodable file names) replaced by U+FFFD, so the SVG always parses and encodes.
    A character loop, not a regex: compiling that character class costs ~8 ms per process."""
    def allowed(o: int) -> bool:
        return o in (9, 10, 13) or 0x20 <= o <= 0xD7FF or 0xE000 <= o <= 0xFFFD or 0x10000 <= o <= 0x10FFFF

    return "".join(c if allowed(ord(c)) else "\ufffd" for c in text)


def _escape(text: str) -> str:
    return _xml_text(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def to_svg(image: VectorImage, scale: float = 1.0, precision: int = DEFAULT_PRECISION, title: str | None = None,
           layout: str = "stacked", simplify: float = DEFAULT_SIMPLIFY, shading: str = "smooth",
           sigma: float = DEFAULT_SIGMA) -> str:
    """Write a VectorImage as SVG text; ``scale`` sets width/height, the viewBox stays W×H.

    ``layout`` and ``simplify`` are those of :func:`depixel.svg.outlines.build_outlines`.
    ``shading="smooth"`` blends the bands of every smooth group with a Gaussian of standard
    deviation ``sigma`` pixels inside the group's outline (paper §3.5, docs/svg.md);
    ``"flat"`` draws the bands alone (the same shapes and path data). The outlines are
    built and written a batch of shapes at a time, so those of the whole image are never
    held at once."""
    validate.choice("shading", shading, SHADINGS)
    validate.positive("sigma", sigma)
    shapes = outline_shapes(image, layout, grid=10.0**-precision, simplify=simplify)
    return _document(shapes, scale, precision, title, sigma if shading == "smooth" else None)


def _document(shapes: OutlineShapes, scale: float, precision: int, title: str | None, sigma: float | None) -> str:
    """The SVG document of ``shapes``, their outlines built a batch of consecutive shapes at a time,
    with the smooth shading of a Gaussian of ``sigma`` pixels (None: flat)."""
    h, w = shapes.shape
    width, height = number(w * scale, 3), number(h * scale, 3)
    labels = Labels(shapes, smooth=sigma is not None)
    head = (
        f'{SVG_HEADER}<svg xmlns="{"http://www.w3.org/2000/svg"}" xmlns:inkscape="{INKSCAPE_NS}"'
        f'{XLINK if sigma is not None and labels.smooth.masks else ""} version="1.1" '
        f'width="{width}" height="{height}" viewBox="0 0 {w} {h}">\n'
    )
    if title:
        head += f"<title>{_escape(title)}</title>\n"
    parts = [head, labels.smooth.defs(sigma) if sigma is not None else ""]
    first = 0
    for batch in shapes.batches():
        parts.append(elements(batch, first, labels, path_data(batch, precision)))
        first += len(batch)
    parts.append("</svg>\n")
    return "".join(parts)


#: shapes are formatted in batches of about this many segments, to bound temporary memory
#: (formatting costs a few hundred bytes a segment); the text does not depend on the batches
PATH_BATCH = 1 << 12


def path_data(outlines: Outlines, precision: int) -> list[str]:
    """The ``d`` attribute of every shape."""
    loop_ptr = outlines.loop_ptr.take(outlines.shape_ptr)
    segments = loop_ptr[1:] - loop_ptr[:-1]  # (S,) segments of each shape
    out: list[str] = []
    for a, b in batch_bounds(segments, PATH_BATCH):
        out += _path_data(outlines.shapes(a, b), precision)
    return out


def _path_data(outlines: Outlines, precision: int) -> list[str]:
    """:func:`path_data` of one batch of shapes."""
    unit = 10.0**precision
    cmd, args, per_loop = _commands(outlines, unit)
    n_cmd = cmd.size
    arity = _ARITY.take(cmd)
    cmd_ptr = np.zeros(per_loop.size + 1, np.int64)  # each shape's commands (a loop's: M, its segments, Z)
    per_loop.cumsum(out=cmd_ptr[1:])
    cmd_ptr = cmd_ptr.take(outlines.shape_ptr)
    new_shape = np.zeros(n_cmd + 1, bool)  # (the place after the last command too)
    new_shape[cmd_ptr] = True
    new_shape = new_shape[:-1]

    # relative arguments: from the current point (previous end; for M, the start of the
    # previous loop of the same path, or the origin)
    absolute = args  # (C, 6) int64 units, (x, y) pairs; H has x, V has y in column 0
    rel = _relative(cmd, absolute, new_shape)
    # the numbers the commands use: command num_cmd's argument column num_k, in order
    n_num = arity
    num_cmd = np.arange(n_cmd).repeat(n_num)
    num_k = ranges(0, n_num)
    flat = num_cmd * _W + num_k  # the number's place in (C, 6) argument tables
    texts, use_rel, glued = _format(absolute, rel, flat, num_cmd, num_k, n_cmd, precision)
    letter = np.where(use_rel, cmd + 8, cmd)  # 0-7 upper case, 8-15 lower case
    prev_letter = _prepend(-1, letter[:-1])
    implicit = ((letter == prev_letter) & (cmd != M) & (cmd != Z)) | \
        ((letter == L) & (prev_letter == M)) | ((letter == L + 8) & (prev_letter == M + 8))
    implicit &= ~new_shape
    explicit = ~implicit

    # token stream: per command an optional letter, then its numbers
    tok_count = explicit.astype(np.int64)
    tok_count += n_num
    tok_end = tok_count.cumsum()
    tok_start = tok_end - tok_count
    n_tok = int(tok_end[-1]) if n_cmd else 0
    letter_pos = tok_start.compress(explicit)
    num_pos = tok_start.take(num_cmd) + explicit.take(num_cmd) + num_k

    # separators: a space before a number that follows a number, unless it is glued to it.
    # A number follows a number (the one before it, in the same path) unless it is the first
    # of a command with a letter: an implicit command repeats one with numbers, and a path
    # starts with its M's letter
    follows = num_k > 0
    follows |= implicit.take(num_cmd)
    sep = np.zeros(n_tok, bool)
    sep[num_pos] = follows & ~glued

    letters, space = _constant_texts()
    table, (letter_row, abs_row, space_row) = stack([letters, texts, space])
    row = np.empty(n_tok, np.int64)
    row[letter_pos] = letter_row + letter.compress(explicit)
    row[num_pos] = np.arange(abs_row, abs_row + num_cmd.size)
    # interleave the separators: token i becomes [space] + token
    out_count = 1 + sep.astype(np.int64)
    out_start = out_count.cumsum() - out_count
    stream = np.empty(int(out_count.sum()), np.int64)
    stream[out_start + sep] = row
    stream[out_start[sep]] = space_row
    pieces = table.take(stream)
    # split per shape
    shape_tok_end = _prepend(0, tok_end).take(cmd_ptr[1:])
    out_end = np.concatenate((out_start, [stream.size])).take(shape_tok_end)
    text = pieces.tobytes().decode("ascii")
    byte_end = pieces.length.cumsum()
    bounds = _prepend(0, byte_end.take(out_end - 1))
    return [text[bounds[i] : bounds[i + 1]] for i in range(len(outlines))]


@cache
def _constant_texts() -> tuple[Texts, Texts]:
    """The command letters (upper then lower case) and the space, as tables (made once)."""
    return Texts.of(list(_LETTERS) + list(_LETTERS.lower())), Texts.of([" "])


def _prepend(first: int | bool, values: np.ndarray) -> np.ndarray:
    """``np.r_[first, values]`` (of ``values``' dtype) without the cost of ``np.r_``, ~10 µs
    a call, ten calls a batch of shapes."""
    out = np.empty(values.size + 1, values.dtype)
    out[0] = first
    out[1:] = values
    return out


def _commands(outlines: Outlines, unit: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Command codes and absolute arguments (``(C, 6)`` int64 in 10^-precision units) of
    every path: per loop M, its segments (the last one left out when it is a line: Z draws
    it), Z; and the number of commands of each loop."""
    kind = outlines.kind
    end = (outlines.end * unit).round().astype(np.int64)
    ctrl = (nan_to_zero(outlines.ctrl) * unit).round().astype(np.int64)
    ctrl2 = (nan_to_zero(outlines.ctrl2) * unit).round().astype(np.int64)
    n_loop = outlines.loop_ptr.size - 1
    loop_len = outlines.loop_ptr[1:] - outlines.loop_ptr[:-1]
    last = outlines.loop_ptr[1:] - 1
    start = end.take(last, axis=0)  # each loop starts where its last segment ends
    seg_start = np.empty_like(end)  # the previous segment's end; a loop's first: the loop's start
    seg_start[1:] = end[:-1]
    set_rows(seg_start, outlines.loop_ptr[:-1], start)
    last_line = kind.take(last) == LINE
    keep = np.ones(kind.size, bool)
    keep[last.compress(last_line)] = False
    # a quadratic whose control mirrors the previous quadratic's through its start is "T"
    smooth = kind == QUAD
    smooth[1:] &= smooth[:-1].copy()  # after a quadratic (the first of a loop is left out)
    smooth[outlines.loop_ptr[:-1]] = False
    for c in range(2):  # (a test over a short axis is slow)
        smooth[1:] &= ctrl[1:, c] == 2 * seg_start[1:, c] - ctrl[:-1, c]

    code = np.where(kind == LINE, L, np.where(kind == CUBIC, C, np.where(smooth, T, Q)))
    horizontal = (kind == LINE) & (end[:, 1] == seg_start[:, 1])
    vertical = (kind == LINE) & (end[:, 0] == seg_start[:, 0]) & ~horizontal
    code = np.where(horizontal, H, np.where(vertical, V, code))
    # the arguments column by column (whole columns: numpy handles rows of (K, 6) one by one):
    # lines and T their end (H its x, V its y), Q control and end, C both controls and end
    quad, cubic = code == Q, code == C
    curve = quad | cubic
    # interleave: loop l = [M start] + its kept segments + [Z], as rows of one table:
    # the segments' arguments, then each loop's M, then a row of zeros for Z
    n_seg = kind.size
    table = np.zeros((n_seg + n_loop + 1, _W), np.int64)
    segment_args = table[:n_seg]
    segment_args[:, 0] = np.where(curve, ctrl[:, 0], np.where(code == V, end[:, 1], end[:, 0]))
    segment_args[:, 1] = np.where(curve, ctrl[:, 1], end[:, 1])
    segment_args[:, 2] = np.where(quad, end[:, 0], np.where(cubic, ctrl2[:, 0], 0))
    segment_args[:, 3] = np.where(quad, end[:, 1], np.where(cubic, ctrl2[:, 1], 0))
    segment_args[:, 4] = np.where(cubic, end[:, 0], 0)
    segment_args[:, 5] = np.where(cubic, end[:, 1], 0)
    for c in range(2):
        table[n_seg : n_seg + n_loop, c] = start[:, c]
    per_loop = loop_len + 2
    per_loop -= last_line
    loop_end = per_loop.cumsum()
    loop_first = loop_end - per_loop
    total = int(loop_end[-1]) if n_loop else 0
    cmd = np.empty(total, np.int64)
    source = np.full(total, table.shape[0] - 1)  # the table row of every command
    cmd[loop_first] = M
    source[loop_first] = kind.size + np.arange(n_loop)
    cmd[loop_end - 1] = Z
    # the kept segments are each loop's first ones: segment j of loop l goes after l's M
    seg_index = keep.nonzero()[0]
    pos = (loop_first + 1 - outlines.loop_ptr[:-1]).repeat(per_loop - 2)
    pos += seg_index
    cmd[pos] = code.take(seg_index)
    source[pos] = seg_index
    return cmd, table.take(source, axis=0), per_loop


def _relative(cmd: np.ndarray, absolute: np.ndarray, new_shape: np.ndarray) -> np.ndarray:
    """The arguments relative to the current point before each command (``new_shape``: the
    command starts a path)."""
    n = cmd.size
    rows = np.arange(n)
    x_only, y_only, close = cmd == H, cmd == V, cmd == Z
    pair = ~(x_only | y_only | close)
    # end point of every command (Z returns to its loop's M; H and V set one coordinate)
    loop_m = np.maximum.accumulate(np.where(cmd == M, rows, 0))
    end_at = np.where(close, loop_m * _W, rows * _W + np.where(cmd == Q, 2, np.where(cmd == C, 4, 0)))
    flat = absolute.ravel()
    sets = pair | close
    end_x, end_y = np.where(sets, flat.take(end_at), 0), np.where(sets, flat.take(end_at + 1), 0)
    # propagate x (for V) and y (for H): the last command that set that coordinate
    x_src = np.maximum.accumulate(np.where(sets | x_only, rows, 0))
    y_src = np.maximum.accumulate(np.where(sets | y_only, rows, 0))
    x_val = np.where(x_only, absolute[:, 0], end_x)
    y_val = np.where(y_only, absolute[:, 0], end_y)
    # the current point before each command (the origin at a new path)
    before_x = np.where(new_shape, 0, _prepend(0, x_val.take(x_src[:-1])))
    before_y = np.where(new_shape, 0, _prepend(0, y_val.take(y_src[:-1])))
    two = (cmd == Q) | (cmd == C)  # commands with a second and a third point
    three = cmd == C
    relative = absolute.copy()  # (written a column at a time: np.stack of the offsets costs more)
    relative[:, 0] -= np.where(pair | x_only, before_x, np.where(y_only, before_y, 0))
    relative[:, 1] -= np.where(pair, before_y, 0)
    relative[:, 2] -= np.where(two, before_x, 0)
    relative[:, 3] -= np.where(two, before_y, 0)
    relative[:, 4] -= np.where(three, before_x, 0)
    relative[:, 5] -= np.where(three, before_y, 0)
    return relative


def _format(absolute: np.ndarray, relative: np.ndarray, flat: np.ndarray, num_cmd: np.ndarray, num_k: np.ndarray,
            n_cmd: int, precision: int) -> tuple[Texts, np.ndarray, np.ndarray]:
    """The compact text of the numbers the commands use (command ``num_cmd``'s argument
    column ``num_k``, at ``flat`` in the ``(C, 6)`` tables in 10^-precision units), each
    command's written relative where that makes its numbers shorter (absolute on a tie);
    which commands are relative; and which numbers are glued to the number before them
    (no space: it starts with "-", or with "." after a number with a point).

    The lengths of both forms are counted from their digits (no text), and only the chosen
    numbers are formatted: on a sprite's few thousand numbers the numpy calls cost about
    as much as the arithmetic, so both forms are measured in one table of 2N."""
    n = num_cmd.size
    values = np.empty((2, n), np.int64)
    absolute.ravel().take(flat, out=values[0])
    relative.ravel().take(flat, out=values[1])
    decimals = Decimals(values.ravel(), precision)
    n_whole, n_frac = decimals.digit_counts()
    minus = decimals.scaled < 0
    has_dot = decimals.frac != 0
    dot_start = decimals.whole == 0  # compact: "-.25", ".25"
    dot_start &= has_dot
    length = n_whole - dot_start  # the characters of each number's text
    length += minus
    length += has_dot
    length += n_frac
    dot_start &= ~minus
    glued = _glued(minus, dot_start, has_dot)  # (the first relative number's flag is not read)
    cost = length.reshape(2, n)
    cost += (num_k > 0) & ~glued.reshape(2, n)  # with the space before it, in its command
    use_rel = np.bincount(num_cmd, weights=cost[1] - cost[0], minlength=n_cmd) < 0  # (Z: no numbers)
    pick = np.arange(n)
    pick += use_rel.take(num_cmd) * n
    return (decimals.take(pick).texts(compact=True), use_rel,
            _glued(minus.take(pick), dot_start.take(pick), has_dot.take(pick)))


def _glued(minus: np.ndarray, dot_start: np.ndarray, has_dot: np.ndarray) -> np.ndarray:
    """Which numbers need no space after the number before them in order."""
    glued = minus.copy()
    glued[1:] |= dot_start[1:] & has_dot[:-1]
    return glued
