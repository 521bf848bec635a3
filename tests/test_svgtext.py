"""The vectorized text and loop kernels against slow, obviously-correct references."""
from __future__ import annotations

import numpy as np
import pytest

from depixel.svg.loops import trace_loops
from depixel.svg.svgtext import Decimals, Texts, number, numbers, stack


def reference_number(value: float, precision: int) -> str:
    q = int(np.round(value * 10**precision))
    whole, frac = divmod(abs(q), 10**precision)
    text = f"{whole}.{frac:0{precision}d}".rstrip("0") if frac else str(whole)
    return ("-" if q < 0 else "") + text


@pytest.mark.parametrize("precision", [0, 1, 3, 5])
def test_numbers_match_python_formatting(precision):
    rng = np.random.default_rng(precision)
    values = np.concatenate([rng.normal(0, 300, 2000), rng.integers(-40, 40, 200) / 4,
                             [0.0, -0.0, -0.0004, 0.0004, 1e9, -1e9, 0.5, -0.5]])
    assert numbers(values, precision).tolist() == [reference_number(v, precision) for v in values]


@pytest.mark.parametrize("precision", [0, 1, 3, 5])
def test_number_is_numbers_of_one_value(precision):
    """The scalar formatter of the document head and attributes writes what numbers() does."""
    rng = np.random.default_rng(10 + precision)
    values = np.concatenate([rng.normal(0, 300, 500), rng.integers(-40, 40, 100) / 4, np.arange(256) / 255.0,
                             [0.0, -0.0, -0.0004, 0.0004, 1e9, -1e9, 0.5, -0.5, 2.5, 0.0125]])
    assert [number(v, precision) for v in values.tolist()] == numbers(values, precision).tolist()


def reference_compact(value: float, precision: int) -> str:
    text = reference_number(value, precision)
    return text.replace("0.", ".", 1) if text.lstrip("-").startswith("0.") else text


@pytest.mark.parametrize("compact", [False, True])
@pytest.mark.parametrize("precision", [0, 1, 2, 3])
def test_path_numbers_by_table_look_ups_and_by_planes_agree_with_python(precision, compact):
    """Numbers of at most three whole and three fraction digits (the path data of images up
    to 999 pixels) are formatted from digit tables; with one larger number in the call, by
    character planes. Both give the reference text."""
    rng = np.random.default_rng(10 + precision)
    values = np.concatenate([rng.uniform(-990, 990, 3000), rng.uniform(-1.2, 1.2, 1000),
                             rng.integers(-4000, 4000, 500) / 8, [0.0, -0.0, 0.0004, -0.0004, 0.5, -0.5, 99.99, 989.999]])
    reference = [(reference_compact if compact else reference_number)(v, precision) for v in values]
    assert numbers(values, precision, compact=compact).tolist() == reference
    larger = numbers(np.append(values, 12345.5), precision, compact=compact).tolist()
    assert larger[:-1] == reference and larger[-1] == reference_number(12345.5, precision)


def test_numbers_rows_joined_with_spaces_and_prefix():
    assert numbers(np.array([[1.5, -2.0], [0.125, 10.0]]), 3, prefix="L").tolist() == ["L1.5 -2", "L0.125 10"]
    assert numbers(np.zeros((0, 4)), 3).tolist() == []


def test_compact_numbers_drop_the_leading_zero():
    values = np.array([0.5, -0.25, 0.0, 1.5, -3.0, 0.004, -0.0004])
    assert numbers(values, 3, compact=True).tolist() == [".5", "-.25", "0", "1.5", "-3", ".004", "0"]


def test_stack_and_take():
    a = Texts.of(["ab", "", "c"])
    b = numbers(np.array([1, 2, 3]), 0)
    table, first = stack([a, b, a.take(np.array([2, 0]))])
    assert first == [0, 3, 6]
    assert table.tolist() == ["ab", "", "c", "1", "2", "3", "c", "ab"]
    assert table.take(np.array([7, 3, 7])).tobytes() == b"ab1ab"


def reference_loops(owner, u, v):
    """Walk each loop from its smallest unvisited half-edge; pair the i-th half-edge into a
    node with the i-th out of it (index order), as trace_loops documents."""
    n = len(owner)
    out_of: dict = {}
    for i in range(n):
        out_of.setdefault((owner[i], u[i]), []).append(i)
    into: dict = {}
    for i in range(n):
        into.setdefault((owner[i], v[i]), []).append(i)
    nxt = {}
    for key, ins in into.items():
        for i, o in zip(ins, out_of[key]):
            nxt[i] = o
    seen, loops = set(), []
    for start in range(n):
        if start in seen:
            continue
        walk, i = [], start
        while i not in seen:
            seen.add(i)
            walk.append(i)
            i = nxt[i]
        loops.append((owner[start], walk))
    loops.sort(key=lambda item: (item[0], item[1][0]))
    return loops


