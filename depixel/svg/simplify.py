"""Optional simplification of the boundary pieces: fewer curves within a tolerance.

Not in the paper; potrace's ``opttolerance`` and vtracer's ``splice_threshold`` give their
users the same choice. Each piece of boundary between two junctions
(:mod:`depixel.svg.boundaries`) is simplified on its own, so two shapes that share it still
draw the same geometry, and its ends (junctions, corners, curve ends) stay where they are.

A run of the piece's exact segments is replaced by one Bézier with the same end points and
the same tangent directions there (so the result is exactly as smooth as the spline at
every joint it keeps, and corners stay sharp): the quadratic whose control point is where
the two end tangents meet, when it fits (4 numbers in the file), else the cubic whose two
control legs are fitted by least squares to points of the run (chord-length parameters).
Each piece is cut into runs of at most 8 segments, then every run that does not fit is
halved, level by level, all pieces at once; neighbouring fits are merged once more at the
end. A fit is kept only when

* every sample of the exact run lies within ``tolerance`` pixels of the new curve, and it
  is not more than 10 % longer than the run (no loop or bulge between samples),
* no protected point near it — the centres of the pixels beside the piece and the lattice
  corners of the diagonal links at its nodes, the points the optimizer keeps clear of
  (:mod:`depixel.optimize.fidelity`) — lies between the new curve and the run it replaces (which
  would put it on the other side of the boundary), or comes nearer to the new curve than
  ``min(its distance to the exact spline, clearance)``.

So every pixel centre keeps its colour and every thin diagonal stays connected.

This module is the driver (cutting, halving, merging, reassembling the pieces); one fit and
its checks, on whole batches of runs, are :mod:`depixel.svg.curvefit`.
"""
from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from ..arrays import batch_bounds, in_sorted, ranges, set_rows
from ..vector import VectorImage
from .boundaries import CUBIC, BoundaryPieces
from .curvefit import fit
from .reference import BATCH, Exact, Protected

#: ranges [lo, hi) of exact segments: the two arrays
Ranges = tuple[np.ndarray, np.ndarray]


def simplify_pieces(pieces: BoundaryPieces, image: VectorImage, tolerance: float, clearance: float = 0.075,
                    grid: float | None = None) -> BoundaryPieces:
    """Replace runs of segments of every piece by single cubics while they stay within
    ``tolerance`` pixels of the exact curve and keep the protected points (module docstring).

    ``clearance``: the least distance kept from a protected point that was farther than
    that from the exact curve (pixels). ``grid`` rounds the new control points like the rest.
    """
    if tolerance <= 0 or pieces.kind.size == 0:
        return pieces
    exact = Exact(pieces, tolerance)
    protected = Protected(pieces, image, exact, tolerance + clearance)
    # ranges [lo, hi) of exact segments to fit: each piece cut into chunks of at most
    # _CHUNK segments (a cubic within 0.1 px seldom spans more spans of the spline), then
    # halved until a cubic fits or one segment is left
    lo, hi = _chunks(pieces.ptr, _CHUNK)
    fits = _Fits(exact, protected, pieces.ptr, tolerance, clearance, grid)
    fitted: list[tuple[np.ndarray, ...]] = []
    failed: list[np.ndarray] = []  # ranges that did not fit (a fit depends on its range alone)
    while lo.size:
        kind, c1, c2, ok = fits.get(lo, hi, partial(_ahead, lo, hi, fitted, failed, pieces.ptr))
        fitted.append((lo[ok], hi[ok], kind[ok], c1.compress(ok, axis=0), c2.compress(ok, axis=0)))
        lo, hi = lo[~ok], hi[~ok]
        failed.append(_range_keys(lo, hi, pieces.ptr))
        lo, hi = _halves(lo, hi)
    fitted = _merge_neighbours(fits, pieces.ptr, fitted, np.sort(np.concatenate(failed)) if failed
                               else np.zeros(0, np.int64))
    return _assemble(pieces, fitted)


