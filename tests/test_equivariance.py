"""Issue 31 — the optimized curves depend on the picture alone: a mirrored or quarter-turned
image gives the mirrored or turned curves, a mirror-symmetric sprite a mirror-symmetric
drawing, and a one-pixel edit leaves the curves far from it as they were. Hand-made patterns
always; corpus sprites when ../shared is present. Each test was made red by breaking the
behaviour (see the commit that added it)."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from conftest import CORPUS, FIXTURES, art, needs_corpus

from depixel.pipeline import depixelize
from depixel.prepare.image import load_image
from depixel.render.raster import render_rgba
from depixel.svg.outlines import outline_shapes
from depixel.svg.writer import DEFAULT_SIMPLIFY, to_svg

#: (name, image transform, map of a node (qx, qy) in quarter pixels of the transformed image back
#: to the original's, given the original's width and height in pixels)
Transform = tuple[str, Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray, int, int], np.ndarray]]
TRANSFORMS: list[Transform] = [
    ("mirror_x", lambda a: a[:, ::-1], lambda p, w, h: np.stack([w - p[:, 0], p[:, 1]], axis=1)),
    ("mirror_y", lambda a: a[::-1], lambda p, w, h: np.stack([p[:, 0], h - p[:, 1]], axis=1)),
    ("turn", np.rot90, lambda p, w, h: np.stack([w - p[:, 1], p[:, 0]], axis=1)),  # (x, y) -> (y, w - x)
]

#: hand-made patterns: thin lines, T-junctions of three colours, staircases, corners, a ring
PATTERNS = {
    "invader": """
    ..#.....#..
    ...#...#...
    ..#######..
    .##.###.##.
    ###########
    #.#######.#
    #.#.....#.#
    ...##.##...
    """,
    "three colours": """
    ..........
    .rrrr.....
    .rrrrgg...
    .rrrggggg.
    ..bbbgggg.
    ..bbbbgg..
    ...bbb....
    ..........
    """,
    "ring and staircase": """
    ............
    ...####.....
    ..##..##....
    ..#....#..##
    ..##..##.###
    ...####.####
    ......######
    ............
    """,
}
FIXTURE_NAMES = ["ghost.png", "mushroom.png", "heart.png"]
CORPUS_NAMES = ["smw_boo.png", "sma_toad.png", "win31_386.png", "mana_rabite.png", "smw_yoshi.png", "invaders_01.png"]


def pattern(name: str) -> np.ndarray:
    if name in PATTERNS:
        return art(PATTERNS[name])
    path = FIXTURES / name if (FIXTURES / name).is_file() else CORPUS / name
    return load_image(path)


def optimized(img: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The nodes (N, 2) in quarter pixels, their optimized positions (N, 2) and whether each is
    on a curve (N,)."""
    opt = depixelize(np.ascontiguousarray(img)).optimized
    on_curve = np.zeros(len(opt.positions), bool)
    on_curve[opt.splines.curve_nodes] = True
    return opt.splines.cells.nodes.astype(np.int64), opt.positions, on_curve


def by_node(nodes: np.ndarray) -> np.ndarray:
    """The order of the nodes by their quarter-pixel coordinates."""
    return np.lexsort((nodes[:, 1], nodes[:, 0]))


def assert_equivariant(img: np.ndarray, transform: Transform) -> None:
    """The optimized positions of the transformed image, mapped back, are the original's
    within 1e-6 px (the same nodes: the cells of these images are equivariant)."""
    _, image_of, back = transform
    h, w = img.shape[:2]
    nodes, positions, on_curve = optimized(img)
    their_nodes, their_positions, _ = optimized(image_of(img))
    mapped = back(their_nodes, 4 * w, 4 * h)
    mine, theirs = by_node(nodes), by_node(mapped)
    assert np.array_equal(nodes[mine], mapped[theirs]), "the cells differ: not a case for this test"
    difference = np.abs(positions[mine] - back(their_positions[theirs], w, h)).max(axis=1)
    moved = on_curve[mine] & (np.abs(positions[mine] - nodes[mine] / 4.0).max(axis=1) > 1e-3)
    assert moved.sum() >= 3, "nothing to compare: the case moves no curve"
    worst = int(difference.argmax())
    assert difference.max() < 1e-6, f"node {nodes[mine][worst] / 4} differs by {difference.max():.2e} px"


@pytest.mark.parametrize("transform", TRANSFORMS, ids=[t[0] for t in TRANSFORMS])
@pytest.mark.parametrize("name", [*PATTERNS, *FIXTURE_NAMES])
def test_a_turned_or_mirrored_pattern_gives_the_turned_or_mirrored_curves(name, transform):
    assert_equivariant(pattern(name), transform)


@needs_corpus
@pytest.mark.parametrize("transform", TRANSFORMS, ids=[t[0] for t in TRANSFORMS])
@pytest.mark.parametrize("name", CORPUS_NAMES)
def test_a_turned_or_mirrored_sprite_gives_the_turned_or_mirrored_curves(name, transform):
    assert_equivariant(pattern(name), transform)


