"""Which faces each shape covers, and in which order the shapes are drawn.

Part of stage 6 (:mod:`depixel.svg.outlines`). The faces of a vector image (linked cells of one
colour, :mod:`depixel.vector`), their adjacency, their *depth* (boundaries to cross from
the image border or a transparent area), the drawing rank that follows from it, and the
faces a shape stands on in the stacked layout: itself, every opaque neighbour drawn above
it (so the lower of two touching faces lies beneath their common boundary), and — while
that shortens the outline — opaque faces drawn above it that its outline would otherwise
have to go around.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import batch_bounds, in_sorted, ranges, sums_by_key, unique
from ..vector import VectorImage, faces_and_regions
from .lenses import lenses_before, thin_lenses
from .smoothgroups import smooth_groups

#: shape roles, for the labels of an editor's layers panel
ROLES = ("backdrop", "outline", "band", "shape")
#: member keys grown together in the stacked layout (:meth:`FaceTopology._absorb`)
ABSORB_BATCH = 1 << 14
#: :meth:`FaceTopology._grow` keeps a batch's keys as a dense (owner, face) table of booleans
#: while it spans at most this many keys (a sprite's shapes; a frame's batches search the keys)
DENSE_ABSORB_BYTES = 1 << 17


@dataclass(frozen=True, eq=False)
class FaceBoundaries:
    """What tracing the outlines needs of a :class:`FaceTopology` (views of its arrays): the
    drawing rank of every face and the boundary half-edges of each face (entries
    ``entry_ptr[f]:entry_ptr[f+1]``, each with the face on its right)."""

    n_faces: int
    rank: np.ndarray  # (F,) drawing rank of each face
    entry_ptr: np.ndarray  # (F+1,)
    entry_other: np.ndarray  # (M,) int32 the face on the left (-1: outside the image)
    entry_from: np.ndarray  # (M,) int32 node the half-edge leaves
    entry_to: np.ndarray  # (M,) int32 node it enters
    entry_edge: np.ndarray  # (M,) int32 its cell edge
    nodes: np.ndarray  # (N, 2) quarter-pixel node positions
    opaque: np.ndarray  # (F,) bool: the face is fully opaque


class FaceTopology:
    """Faces, their depth, drawing rank and role, the faces each lies under in the stacked
    layout, and the boundary half-edges of each."""

    def __init__(self, image: VectorImage, stacked: bool = True) -> None:
        """``stacked``: the topology of the stacked layout (the faces each lies under), or of
        the cutout layout (each face alone)."""
        cells = image.cells
        self.image, self.cells = image, cells
        self.stacked = stacked
        h, w = cells.shape
        labels, region = faces_and_regions(cells)
        assert region is not None
        self.labels = labels
        n = int(labels.max()) + 1
        self.n_faces = n
        # the faces are numbered in order of their first pixel (faces_and_regions), so a
        # face's first pixel is where the running maximum of the labels grows
        seen = np.maximum.accumulate(labels)
        grows = np.empty(labels.size, bool)
        grows[:1] = True
        np.greater(seen[1:], seen[:-1], out=grows[1:])
        first_pixel = grows.nonzero()[0]
        self.first_pixel = first_pixel
        self.face_rgba = image.rgba.reshape(-1, 4).take(first_pixel, axis=0)
        self.face_region = region.take(first_pixel)
        self.area = np.bincount(labels, minlength=n)
        alpha = self.face_rgba[:, 3]
        self.drawn = alpha > 0
        self.opaque = alpha == 255

        # the face on the left and on the right of every cell edge (-1: outside the image)
        sides = cells.edge_pixels
        left = np.where(sides[:, 0] >= 0, labels.take(np.maximum(sides[:, 0], 0)), -1)
        right = np.where(sides[:, 1] >= 0, labels.take(np.maximum(sides[:, 1], 0)), -1)
        boundary = (left != right).nonzero()[0]
        left, right = left.take(boundary), right.take(boundary)
        # one entry per face side of a boundary edge, oriented with the face on the right,
        # sorted by face (stable); 32-bit, since an image has far fewer than 2^31 of anything
        has_r, has_l = right >= 0, left >= 0
        entry_face = np.concatenate([right.compress(has_r), left.compress(has_l)])
        order = entry_face.argsort(kind="stable")
        self.entry_ptr = np.concatenate(([0], np.bincount(entry_face, minlength=n).cumsum()))
        del entry_face

        def entries(of_right: np.ndarray, of_left: np.ndarray, order: np.ndarray = order) -> np.ndarray:
            return np.concatenate([of_right.compress(has_r), of_left.compress(has_l)], dtype=np.int32).take(order)

        self.entry_other = entries(left, right)
        # edge k's nodes are at 2k and 2k + 1 of the flat (E, 2) array (a column's take would
        # copy the whole column first; gathered rows would leave strided columns)
        u, v = cells.edges.ravel().take(2 * boundary), cells.edges.ravel().take(2 * boundary + 1)
        self.entry_from, self.entry_to = entries(u, v), entries(v, u)
        inner = has_l & has_r
        n_nodes = len(cells.nodes)
        # where three or more boundaries between faces meet (the image border not counted): where
        # an outline may turn from one curve onto another, so the curves are cut into pieces there
        self.junction = (np.bincount(u.compress(inner), minlength=n_nodes)
                         + np.bincount(v.compress(inner), minlength=n_nodes)) >= 3
        if stacked:  # where three faces meet (the outside counted as one), three boundary edges do
            meeting = (np.bincount(u, minlength=n_nodes) + np.bincount(v, minlength=n_nodes)) >= 3
        del u, v
        self.entry_edge = entries(boundary, boundary)
        del order
        left_in, right_in = left.compress(inner), right.compress(inner)
        lo, hi = np.minimum(left_in, right_in).astype(np.int64), np.maximum(left_in, right_in)
        del left_in, right_in
        pair_key = _distinct(lo * n + hi)
        lo, hi = np.divmod(pair_key, n)
        del pair_key
        m = lo.size
        pairs = np.empty((2 * m, 2), np.int32)  # neighbouring faces, both directions
        pairs[:m, 0], pairs[:m, 1], pairs[m:, 0], pairs[m:, 1] = lo, hi, hi, lo
        del lo, hi

        on_border = np.zeros(n, bool)
        on_border[np.maximum(left, right).compress(has_r ^ has_l)] = True  # (the outside is -1)
        self.on_border = on_border
        del left, right, boundary
        self.depth = self._depths(pairs)
        self.group = smooth_groups(cells, labels, self.face_region, self.drawn)
        self.rank, self.face_of_rank = self._ranks(region, pairs)
        self.role = self._roles(pairs)
        # the adjacency is kept only as the members it gives (stacked: the underlays, what
        # members() starts from)
        own = self.drawn.nonzero()[0]
        if stacked:
            under = self._under_keys(pairs)
            del pairs
            at_corners = self._under_keys(self._corner_pairs(labels, meeting))
            self.underlays = _distinct(np.concatenate([own * n + own, under, at_corners]))
        else:
            self.underlays = own * n + own

    def boundaries(self) -> FaceBoundaries:
        """The rank and boundary half-edges alone, to keep when the rest is no longer needed."""
        return FaceBoundaries(self.n_faces, self.rank, self.entry_ptr, self.entry_other, self.entry_from,
                              self.entry_to, self.entry_edge, self.cells.nodes, self.opaque)

    def _corner_pairs(self, labels: np.ndarray, meeting: np.ndarray) -> np.ndarray:
        """(K, 2) (lowest face at a node, another face at that node) for every node where
        three or more faces meet: faces that touch there only at a corner (the diagonal ones
        where four meet) are not neighbours, yet unless the lowest of them lies under all the
        others a seam opens at that point. ``meeting`` (N,) bool: a superset of those nodes
        (the corners of the cells at the others are left out before the sort)."""
        cells = self.cells
        n = self.n_faces
        at_meeting = meeting.take(cells.cell_nodes)
        face_at = labels.repeat(cells.cell_ptr[1:] - cells.cell_ptr[:-1]).compress(at_meeting)
        drawn_first = self.rank.take(face_at)
        drawn_first += n * ~self.drawn.take(face_at)  # the lowest drawn face first
        del face_at
        # one sorted key per (node, face) instead of a lexsort: ranks are distinct, so the
        # face comes back from its rank
        key = cells.cell_nodes.compress(at_meeting).astype(np.int64)
        key *= 2 * n
        key += drawn_first
        del drawn_first
        if key.size == 0:  # one face, or faces that only meet in twos
            return np.zeros((0, 2), np.int32)
        node, drawn_first = np.divmod(_distinct(key), 2 * n)
        del key
        face_at = self.face_of_rank.take(drawn_first % n)
        del drawn_first
        start = np.concatenate(([True], node[1:] != node[:-1])).nonzero()[0]
        del node
        count = np.concatenate((start[1:], [face_at.size])) - start
        lowest = face_at.take(start).repeat(count)  # sorted by rank within each node
        crowded = (count >= 3).repeat(count) & (face_at != lowest)
        corners = np.empty((int(crowded.sum()), 2), np.int32)
        corners[:, 0], corners[:, 1] = lowest.compress(crowded), face_at.compress(crowded)
        return corners

    def _depths(self, pairs: np.ndarray) -> np.ndarray:
        """(F,) boundaries to cross from outside: 0 for transparent faces, 1 on the border or
        beside a transparent face, then one more per face boundary (shortest path)."""
        n = self.n_faces
        depth = np.full(n, n + 1, np.int64)
        depth[self.on_border] = 1
        depth[~self.drawn] = 0
        a, b = pairs[:, 0].copy(), pairs[:, 1].copy()
        reach = np.empty(n, np.int64)
        while True:
            reach.fill(n + 1)
            step = depth.take(a)
            step += 1
            np.minimum.at(reach, b, step)
            # depth only decreases: it is settled when no face's reach is below its depth
            if not np.logical_or.reduce(np.less(reach, depth)):
                return depth
            np.minimum(depth, reach, out=depth)

    def _ranks(self, region: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drawing rank of every face, and the face of every rank: by depth, pockets last,
        then by region, larger faces first, then scanline order. The faces of a smooth group
        are ranked together, as one face of the group's least depth (a pocket if one of
        them is), largest area and first pixel, and among themselves by depth, pockets, area
        and first pixel: a face inside a filled hole of a shape is still drawn after it
        (docs/design.md, "Smooth groups in the drawing order"). Stacked: then each thin lens
        just below the contrasting face it borders (:mod:`depixel.svg.lenses`)."""
        n = self.n_faces
        region_of = self.face_region
        region_depth = np.full(int(region.max()) + 1, n + 1, np.int64)
        np.minimum.at(region_depth, region_of, self.depth)
        region_area = np.bincount(region_of, weights=self.area)
        region_key = np.lexsort((np.arange(region_area.size), -region_area, region_depth))
        region_rank = np.empty_like(region_key)
        region_rank[region_key] = np.arange(region_key.size)
        pockets = self._pockets()
        # (depth, pocket, area, first pixel) of what each face is ranked as; within a group
        # the face's own
        outer = [self.depth.copy(), pockets.astype(np.int64), self.area.copy(), self.first_pixel.astype(np.int64)]
        inner = [np.zeros(n, np.int64) for _ in range(4)]
        grouped = (self.group >= 0).nonzero()[0]
        if grouped.size:
            of = self.group.take(grouped)
            for key, at, reduce in zip(outer, inner, (np.minimum, np.maximum, np.maximum, np.minimum)):
                own = key.take(grouped)
                value = np.full(int(of.max()) + 1, np.iinfo(np.int64).max if reduce is np.minimum else -1)
                reduce.at(value, of, own)
                key[grouped] = value.take(of)
                at[grouped] = own
        depth, pocket, area, first = outer
        order = np.lexsort((inner[3], -inner[2], inner[1], inner[0], first, -area, region_rank[region_of], pocket,
                            depth))
        if self.stacked:
            lens = thin_lenses(self.image, self.entry_ptr, self.entry_from, self.entry_to, self.entry_edge)
            lens &= (self.group < 0) & ~pockets & self.opaque
            order = lenses_before(order, pairs, lens, self.group, self.face_rgba[:, :3], self.opaque, self.area)
        rank = np.empty(n, np.int64)
        rank[order] = np.arange(n)
        return rank, order

    def _pockets(self) -> np.ndarray:
        """(F,) bool: the face has a pixel whose four neighbours all belong to one other face
        of the same depth — a pocket reached only through a diagonal link, which at any
        zoom looks enclosed by that face. Such faces are drawn after the others of their
        depth, so the enclosing face covers them instead of showing a hole there."""
        h, w = self.cells.shape
        labels = self.labels.reshape(h, w)
        pocket = np.zeros(self.n_faces, bool)
        if h < 3 or w < 3:
            return pocket
        centre = labels[1:-1, 1:-1]
        up, down, left, right = labels[:-2, 1:-1], labels[2:, 1:-1], labels[1:-1, :-2], labels[1:-1, 2:]
        around = (up == down) & (up == left) & (up == right) & (up != centre)
        around &= self.depth[up] == self.depth[centre]
        pocket[centre[around]] = True
        return pocket

    def members(self, edge_cost: np.ndarray | None = None) -> np.ndarray:
        """Sorted keys ``owner * F + member`` of (owner face, member face) pairs: the faces
        each drawn face's shape covers before its holes are filled.

        Cutout: the face alone. Stacked: the face and every opaque neighbour drawn above it
        (so the lower of two touching faces lies beneath their boundary), then, while it
        shortens the outline (``edge_cost`` per cell edge: what drawing it costs), every
        opaque face drawn above it whose boundary is mostly shared with the shape already."""
        if not self.stacked or edge_cost is None:
            return self.underlays
        return self._absorb(self.underlays, edge_cost)

    def _under_keys(self, pairs: np.ndarray) -> np.ndarray:
        """Keys ``a * F + b`` of the (a, b) pairs where b is opaque and drawn above a drawn face a."""
        a, b = pairs[:, 0], pairs[:, 1]
        under = self.drawn.take(a) & self.opaque.take(b) & (self.rank.take(b) > self.rank.take(a))
        return a.compress(under).astype(np.int64) * self.n_faces + b.compress(under)

    def _absorb(self, keys: np.ndarray, edge_cost: np.ndarray) -> np.ndarray:
        """Grow each shape's member set (keys owner * F + member, sorted) by the faces that
        shorten its outline, until none does. Each shape grows on its own, so the shapes
        are grown a batch at a time (:data:`ABSORB_BATCH` keys), which bounds the memory of
        the candidate arrays (~40 a face on noise) and changes nothing else."""
        n = self.n_faces
        ptr, others, costs, perimeter = self._neighbours(edge_cost)
        # a candidate's rank, -1 if it is not opaque (ranks are 0..F-1)
        neighbours = (ptr[:-1], ptr[1:] - ptr[:-1], others, costs, perimeter, np.where(self.opaque, self.rank, -1))
        if 0 < keys.size <= ABSORB_BATCH:  # one batch (a sprite's): no cuts to find
            return self._grow(keys, neighbours)
        owner = keys // n
        cuts = unique(np.concatenate(([0], owner.searchsorted(owner[ABSORB_BATCH::ABSORB_BATCH]), [keys.size])))
        del owner
        return np.concatenate([self._grow(keys[a:b], neighbours)
                               for a, b in zip(cuts[:-1].tolist(), cuts[1:].tolist())] or [keys])

    def _neighbours(self, edge_cost: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The faces each face borders, in CSR form ``(ptr, other face, cost of their common
        boundary)``, and each face's perimeter cost (the image border included). The entries
        are sorted by face, so a batch of faces at a time gives the same pairs and sums."""
        n = self.n_faces
        perimeter = np.zeros(n)
        count = np.zeros(n, np.int64)
        others: list[np.ndarray] = [np.zeros(0, np.int32)]
        costs: list[np.ndarray] = [np.zeros(0)]
        for a, b in batch_bounds(self.entry_ptr[1:] - self.entry_ptr[:-1], ABSORB_BATCH):
            lo, hi = int(self.entry_ptr[a]), int(self.entry_ptr[b])
            face = np.arange(a, b).repeat(self.entry_ptr[a + 1 : b + 1] - self.entry_ptr[a:b])
            other = self.entry_other[lo:hi]
            key, cost = sums_by_key(face * (n + 1) + np.where(other >= 0, other, n),
                                    edge_cost.take(self.entry_edge[lo:hi]))
            face, other = np.divmod(key, n + 1)
            perimeter[a:b] = np.bincount(face - a, weights=cost, minlength=b - a)
            inner = other < n
            count[a:b] = np.bincount(face[inner] - a, minlength=b - a)
            others.append(other[inner].astype(np.int32))
            costs.append(cost[inner])
        ptr = np.concatenate(([0], count.cumsum()))
        return ptr, np.concatenate(others), np.concatenate(costs), perimeter

    def _grow(self, keys: np.ndarray, neighbours: tuple[np.ndarray, ...]) -> np.ndarray:
        """:meth:`_absorb` of the shapes whose keys these are. A round looks at the shapes
        that grew in the round before (all at first): the others' candidates and sums are
        those of a round that added nothing to them."""
        n = self.n_faces
        nb_start, nb_count, h, w, perimeter, above = neighbours
        # where the batch's owners span a small (owner, face) table (a sprite's): whether a
        # face may join an owner's shape (opaque, drawn above the owner, not a member yet),
        # one look-up a candidate instead of the two rank gathers and a test of the keys so
        # far; the keys are then counted from the table's first (a multiple of n); else a
        # binary search of the sorted keys
        first_owner = int(keys[0]) // n if keys.size else 0
        n_owners = int(keys[-1]) // n + 1 - first_owner if keys.size else 0
        low = first_owner * n
        allowed = None
        if 0 < n_owners * n <= DENSE_ABSORB_BYTES:
            allowed = np.less.outer(self.rank[first_owner : first_owner + n_owners], above).ravel()
            keys = keys - low
            allowed.put(keys, False)
        growing = keys  # the keys of the shapes that may grow
        while True:
            owner, member = np.divmod(growing, n)
            start, count = nb_start.take(member), nb_count.take(member)
            idx = ranges(start, count)
            cand = h.take(idx)
            if allowed is not None:
                cand_key = (growing - member).repeat(count)
                cand_key += cand
                ok = allowed.take(cand_key, mode="clip")  # (every key is within the table: "clip" is not buffered)
            else:
                f = owner.repeat(count)
                cand_key = f * n
                cand_key += cand
                ok = np.greater(above.take(cand), self.rank.take(f))
                ok &= ~in_sorted(keys, cand_key)
            cand_key, weight = cand_key.compress(ok), w.take(idx.compress(ok))
            if cand_key.size == 0:
                break
            uniq, shared = sums_by_key(cand_key, weight)
            gain = 2 * shared - perimeter.take(uniq % n)  # (low is a multiple of n)
            add = uniq.compress(gain > 1e-9)
            if add.size == 0:
                break
            keys = np.concatenate((keys, add))  # none of them among the keys (fresh)
            keys.sort()
            if allowed is not None:
                allowed.put(add, False)
            growing = keys.compress(in_sorted(add // n, keys // n))  # (add is sorted: so are its owners)
        return keys + low if allowed is not None else keys

    def _roles(self, pairs: np.ndarray) -> np.ndarray:
        """(F,) int8 role of each face's shape: the lowest shape, when it covers most of the
        image along its border, is the backdrop; a face darker than every face it encloses
        is an outline; a face sharing its region with others is a shading band."""
        h, w = self.cells.shape
        role = np.full(self.n_faces, ROLES.index("shape"), np.int8)
        region_faces = np.bincount(self.face_region.compress(self.drawn), minlength=int(self.face_region.max()) + 1)
        role[region_faces.take(self.face_region) > 1] = ROLES.index("band")
        luma = self.face_rgba[:, :3].astype(np.float64) @ np.array([0.299, 0.587, 0.114])
        a, b = pairs[:, 0], pairs[:, 1]
        deeper = self.depth.take(b) > self.depth.take(a)
        outer = a.compress(deeper)
        encloses = np.zeros(self.n_faces, bool)
        encloses[outer] = True
        darkest_inside = np.full(self.n_faces, 1e9)
        np.minimum.at(darkest_inside, outer, luma.take(b.compress(deeper)))
        outline = encloses & (luma < darkest_inside) & self.opaque
        role[outline] = ROLES.index("outline")
        drawn = self.face_of_rank[self.drawn[self.face_of_rank]]
        lowest = drawn[0] if drawn.size else -1
        if lowest >= 0 and self.on_border[lowest] and self.opaque[lowest] and self.area[lowest] * 4 >= h * w:
            role[lowest] = ROLES.index("backdrop")
        return role


def _distinct(values: np.ndarray) -> np.ndarray:
    """The distinct values, sorted, of an array the caller gives up (sorted in place: no
    argsort and no copy, where ``unique`` makes three)."""
    values.sort()
    first = np.ones(values.size, bool)
    np.not_equal(values[1:], values[:-1], out=first[1:])
    return values.compress(first)
