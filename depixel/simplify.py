"""Optional simplification of the boundary pieces: fewer curves within a tolerance.

Not in the paper; potrace's ``opttolerance`` and vtracer's ``splice_threshold`` give their
users the same choice. Each piece of boundary between two junctions
(:mod:`depixel.boundaries`) is simplified on its own, so two shapes that share it still
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
  (:mod:`depixel.fidelity`) — lies between the new curve and the run it replaces (which
  would put it on the other side of the boundary), or comes nearer to the new curve than
  ``min(its distance to the exact spline, clearance)``.

So every pixel centre keeps its colour and every thin diagonal stays connected.

This module is the driver (cutting, halving, merging, reassembling the pieces); one fit and
its checks, on whole batches of runs, are :mod:`depixel.curvefit`.
"""
from __future__ import annotations

import numpy as np

from .arrays import batch_bounds, in_sorted, set_rows
from .boundaries import CUBIC, BoundaryPieces
from .curvefit import BATCH, Exact, Protected, fit
from .vector import VectorImage


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
    fitted: list[tuple[np.ndarray, ...]] = []
    failed = []  # ranges that did not fit (a fit depends on its range alone)
    while lo.size:
        kind, c1, c2, ok = _fit_checked(exact, protected, lo, hi, tolerance, clearance, grid)
        fitted.append((lo[ok], hi[ok], kind[ok], c1.compress(ok, axis=0), c2.compress(ok, axis=0)))
        lo, hi = lo[~ok], hi[~ok]
        failed.append(_range_keys(lo, hi, pieces.ptr))
        mid = (lo + hi) // 2
        lo, hi = np.concatenate([lo, mid]), np.concatenate([mid, hi])
        more = hi - lo > 1
        lo, hi = lo[more], hi[more]
    fitted = _merge_neighbours(exact, protected, pieces.ptr, fitted, np.sort(np.concatenate(failed)) if failed
                               else np.zeros(0, np.int64), tolerance, clearance, grid)
    return _assemble(pieces, fitted)


_CHUNK = 8


def _fit_checked(exact: Exact, protected: Protected, lo: np.ndarray, hi: np.ndarray, tolerance: float,
                 clearance: float, grid: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`fit` of every range [lo, hi), a batch at a time."""
    bounds = batch_bounds(hi - lo + 2, BATCH)  # samples and protected points grow with the segments
    if len(bounds) <= 1:
        return fit(exact, protected, lo, hi, tolerance, clearance, grid)
    parts = [fit(exact, protected, lo[a:b], hi[a:b], tolerance, clearance, grid) for a, b in bounds]
    kinds, c1s, c2s, oks = zip(*parts)
    return np.concatenate(kinds), np.concatenate(c1s), np.concatenate(c2s), np.concatenate(oks)


def _chunks(ptr: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Every piece of more than one segment cut into near-equal runs of at most ``size``."""
    length = np.diff(ptr)
    count = np.where(length > 1, -(-length // size), 0)
    piece = np.repeat(np.arange(length.size), count)
    k = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    lo = ptr[piece] + (length[piece] * k) // count[piece]
    hi = ptr[piece] + (length[piece] * (k + 1)) // count[piece]
    return lo, hi


def _range_keys(lo: np.ndarray, hi: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """One int64 number per range [lo, hi) of exact segments (``ptr[-1]`` of them)."""
    return lo.astype(np.int64) * (int(ptr[-1]) + 1) + hi


def _merge_neighbours(exact, protected, ptr, fitted, failed, tolerance, clearance, grid):
    """Try once to fit one curve over two neighbouring fitted ranges of a piece (not
    again over a range that did not fit before: ``failed``, sorted :func:`_range_keys`)."""
    if not fitted:
        return fitted
    lo, hi, kinds, c1, c2 = (np.concatenate([f[i] for f in fitted]) for i in range(5))
    order = np.argsort(lo, kind="stable")
    lo, hi, kinds, c1, c2 = lo[order], hi[order], kinds[order], c1.take(order, axis=0), c2.take(order, axis=0)
    piece_of = np.searchsorted(ptr, lo, side="right") - 1
    for parity in (0, 1):
        if lo.size < 2:
            break
        touching = (hi[:-1] == lo[1:]) & (piece_of[:-1] == piece_of[1:])
        a = np.flatnonzero(touching & (np.arange(lo.size - 1) % 2 == parity))
        a = a[~in_sorted(failed, _range_keys(lo[a], hi[a + 1], ptr))]
        if a.size == 0:
            continue
        mk, m1, m2, ok = _fit_checked(exact, protected, lo[a], hi[a + 1], tolerance, clearance, grid)
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
    replaced = np.cumsum(cover)[:n] > 0
    keep = ~replaced | (head >= 0)
    at = np.maximum(head, 0)
    kind = np.where(head >= 0, kinds[at] if los.size else CUBIC, pieces.kind).astype(np.uint8)
    ctrl = np.where((head >= 0)[:, None], c1s.take(at, axis=0) if los.size else 0.0, pieces.ctrl)
    ctrl2 = np.where((head >= 0)[:, None], c2s.take(at, axis=0) if los.size else 0.0, pieces.ctrl2)
    end = np.where((head >= 0)[:, None], pieces.end.take(np.maximum(his[at] - 1, 0), axis=0) if los.size else 0.0,
                   pieces.end)
    piece = np.repeat(np.arange(len(pieces)), np.diff(pieces.ptr))[keep]
    ptr = np.searchsorted(piece, np.arange(len(pieces) + 1)).astype(np.int64)
    return pieces.replace_segments(pieces.start, ptr, kind[keep], ctrl.compress(keep, axis=0),
                                   end.compress(keep, axis=0), ctrl2.compress(keep, axis=0))