def test_trace_loops_matches_reference_walk():
    rng = np.random.default_rng(7)
    for _ in range(30):
        # random closed walks (with repeated nodes, so loops touch themselves) per owner
        owner, u, v = [], [], []
        for o in rng.integers(0, 5, rng.integers(1, 8)):
            nodes = rng.integers(0, 6, rng.integers(2, 9))
            nodes = nodes[np.r_[True, nodes[1:] != nodes[:-1]]]
            if len(nodes) < 2 or nodes[0] == nodes[-1]:
                continue
            owner += [o] * len(nodes)
            u += nodes.tolist()
            v += np.roll(nodes, -1).tolist()
        if not owner:
            continue
        perm = rng.permutation(len(owner))
        owner, u, v = (np.array(a)[perm] for a in (owner, u, v))
        loops = trace_loops(owner, u, v)
        got = [(int(loops.owner[k]), loops.halfedges[loops.ptr[k] : loops.ptr[k + 1]].tolist())
               for k in range(len(loops))]
        assert got == reference_loops(owner.tolist(), u.tolist(), v.tolist())


def test_trace_loops_rejects_open_chains():
    with pytest.raises(ValueError):
        trace_loops(np.zeros(2, np.int64), np.array([0, 1]), np.array([1, 2]))


def _square_halfedges(cells: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boundary half-edges (clockwise on screen, y down) of the union of unit squares
    ``cells`` (x, y), with node ids from a 10-wide grid and the grid as points."""
    edges = set()
    for x, y in cells:
        corners = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)]
        for a, b in zip(corners, corners[1:] + corners[:1]):
            if (b, a) in edges:
                edges.discard((b, a))
            else:
                edges.add((a, b))
    uv = sorted(edges)
    u = np.array([a[1] * 10 + a[0] for a, _ in uv])
    v = np.array([b[1] * 10 + b[0] for _, b in uv])
    return u, v, np.array([(i % 10, i // 10) for i in range(100)])


def _area(loop_nodes: np.ndarray, points: np.ndarray) -> float:
    p = points[loop_nodes].astype(float)
    q = np.roll(p, -1, axis=0)
    return float((p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]).sum() / 2)


@pytest.mark.parametrize("cells, areas", [
    ([(0, 0), (1, 1)], [2.0]),  # squares touching at a corner: one outer boundary round both
    ([(x, y) for x in range(3) for y in range(3) if (x, y) not in ((1, 1), (2, 2))], [-1.0, 8.0]),  # hole at a notch
])
def test_trace_loops_with_points_keeps_touching_loops_apart(cells, areas):
    """Where a boundary touches itself at a node, the angle rule keeps the outside on the
    left: every loop is an outer boundary (clockwise, area > 0) or a hole (area < 0), never
    a mix — a hole that touches the outline at a corner is a loop of its own."""
    u, v, points = _square_halfedges(cells)
    loops = trace_loops(np.zeros(u.size, np.int64), u, v, points=points)
    got = sorted(_area(u[loops.halfedges[a:b]], points) for a, b in zip(loops.ptr[:-1], loops.ptr[1:]))
    assert got == areas


def test_path_numbers_written_relative_only_where_shorter():
    """svg._format measures the absolute and the relative numbers of each command, with the
    separators SVG needs, and formats only the shorter form (absolute on a tie); it says
    which numbers are glued to the one before (no space)."""
    from depixel.svg.writer import _W, _format

    # the used arguments (hundredths) of three commands: 2 of the first, 3 of the second, 1 of the third
    num_cmd, num_k = np.array([0, 0, 1, 1, 1, 2]), np.array([0, 1, 0, 1, 2, 0])
    absolute, relative = np.zeros((3, _W), np.int64), np.zeros((3, _W), np.int64)
    flat = num_cmd * _W + num_k
    absolute.ravel()[flat] = [-50, 25, 100, 7, 300, 1000]
    relative.ravel()[flat] = [-50, -25, 0, 0, 0, 2000]
    texts, use_rel, glued = _format(absolute, relative, flat, num_cmd, num_k, 3, 2)
    # "-.5.25" (6) against "-.5-.25" (7); "1 .07 3" (7) against "0 0 0" (5); "10" against "20"
    assert use_rel.tolist() == [False, True, False]
    assert texts.tolist() == ["-.5", ".25", "0", "0", "0", "10"]
    assert glued.tolist() == [True, True, False, False, False, False]


@pytest.mark.parametrize("precision", [0, 1, 3, 4, 6, 12])
def test_decimals_digit_counts_measure_the_texts(precision):
    """The digits counted without formatting add up to each number's text length, by the
    tables (at most 3 digits) and by the loops (more)."""
    rng = np.random.default_rng(20 + precision)
    values = np.concatenate([rng.uniform(-990, 990, 1000), rng.uniform(-1.2, 1.2, 300),
                             rng.integers(-4000, 4000, 200) / 8, [0.0, 0.0004, -0.5, 99.99, 1.25]])
    for extra in ([], [123456.5]):
        decimals = Decimals.rounded(np.append(values, extra), precision)
        n_whole, n_frac = decimals.digit_counts()
        counted = (decimals.scaled < 0) + n_whole + (n_frac > 0) + n_frac
        assert counted.tolist() == decimals.texts().length.tolist()
        assert decimals.take(np.arange(5)).texts().tolist() == decimals.texts().tolist()[:5]
