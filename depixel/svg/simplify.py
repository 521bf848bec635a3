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
A fit is kept only when

* every sample of the exact run lies within ``tolerance`` pixels of the new curve, and it
  is not more than 10 % longer than the run (no loop or bulge between samples),
* no protected point near it — the centres of the pixels beside the piece and the lattice
  corners of the diagonal links at its nodes, the points the optimizer keeps clear of
  (:mod:`depixel.optimize.fidelity`) — lies between the new curve and the run it replaces (which
  would put it on the other side of the boundary), or comes nearer to the new curve than
  ``min(its distance to the exact spline, clearance)``.

So every pixel centre keeps its colour and every thin diagonal stays connected.

Which runs are tried is decided by the curve alone (:mod:`depixel.svg.breaks`): straight runs
stay as they are (a straight run of the spline's quadratics becomes one line); each
*stretch* between them and the pieces' ends is tried whole, and
where it does not fit it is cut at its knots (where the tangent is horizontal or vertical),
else at its joint farthest from the chord, and the parts are tried again; at last
touching fits are merged two at a time, each merge that fits better than both merges it
overlaps. Nothing depends on where a piece's numbering starts or on its direction, so
mirroring or turning the image turns the curves with it, and a change in one place changes
the curves near it only.

This module is the driver (trying, cutting, merging, reassembling the pieces); one fit and
its checks, on whole batches of runs, are :mod:`depixel.svg.curvefit`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..arrays import batch_bounds, in_sorted, unique
from ..vector import VectorImage
from .boundaries import CUBIC, LINE, QUAD, BoundaryPieces
from .breaks import BREAK, Breaks, piece_breaks
from .curvefit import fit
from .reference import BATCH, Exact, Protected

#: ranges [lo, hi) of exact segments: the two arrays
Ranges = tuple[np.ndarray, np.ndarray]


def simplify_pieces(pieces: BoundaryPieces, image: VectorImage, tolerance: float, clearance: float = 0.075,
                    grid: float | None = None) -> BoundaryPieces:
    """Replace runs of segments of every piece by single Béziers while they stay within
    ``tolerance`` pixels of the exact curve and keep the protected points (module docstring).

    ``clearance``: the least distance kept from a protected point that was farther than
    that from the exact curve (pixels). ``grid`` rounds the new control points like the rest.
    """
    if tolerance <= 0 or pieces.kind.size == 0:
        return pieces
    pieces, refs = references(pieces, image, tolerance, clearance)
    return assemble(pieces, *simplified_ranges(refs, tolerance, clearance, grid))


class References(NamedTuple):
    """What the fits of some pieces are made and checked against."""

    ptr: np.ndarray  # (P+1,) the pieces' segments, as BoundaryPieces.ptr
    kind: np.ndarray  # (K,) the segments' kinds
    breaks: Breaks
    exact: Exact
    protected: Protected


def references(pieces: BoundaryPieces, image: VectorImage, tolerance: float, clearance: float
               ) -> tuple[BoundaryPieces, References]:
    """The pieces with their closed ones started at a place of their own
    (:func:`piece_breaks`), and what their fits are checked against: their :class:`Breaks`,
    exact segments and protected points."""
    pieces, breaks = piece_breaks(pieces)
    exact = Exact(pieces, tolerance)
    return pieces, References(pieces.ptr, pieces.kind, breaks, exact,
                              Protected(pieces, image, exact, tolerance + clearance))


def simplified_ranges(refs: References, tolerance: float, clearance: float, grid: float | None,
                      speculative: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ranges [lo, hi) of exact segments (sorted) that become one curve each, their kinds
    and controls, for the pieces of ``refs`` (one image's, or several's one after another:
    every range lies in one piece and is fitted alone). ``speculative``:
    :data:`SPECULATIVE_SEGMENTS` unless larger."""
    fits = _Fits(refs.exact, refs.protected, refs.ptr, tolerance, clearance, grid)
    breaks = refs.breaks
    lo, hi = _merge(fits, breaks, *_with_single_segments(*_top_down(fits, breaks, speculative), breaks.fixed))
    curve = hi - lo > 1  # (a single segment is kept as it is)
    lo, hi = lo[curve], hi[curve]
    kinds, c1, c2, _, _ = fits.get(lo, hi)
    line_lo, line_hi = _bent_straight_runs(refs.ptr, refs.kind, breaks)
    if line_lo.size:
        nan = np.full((line_lo.size, 2), np.nan)
        order = np.concatenate([lo, line_lo]).argsort(kind="stable")
        lo, hi = np.concatenate([lo, line_lo])[order], np.concatenate([hi, line_hi])[order]
        kinds = np.concatenate([kinds, np.full(line_lo.size, LINE, np.uint8)])[order]
        c1, c2 = np.concatenate([c1, nan])[order], np.concatenate([c2, nan])[order]
    return lo, hi, kinds, c1, c2


def _bent_straight_runs(ptr: np.ndarray, kind: np.ndarray, breaks: Breaks) -> Ranges:
    """The ranges [lo, hi) of the straight runs (:class:`Breaks`) with a quadratic, each to be
    written as one line (a closed piece starts at a run's start, :func:`piece_breaks`, so no
    run goes on through a piece's start here); the pieces' ``ptr`` and segment ``kind``."""
    run = breaks.run
    piece_start = np.zeros(run.size, bool)
    piece_start[ptr[:-1].compress(ptr[1:] > ptr[:-1])] = True
    begins = (run >= 0) & (piece_start | (run != np.roll(run, 1)))
    starts = begins.nonzero()[0]
    stops = np.concatenate([(begins | (run < 0)).nonzero()[0], [run.size]])
    ends = stops.take(stops.searchsorted(starts, side="right"))
    quads = np.concatenate([[0], np.cumsum(kind == QUAD)])
    bent = quads.take(ends) > quads.take(starts)
    return starts.compress(bent), ends.compress(bent)


#: a pass of fits costs about a quarter of a millisecond of numpy calls whatever its size,
#: plus 1.5–2 µs a segment: up to this many segments in all, the first pass fits every range
#: the cutting may ask for (about half again as many as it asks for on the paper corpus, for
#: one pass instead of four), else each pass also fits the parts of its :data:`LONG` ranges.
#: The result does not depend on it (a fit depends on its range alone)
SPECULATIVE_SEGMENTS = 2048
#: ranges this long or longer seldom fit (a fifth of them on the paper corpus)
LONG = 8
#: a range of more segments is cut without a try (a twentieth of them fit, at a cost that
#: grows with the square of their length)
MAX_RUN = 12


def _top_down(fits: _Fits, breaks: Breaks, speculative: int = 0) -> Ranges:
    """The ranges that fit: every stretch (:meth:`Breaks.stretches`) if it fits, else its
    parts (:meth:`Breaks.split`) that fit, and so on; a range of more than :data:`MAX_RUN`
    segments is cut without a try."""
    # the tree of the ranges the cutting may ask for: each level the parts of the one before
    levels = [(*breaks.stretches(), np.zeros(0, np.int64))]
    while levels[-1][0].size:
        lo, hi = levels[-1][:2]  # (a run of two segments has no part to try)
        levels.append(breaks.split(lo, hi) if (hi - lo > 2).any() else (lo[:0], hi[:0], lo[:0]))
    tried = [hi - lo <= MAX_RUN for lo, hi, _ in levels]
    every = (np.concatenate([lo[t] for (lo, _, _), t in zip(levels, tried)]),
             np.concatenate([hi[t] for (_, hi, _), t in zip(levels, tried)]))
    whole = int((every[1] - every[0]).sum()) <= max(SPECULATIVE_SEGMENTS, speculative)
    kept = [(levels[0][0][:0], levels[0][1][:0])]
    asked = np.ones(levels[0][0].size, bool)  # the ranges of a level whose run did not fit
    for depth, (lo, hi, _) in enumerate(levels[:-1]):
        part_lo, part_hi, run = levels[depth + 1]
        if whole:
            ahead = every
        else:  # the parts of the long ranges, which seldom fit
            long = ((hi - lo >= LONG) & asked).take(run) & tried[depth + 1]
            ahead = part_lo[long], part_hi[long]
        now = asked & tried[depth]
        ok = np.zeros(lo.size, bool)
        ok[now] = fits.get(lo[now], hi[now], ahead)[3]
        kept.append((lo[ok], hi[ok]))
        asked = (asked & ~ok).take(run)
    return np.concatenate([lo for lo, _ in kept]), np.concatenate([hi for _, hi in kept])


#: a merge is chosen over an overlapping one only when its curve's error is smaller by more
#: than this (pixels): closer ones count as a tie, so the numbers of a mirrored image, which
#: differ in the last bits, make the same choice
_MARGIN = 1e-6


def _merge(fits: _Fits, breaks: Breaks, lo: np.ndarray, hi: np.ndarray) -> Ranges:
    """The touching ranges [lo, hi) (sorted) of a stretch merged two at a time where one
    curve fits both and it is nearer to the exact run than the curves of the two merges it
    overlaps (so the choice depends neither on a piece's direction nor on where it starts,
    and only on the neighbourhood; a tie merges neither). Once: a second round would save
    0.3 % of the commands on the paper corpus, for another pass of fits."""
    pair = ((hi[:-1] == lo[1:]) & (breaks.joint.take(lo[1:]) != BREAK)).nonzero()[0]  # i and i + 1 touch
    if pair.size == 0:
        return lo, hi
    _, _, _, ok, err = fits.get(lo.take(pair), hi.take(pair + 1))
    error = np.full(lo.size + 1, np.inf)  # error[i + 1]: of the merge of ranges i and i + 1 (inf: none)
    error[pair + 1] = np.where(ok, err, np.inf)
    chosen = (np.isfinite(error[1:-1]) & (error[1:-1] < error[:-2] - _MARGIN)
              & (error[1:-1] < error[2:] - _MARGIN)).nonzero()[0]
    hi[chosen] = hi.take(chosen + 1)
    keep = np.ones(lo.size, bool)
    keep[chosen + 1] = False
    return lo.compress(keep), hi.compress(keep)


def _with_single_segments(lo: np.ndarray, hi: np.ndarray, fixed: np.ndarray) -> Ranges:
    """The ranges [lo, hi) and, as ranges of their own, the segments outside them that are
    not part of a straight run (``fixed``): all of them, sorted."""
    n = fixed.size
    cover = np.zeros(n + 1, np.int64)
    np.add.at(cover, lo, 1)
    np.add.at(cover, hi, -1)
    single = ((cover.cumsum()[:n] == 0) & ~fixed).nonzero()[0]
    lo, hi = np.concatenate([lo, single]), np.concatenate([hi, single + 1])
    order = lo.argsort(kind="stable")
    return lo.take(order), hi.take(order)


class _Fits:
    """:func:`fit` of ranges [lo, hi) of exact segments, each range fitted once (a batch at a
    time, :data:`BATCH`), and ranges asked for later fitted ahead in the same pass."""

    def __init__(self, exact: Exact, protected: Protected, ptr: np.ndarray, tolerance: float, clearance: float,
                 grid: float | None) -> None:
        self.exact, self.protected, self.ptr = exact, protected, ptr
        self.tolerance, self.clearance, self.grid = tolerance, clearance, grid
        self.keys = np.zeros(0, np.int64)  # sorted _range_keys of the ranges fitted so far
        self.kind, self.ok, self.err = np.zeros(0, np.uint8), np.zeros(0, bool), np.zeros(0)
        self.c1, self.c2 = np.zeros((0, 2)), np.zeros((0, 2))

    def get(self, lo: np.ndarray, hi: np.ndarray, ahead: Ranges | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(kind, c1, c2, ok, error)`` of the ranges [lo, hi) of two segments or more
        (:func:`fit`); when that takes a pass, the ranges ``ahead`` are fitted in it too."""
        keys = _range_keys(lo, hi, self.ptr)
        new = keys[~in_sorted(self.keys, keys)]
        if new.size:
            if ahead is not None:
                extra = _range_keys(*ahead, self.ptr)
                new = np.concatenate([new, extra[~in_sorted(self.keys, extra)]])
            new = unique(new)  # (arrays.unique: np.unique alone would import numpy.ma)
            new_lo, new_hi = np.divmod(new, int(self.ptr[-1]) + 1)
            kind, c1, c2, ok, err = self._fit(new_lo, new_hi)
            order = np.concatenate([self.keys, new]).argsort(kind="stable")
            self.keys = np.concatenate([self.keys, new])[order]
            self.kind, self.ok = np.concatenate([self.kind, kind])[order], np.concatenate([self.ok, ok])[order]
            self.err = np.concatenate([self.err, err])[order]
            self.c1 = np.concatenate([self.c1, c1]).take(order, axis=0)
            self.c2 = np.concatenate([self.c2, c2]).take(order, axis=0)
        at = self.keys.searchsorted(keys)
        return self.kind[at], self.c1.take(at, axis=0), self.c2.take(at, axis=0), self.ok[at], self.err[at]

    def _fit(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, ...]:
        bounds = batch_bounds(hi - lo + 2, BATCH)  # samples and protected points grow with the segments
        parts = [fit(self.exact, self.protected, lo[a:b], hi[a:b], self.tolerance, self.clearance, self.grid)
                 for a, b in bounds]
        return tuple(np.concatenate(x) for x in zip(*parts)) if len(parts) > 1 else parts[0]


def _range_keys(lo: np.ndarray, hi: np.ndarray, ptr: np.ndarray) -> np.ndarray:
    """One int64 number per range [lo, hi) of exact segments (``ptr[-1]`` of them)."""
    return lo.astype(np.int64) * (int(ptr[-1]) + 1) + hi


def assemble(pieces: BoundaryPieces, lo: np.ndarray, hi: np.ndarray, kinds: np.ndarray, c1s: np.ndarray,
              c2s: np.ndarray) -> BoundaryPieces:
    """The pieces with each range [lo, hi) replaced by its curve (``kinds``, controls ``c1s``, ``c2s``)."""
    n = pieces.kind.size
    head = np.full(n, -1, np.int64)  # the range starting at each exact segment
    head[lo] = np.arange(lo.size)
    cover = np.zeros(n + 1, np.int64)
    np.add.at(cover, lo, 1)
    np.add.at(cover, hi, -1)
    keep = (cover.cumsum()[:n] == 0) | (head >= 0)
    at = np.maximum(head, 0)
    new = head >= 0
    kind = np.where(new, kinds[at] if lo.size else CUBIC, pieces.kind).astype(np.uint8)
    ctrl = np.where(new[:, None], c1s.take(at, axis=0) if lo.size else 0.0, pieces.ctrl)
    ctrl2 = np.where(new[:, None], c2s.take(at, axis=0) if lo.size else 0.0, pieces.ctrl2)
    end = np.where(new[:, None], pieces.end.take(np.maximum(hi[at] - 1, 0), axis=0) if lo.size else 0.0, pieces.end)
    piece = np.arange(len(pieces)).repeat(np.diff(pieces.ptr))[keep]
    ptr = piece.searchsorted(np.arange(len(pieces) + 1)).astype(np.int64)
    return pieces.replace_segments(pieces.start, ptr, kind[keep], ctrl.compress(keep, axis=0),
                                   end.compress(keep, axis=0), ctrl2.compress(keep, axis=0))