_CHUNK = 8
#: a pass of fits costs about half a millisecond of numpy calls whatever its size, plus
#: 1.5–2 µs a segment: up to this many segments in all, a pass also fits the ranges the next
#: passes may ask for (the halves of its ranges, the merges after this one). The result does
#: not depend on it (a fit depends on its range alone)
SPECULATIVE_SEGMENTS = 256
#: up to this many segments, the pass of the halving's last level also fits every pair of
#: touching ranges the first merge pass may ask for (about twice what it asks for: a sprite's
#: 10–840 segments, saving a pass; a frame's ~12 500 are left to the merge pass itself)
MERGE_AHEAD_SEGMENTS = 1024


class _Fits:
    """:func:`fit` of ranges [lo, hi) of exact segments, each range fitted once, a batch at a
    time (:data:`BATCH`): ranges that later passes may ask for can be fitted ahead, in the
    same pass."""

    def __init__(self, exact: Exact, protected: Protected, ptr: np.ndarray, tolerance: float, clearance: float,
                 grid: float | None) -> None:
        self.exact, self.protected, self.ptr = exact, protected, ptr
        self.tolerance, self.clearance, self.grid = tolerance, clearance, grid
        self.keys = np.zeros(0, np.int64)  # sorted _range_keys of the ranges fitted so far
        self.kind, self.ok = np.zeros(0, np.uint8), np.zeros(0, bool)
        self.c1, self.c2 = np.zeros((0, 2)), np.zeros((0, 2))

    def get(self, lo: np.ndarray, hi: np.ndarray, ahead: Callable[[], Ranges | None] | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(kind, c1, c2, ok)`` of the ranges [lo, hi) (:func:`fit`); the ranges (lo, hi)
        that ``ahead()`` gives, called only when there is a pass, are fitted in the same pass
        where they are new, for later calls."""
        keys = _range_keys(lo, hi, self.ptr)
        if not in_sorted(self.keys, keys).all():  # a pass (only then one ahead)
            extra = None if ahead is None else ahead()
            wanted = keys if extra is None else np.concatenate([keys, _range_keys(*extra, self.ptr)])
            new = np.unique(wanted[~in_sorted(self.keys, wanted)], return_index=True)[0]
            new_lo, new_hi = np.divmod(new, int(self.ptr[-1]) + 1)
            kind, c1, c2, ok = self._fit(new_lo, new_hi)
            order = np.concatenate([self.keys, new]).argsort(kind="stable")
            self.keys = np.concatenate([self.keys, new])[order]
            self.kind, self.ok = np.concatenate([self.kind, kind])[order], np.concatenate([self.ok, ok])[order]
            self.c1 = np.concatenate([self.c1, c1]).take(order, axis=0)
            self.c2 = np.concatenate([self.c2, c2]).take(order, axis=0)
        at = self.keys.searchsorted(keys)
        return self.kind[at], self.c1.take(at, axis=0), self.c2.take(at, axis=0), self.ok[at]

    def _fit(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        bounds = batch_bounds(hi - lo + 2, BATCH)  # samples and protected points grow with the segments
        parts = [fit(self.exact, self.protected, lo[a:b], hi[a:b], self.tolerance, self.clearance, self.grid)
                 for a, b in bounds]
        if len(parts) == 1:
            return parts[0]
        kinds, c1s, c2s, oks = zip(*parts)
        return np.concatenate(kinds), np.concatenate(c1s), np.concatenate(c2s), np.concatenate(oks)


def _halves(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two halves of every range [lo, hi) that have more than one segment."""
    mid = (lo + hi) // 2
    lo, hi = np.concatenate([lo, mid]), np.concatenate([mid, hi])
    more = hi - lo > 1
    return lo[more], hi[more]


def _descendants(lo: np.ndarray, hi: np.ndarray, budget: int) -> tuple[np.ndarray, np.ndarray]:
    """The halves of the ranges [lo, hi), their halves and so on, whole levels while they
    hold at most ``budget`` segments in all: the ranges the halving may ask for next."""
    los, his = [], []
    while True:
        lo, hi = _halves(lo, hi)
        budget -= int((hi - lo).sum())
        if lo.size == 0 or budget < 0:
            break
        los.append(lo)
        his.append(hi)
    return (np.concatenate(los), np.concatenate(his)) if los else (lo[:0], hi[:0])


def _ahead(lo: np.ndarray, hi: np.ndarray, fitted: list[tuple[np.ndarray, ...]], failed: list[np.ndarray],
           ptr: np.ndarray) -> Ranges | None:
    """The ranges that the pass fitting the ranges [lo, hi) of a level of the halving also
    fits for the passes after it: their halves, the halves' halves and so on while they fit
    in :data:`SPECULATIVE_SEGMENTS` with them; at the last level (no range of more than two
    segments: the halves would be single segments, never fitted) the first merge pass's."""
    if int((hi - lo).max()) > 2:
        return _descendants(lo, hi, SPECULATIVE_SEGMENTS - int((hi - lo).sum()))
    return _first_merges(fitted, lo, hi, failed, ptr)


def _first_merges(fitted: list[tuple[np.ndarray, ...]], lo: np.ndarray, hi: np.ndarray, failed: list[np.ndarray],
                  ptr: np.ndarray) -> Ranges | None:
    """Every union of two touching ranges among those ``fitted`` so far and the last level's
    [lo, hi), whether these fit or not, that did not fail before (``failed``: arrays of
    :func:`_range_keys`): those the first merge pass of :func:`_merge_neighbours` asks for
    are among them (it asks for every other pair of the fitted ranges; which of a pair's
    parities depends on the last level's fits before it). None when they hold more than
    :data:`MERGE_AHEAD_SEGMENTS` segments."""
    los = np.concatenate([f[0] for f in fitted] + [lo])
    his = np.concatenate([f[1] for f in fitted] + [hi])
    order = los.argsort(kind="stable")
    los, his = los.take(order), his.take(order)
    piece_of = ptr.searchsorted(los, side="right") - 1
    a = ((his[:-1] == los[1:]) & (piece_of[:-1] == piece_of[1:])).nonzero()[0]
    merged_lo, merged_hi = los.take(a), his.take(a + 1)
    done = np.sort(np.concatenate(failed)) if failed else np.zeros(0, np.int64)
    new = ~in_sorted(done, _range_keys(merged_lo, merged_hi, ptr))
    merged_lo, merged_hi = merged_lo.compress(new), merged_hi.compress(new)
    return (merged_lo, merged_hi) if int((merged_hi - merged_lo).sum()) <= MERGE_AHEAD_SEGMENTS else None


def _chunks(ptr: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Every piece of more than one segment cut into near-equal runs of at most ``size``."""
    length = np.diff(ptr)
    count = np.where(length > 1, -(-length // size), 0)
    piece = np.arange(length.size).repeat(count)
    k = ranges(0, count)
    lo = ptr[piece] + (length[piece] * k) // count[piece]
    hi = ptr[piece] + (length[piece] * (k + 1)) // count[piece]
    return lo, hi


def _range_keys(lo: np.ndarray, hi: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """One int64 number per range [lo, hi) of exact segments (``ptr[-1]`` of them)."""
    return lo.astype(np.int64) * (int(ptr[-1]) + 1) + hi


def _merge_neighbours(fits: _Fits, ptr, fitted, failed):
    """Try once to fit one curve over two neighbouring fitted ranges of a piece (not
    again over a range that did not fit before: ``failed``, sorted :func:`_range_keys`)."""
    if not fitted:
        return fitted
    lo, hi, kinds, c1, c2 = (np.concatenate([f[i] for f in fitted]) for i in range(5))
    order = lo.argsort(kind="stable")
    lo, hi, kinds, c1, c2 = lo[order], hi[order], kinds[order], c1.take(order, axis=0), c2.take(order, axis=0)
    piece_of = ptr.searchsorted(lo, side="right") - 1
    for parity in (0, 1):
        if lo.size < 2:
            break
        touching = (hi[:-1] == lo[1:]) & (piece_of[:-1] == piece_of[1:])
        a = (touching & (np.arange(lo.size - 1) % 2 == parity)).nonzero()[0]
        a = a[~in_sorted(failed, _range_keys(lo[a], hi[a + 1], ptr))]
        if a.size == 0:
            continue
        ahead = partial(_next_merges, lo, hi, touching, a, failed, ptr) if parity == 0 else None
        mk, m1, m2, ok = fits.get(lo[a], hi[a + 1], ahead)
        a, mk, m1, m2 = a[ok], mk[ok], m1.compress(ok, axis=0), m2.compress(ok, axis=0)
        hi[a] = hi[a + 1]
        kinds[a] = mk
        set_rows(c1, a, m1)
        set_rows(c2, a, m2)
        keep = np.ones(lo.size, bool)
        keep[a + 1] = False
        lo, hi, kinds, piece_of = lo[keep], hi[keep], kinds[keep], piece_of[keep]
        c1, c2 = c1.compress(keep, axis=0), c2.compress(keep, axis=0)
    return [(lo, hi, kinds, c1, c2)]


def _next_merges(lo: np.ndarray, hi: np.ndarray, touching: np.ndarray, a: np.ndarray, failed: np.ndarray,
                 ptr: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Every range the second merge pass may try whatever the first one (merging the
    ranges ``a`` with ``a + 1`` of the sorted fitted ranges [lo, hi)) keeps: two, three or
    four neighbouring fitted ranges; None when they hold more than
    :data:`SPECULATIVE_SEGMENTS` segments with the first pass's."""
    n = lo.size
    merging = np.zeros(n + 2, bool)
    merging[a] = True
    near = np.zeros(n + 1, bool)  # near[j]: ranges j and j + 1 touch
    near[: n - 1] = touching
    j = np.arange(n)
    # the unions of the ranges j, j + 1 (and j + 2, j + 3) that a pass of merges can leave
    # side by side, by the first range j and their number
    pair = near[:n] & ~merging[:n]  # (those merging are asked for now)
    three = (merging[:n] & near[1:]) | (merging[1 : n + 1] & near[:n])  # (j, j + 1), j + 2 or j, (j + 1, j + 2)
    four = merging[:n] & merging[2:] & near[1:]  # (j, j + 1), (j + 2, j + 3)
    first = np.concatenate([j[pair], j[three], j[four]])
    count = np.repeat([2, 3, 4], [int(pair.sum()), int(three.sum()), int(four.sum())])
    ahead_lo, ahead_hi = lo[first], hi[first + count - 1]
    keep = ~in_sorted(failed, _range_keys(ahead_lo, ahead_hi, ptr))
    ahead_lo, ahead_hi = ahead_lo[keep], ahead_hi[keep]
    if int((ahead_hi - ahead_lo).sum()) + int((hi[a + 1] - lo[a]).sum()) > SPECULATIVE_SEGMENTS:
        return None
    return ahead_lo, ahead_hi

def _assemble(pieces: BoundaryPieces, fitted) -> BoundaryPieces:
    """The pieces with each fitted range replaced by its cubic."""
    n = pieces.kind.size
    replaced = np.zeros(n, bool)
    head = np.full(n, -1, np.int64)  # fitted range starting at each exact segment
    los, his, kinds, c1s, c2s = (np.concatenate(x) for x in zip(*fitted)) if fitted else \
        (np.zeros(0, np.int64),) * 2 + (np.zeros(0, np.uint8),) + (np.zeros((0, 2)),) * 2
    los, his = los.astype(np.int64), his.astype(np.int64)
    head[los] = np.arange(los.size)
    cover = np.zeros(n + 1, np.int64)
    np.add.at(cover, los, 1)
    np.add.at(cover, his, -1)
    replaced = cover.cumsum()[:n] > 0
    keep = ~replaced | (head >= 0)
    at = np.maximum(head, 0)
    kind = np.where(head >= 0, kinds[at] if los.size else CUBIC, pieces.kind).astype(np.uint8)
    ctrl = np.where((head >= 0)[:, None], c1s.take(at, axis=0) if los.size else 0.0, pieces.ctrl)
    ctrl2 = np.where((head >= 0)[:, None], c2s.take(at, axis=0) if los.size else 0.0, pieces.ctrl2)
    end = np.where((head >= 0)[:, None], pieces.end.take(np.maximum(his[at] - 1, 0), axis=0) if los.size else 0.0,
                   pieces.end)
    piece = np.arange(len(pieces)).repeat(np.diff(pieces.ptr))[keep]
    ptr = piece.searchsorted(np.arange(len(pieces) + 1)).astype(np.int64)
    return pieces.replace_segments(pieces.start, ptr, kind[keep], ctrl.compress(keep, axis=0),
                                   end.compress(keep, axis=0), ctrl2.compress(keep, axis=0))