def assert_symmetric(img: np.ndarray) -> None:
    """A sprite equal to its mirror image: its optimized positions are mirror-symmetric within
    1e-9 px, and its SVG (exact splines, ``--simplify 0``) renders as its own mirror image but
    for anti-aliasing (at most 0.1 % of the pixels of an 8x rendering differ by more than 64)."""
    assert np.array_equal(img, img[:, ::-1])
    h, w = img.shape[:2]
    nodes, positions, _ = optimized(img)
    mirrored = np.stack([4 * w - nodes[:, 0], nodes[:, 1]], axis=1)
    mine, theirs = by_node(nodes), by_node(mirrored)
    assert np.array_equal(nodes[mine], mirrored[theirs])
    image_of = np.stack([w - positions[:, 0], positions[:, 1]], axis=1)
    assert np.abs(positions[mine] - image_of[theirs]).max() < 1e-9
    rendered = render_rgba(to_svg(depixelize(img).vector, simplify=0), width=8 * w, height=8 * h).astype(int)
    differ = np.abs(rendered - rendered[:, ::-1]).max(axis=-1) > 64
    assert differ.mean() <= 0.001, f"{differ.mean():.4%} of the pixels differ from the mirror image"


def test_a_mirror_symmetric_pattern_gives_a_mirror_symmetric_drawing():
    assert_symmetric(pattern("invader"))


@needs_corpus
@pytest.mark.parametrize("name", ["invaders_01.png", "invaders_03.png"])
def test_a_mirror_symmetric_sprite_gives_a_mirror_symmetric_drawing(name):
    assert_symmetric(pattern(name))


def drawn(img: np.ndarray) -> dict[tuple[int, ...], np.ndarray]:
    """Every curved edge of the optimized drawing, keyed by its nodes' quarter-pixel
    coordinates: its end points and controls rounded as the SVG writes them (0.01 px)."""
    vector = depixelize(np.ascontiguousarray(img)).vector
    nodes = vector.cells.nodes.astype(np.int64)
    out = {}
    for edge in np.flatnonzero(vector.curved):
        u, v = vector.cells.edges[edge]
        key = tuple(sorted([tuple(nodes[u]), tuple(nodes[v])]))
        numbers = np.concatenate([vector.points[[u, v]].ravel(), vector.controls[edge].ravel()])
        out[sum(key, ())] = np.round(numbers, 2)
    return out


#: how far (px) a one-pixel edit may change the drawing: a change travels at most two slots
#: a round along a curve and fades as it goes; over the corpus edits measured it stopped
#: within 7 px (docs/design.md, Optimization)
REACH = 8.0


def far_changes(img: np.ndarray, x: int, y: int, reach: float = REACH) -> list[tuple[float, ...]]:
    """The curved edges farther than ``reach`` px (both nodes, Chebyshev) from the centre of
    pixel (x, y) whose drawing changes when that pixel takes another colour."""
    before, after = drawn(img), drawn(edited_pixel(img, x, y))
    changed = []
    for key, numbers in before.items():
        ends = np.array(key, float).reshape(2, 2) / 4.0
        if (np.abs(ends - [x + 0.5, y + 0.5]).max(axis=1) > reach).all():
            if key not in after or not np.array_equal(after[key], numbers):
                changed.append(tuple(ends.ravel()))
    return changed


@pytest.mark.parametrize("name", ["ring and staircase", "ghost.png", "mushroom.png"])
def test_a_one_pixel_edit_leaves_the_curves_far_from_it_as_they_were(name):
    img = pattern(name)
    opaque = np.argwhere(img[..., 3] == 255)
    for y, x in opaque[np.random.default_rng(7).choice(len(opaque), 4, replace=False)]:
        assert far_changes(img, int(x), int(y)) == [], (x, y)


@needs_corpus
@pytest.mark.parametrize("name", ["smw_boo.png", "sma_toad.png", "win31_386.png", "mana_rabite.png", "smw_yoshi.png"])
def test_a_one_pixel_edit_of_a_sprite_leaves_the_curves_far_from_it_as_they_were(name):
    img = pattern(name)
    opaque = np.argwhere(img[..., 3] == 255)
    for y, x in opaque[np.random.default_rng(11).choice(len(opaque), 3, replace=False)]:
        assert far_changes(img, int(x), int(y)) == [], (x, y)


def edited_pixel(img: np.ndarray, x: int, y: int) -> np.ndarray:
    """``img`` with pixel (x, y) given another colour: the one below it, else its inverse (as
    ``shape_checks.py locality`` edits)."""
    edited = img.copy()
    below = img[min(y + 1, img.shape[0] - 1), x, :3]
    edited[y, x, :3] = below if (img[y, x, :3] != below).any() else 255 - img[y, x, :3]
    return edited


@pytest.mark.parametrize("simplify", [0.0, DEFAULT_SIMPLIFY], ids=["exact", "simplified"])
def test_a_one_pixel_edit_changes_no_rendered_pixel_farther_than_four_pixels(simplify):
    # the measure of shape_checks.py locality: an 8x rendering, pixels differing by more than
    # 64 levels farther than 4 source pixels from the edited one (at the default simplify too:
    # the simplified curves are cut and fitted from their neighbourhood alone)
    for name in ("ring and staircase", "ghost.png"):
        img = pattern(name)
        h, w = img.shape[:2]
        before = render_rgba(to_svg(depixelize(img).vector, simplify=simplify), width=8 * w, height=8 * h).astype(int)
        opaque = np.argwhere(img[..., 3] == 255)
        for y, x in opaque[np.random.default_rng(3).choice(len(opaque), 3, replace=False)]:
            edited = img.copy()
            edited[y, x, :3] = 255 - img[y, x, :3]
            after = render_rgba(to_svg(depixelize(edited).vector, simplify=simplify), width=8 * w,
                                height=8 * h).astype(int)
            yy, xx = np.nonzero(np.abs(after - before).max(axis=-1) > 64)
            far = (np.abs(yy / 8 - (y + 0.5)) > 4.5) | (np.abs(xx / 8 - (x + 0.5)) > 4.5)
            assert far.sum() == 0, (name, x, y, int(far.sum()))


def simplified_segments(img: np.ndarray) -> dict[tuple[tuple[float, float], ...], set[tuple[float, ...]]]:
    """Every segment of the boundary pieces at the default ``--simplify``, as the SVG writes
    them (0.01 px): keyed by its two end points (in order, so a piece walked the other way
    gives the same key), the set of its kind and control points."""
    p = outline_shapes(depixelize(np.ascontiguousarray(img)).vector, grid=0.01, simplify=DEFAULT_SIMPLIFY).pieces
    piece = np.arange(len(p)).repeat(np.diff(p.ptr))
    first = p.ptr[:-1].take(piece) == np.arange(p.kind.size)
    start = np.where(first[:, None], p.start.take(piece, axis=0), np.roll(p.end, 1, axis=0))
    numbers = np.nan_to_num(np.round(np.stack([start, p.ctrl, p.ctrl2, p.end], axis=1), 2), nan=-1.0)
    out: dict[tuple[tuple[float, float], ...], set[tuple[float, ...]]] = {}
    for kind, (a, c1, c2, b) in zip(p.kind.tolist(), numbers.tolist()):
        if tuple(b) < tuple(a):  # (a cubic walked backwards has its controls swapped)
            a, b, c1, c2 = b, a, (c2 if kind == 2 else c1), (c1 if kind == 2 else c2)
        out.setdefault((tuple(a), tuple(b)), set()).add((kind, *c1, *c2))
    return out


#: how far (px) a one-pixel edit may change a simplified segment's nearer end: the exact
#: curves change within REACH, and a fitted curve runs from there over at most a stretch
#: between two cuts of the curve's own (docs/design.md, Locality); over the corpus edits
#: measured none farther than 4.6 px
SIMPLIFIED_REACH = 8.0


def far_simplified_changes(img: np.ndarray, x: int, y: int) -> list[tuple[tuple[float, float], ...]]:
    """The simplified segments with both ends farther than :data:`SIMPLIFIED_REACH` px
    (Chebyshev) from the centre of pixel (x, y) whose numbers change when it takes another colour."""
    before, after = simplified_segments(img), simplified_segments(edited_pixel(img, x, y))
    return [key for key, numbers in before.items()
            if (np.abs(np.array(key) - [x + 0.5, y + 0.5]).max(axis=1) > SIMPLIFIED_REACH).all()
            and after.get(key) != numbers]


@pytest.mark.parametrize("name", ["ring and staircase", "ghost.png", "mushroom.png"])
def test_a_one_pixel_edit_leaves_the_simplified_curves_far_from_it_as_they_were(name):
    img = pattern(name)
    opaque = np.argwhere(img[..., 3] == 255)
    for y, x in opaque[np.random.default_rng(7).choice(len(opaque), 4, replace=False)]:
        assert far_simplified_changes(img, int(x), int(y)) == [], (x, y)


@needs_corpus
@pytest.mark.parametrize("name", ["smw_boo.png", "sma_toad.png", "win31_386.png", "mana_rabite.png", "smw_yoshi.png"])
def test_a_one_pixel_edit_of_a_sprite_leaves_the_simplified_curves_far_from_it_as_they_were(name):
    img = pattern(name)
    opaque = np.argwhere(img[..., 3] == 255)
    for y, x in opaque[np.random.default_rng(11).choice(len(opaque), 3, replace=False)]:
        changed = far_simplified_changes(img, int(x), int(y))
        assert changed == [], (x, y, changed[:3])
