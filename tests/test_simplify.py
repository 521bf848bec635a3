"""depixel/svg/simplify.py's driver: which ranges of exact segments are fitted, and that fitting
some of them ahead of time (a speed choice) never shows in the result."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES
from hypothesis import given
from hypothesis import strategies as st

import depixel.svg.simplify as simplify
from depixel import depixelize, load_image
from depixel.svg.outlines import build_outlines
from depixel.svg.simplify import _descendants, _first_merges, _halves, _next_merges, _range_keys


def _pairs(lo, hi):
    return sorted(zip(np.asarray(lo).tolist(), np.asarray(hi).tolist()))


def test_halves_split_every_range_and_drop_single_segments():
    lo, hi = np.array([0, 8, 11]), np.array([8, 11, 12])
    assert _pairs(*_halves(lo, hi)) == [(0, 4), (4, 8), (9, 11)]  # [8, 9), [11, 12) are single


def test_descendants_are_whole_levels_within_the_budget():
    lo, hi = np.array([0]), np.array([8])
    assert _pairs(*_descendants(lo, hi, 100)) == [(0, 2), (0, 4), (2, 4), (4, 6), (4, 8), (6, 8)]
    assert _pairs(*_descendants(lo, hi, 15)) == [(0, 4), (4, 8)]  # the second level would make 16
    assert _pairs(*_descendants(lo, hi, 7)) == []


def _second_pass(lo, hi, piece, failed_keys, merged, ptr):
    """The ranges the second merge pass asks for after the first merged the ranges ``merged``
    with their next ones (simplify._merge_neighbours' bookkeeping, written out plainly)."""
    items = [[lo[i], hi[i], piece[i]] for i in range(len(lo))]
    for a in sorted(merged, reverse=True):
        items[a][1] = items[a + 1][1]
        del items[a + 1]
    asked = []
    for i in range(1, len(items) - 1, 2):
        (l0, h0, p0), (l1, h1, p1) = items[i], items[i + 1]
        if h0 == l1 and p0 == p1 and _range_keys(np.array([l0]), np.array([h1]), ptr)[0] not in failed_keys:
            asked.append((l0, h1))
    return asked


_seldom = st.integers(0, 5).map(lambda x: x == 0)  # a gap, a new piece


@given(st.lists(st.tuples(st.integers(1, 3), _seldom, _seldom), min_size=2, max_size=14),
       st.lists(st.booleans(), min_size=14, max_size=14), st.data())
def test_the_ranges_fitted_ahead_hold_every_range_of_the_second_merge_pass(runs, merges, data):
    """Whichever of the first pass's merges succeed, the second pass asks only for ranges
    :func:`_next_merges` fitted ahead (unless it gives up over the budget)."""
    # consecutive ranges: a gap before some (not touching), a new piece at some
    lo, hi, piece, at, p = [], [], [], 0, 0
    for length, gap, new_piece in runs:
        at += gap
        p += new_piece
        lo.append(at)
        at += length
        hi.append(at)
        piece.append(p)
    lo, hi, piece = np.array(lo), np.array(hi), np.array(piece)
    ptr = np.array([0, at])
    touching = (hi[:-1] == lo[1:]) & (piece[:-1] == piece[1:])
    spans = data.draw(st.lists(st.tuples(st.integers(0, lo.size - 1), st.integers(1, 4)), max_size=4))
    failed = np.sort(np.array([_range_keys(lo[i : i + 1], hi[min(i + n, lo.size) - 1 :][:1], ptr)[0]
                               for i, n in spans], np.int64))  # some unions of 1-4 ranges did not fit before
    a = np.flatnonzero(touching & (np.arange(lo.size - 1) % 2 == 0))
    a = a[~np.isin(_range_keys(lo[a], hi[a + 1], ptr), failed)]
    ahead = _next_merges(lo, hi, touching, a, failed, ptr)
    assert ahead is not None  # small: within the budget
    merged = [int(x) for x, m in zip(a, merges) if m]
    first = set(zip(lo[a].tolist(), hi[a + 1].tolist()))
    assert set(_second_pass(lo, hi, piece, set(failed.tolist()), merged, ptr)) <= set(_pairs(*ahead)) | first


def test_a_large_first_merge_pass_fits_nothing_ahead(monkeypatch):
    lo = np.arange(0, 24, 2)  # 12 ranges of 2 segments, the even ones to merge
    hi = lo + 2
    touching = np.ones(lo.size - 1, bool)
    a = np.arange(0, lo.size - 1, 2)
    failed = np.zeros(0, np.int64)
    assert _next_merges(lo, hi, touching, a, failed, np.array([0, 24])) is not None
    monkeypatch.setattr(simplify, "SPECULATIVE_SEGMENTS", 143)  # 24 asked + 120 ahead
    assert _next_merges(lo, hi, touching, a, failed, np.array([0, 24])) is None


@given(st.lists(st.tuples(st.integers(1, 3), _seldom, _seldom, st.booleans(), st.booleans()), min_size=1,
                max_size=14), st.data())
def test_the_last_levels_pass_holds_every_range_of_the_first_merge_pass(runs, data):
    """Whichever ranges of the halving's last level fit, the first merge pass asks only for
    ranges :func:`_first_merges` gave to that level's pass to fit ahead."""
    # consecutive ranges (a gap before some, a new piece at some), each fitted at an earlier
    # level or of the last level (at most two segments) and then fitting or not
    lo, hi, earlier, fits, ptr, at = [], [], [], [], [0], 0
    for length, gap, new_piece, before, fitting in runs:
        at += gap
        if new_piece and at > ptr[-1]:
            ptr.append(at)
        lo.append(at)
        at += length if before else min(length, 2)
        hi.append(at)
        earlier.append(before)
        fits.append(fitting)
    ptr.append(at)
    lo, hi, earlier, fits, ptr = np.array(lo), np.array(hi), np.array(earlier), np.array(fits), np.array(ptr)
    # some unions of two neighbours did not fit at an earlier level
    tried = data.draw(st.lists(st.integers(0, max(lo.size - 2, 0)), max_size=3)) if lo.size > 1 else []
    failed = [_range_keys(lo.take(tried), hi.take(np.add(tried, 1)), ptr)] if tried else []
    fitted = [(lo[earlier], hi[earlier])]
    ahead = _first_merges(fitted, lo[~earlier], hi[~earlier], failed, ptr)
    assert ahead is not None  # small: within the budget
    # the first merge pass (simplify._merge_neighbours, written out plainly): every other
    # pair of the fitted ranges in order, where they touch in one piece
    kept = earlier | fits
    final_lo, final_hi = lo[kept], hi[kept]
    piece = np.searchsorted(ptr, final_lo, side="right") - 1
    failed_keys = set(np.concatenate(failed).tolist()) if failed else set()
    asked = [(final_lo[i], final_hi[i + 1]) for i in range(0, final_lo.size - 1, 2)
             if final_hi[i] == final_lo[i + 1] and piece[i] == piece[i + 1]
             and _range_keys(final_lo[i : i + 1], final_hi[i + 1 : i + 2], ptr)[0] not in failed_keys]
    assert set(_pairs(*zip(*asked)) if asked else []) <= set(_pairs(*ahead))


def test_a_large_last_level_fits_no_merge_ahead(monkeypatch):
    lo = np.arange(0, 24, 2)  # 12 touching ranges of 2 segments: 11 pairs of 4, 44 segments
    fitted = [(lo[::2], lo[::2] + 2)]
    args = (fitted, lo[1::2], lo[1::2] + 2, [], np.array([0, 24]))
    assert _pairs(*_first_merges(*args)) == [(i, i + 4) for i in range(0, 21, 2)]
    monkeypatch.setattr(simplify, "MERGE_AHEAD_SEGMENTS", 43)
    assert _first_merges(*args) is None


def _outlines_counting_passes(monkeypatch, vector, speculative, merge_ahead, grid, tolerance):
    """Stacked outlines of ``vector`` simplified at ``tolerance`` under the given fit-ahead
    budgets, and the number of curvefit.fit passes they took."""
    calls = []
    real_fit = simplify.fit
    monkeypatch.setattr(simplify, "SPECULATIVE_SEGMENTS", speculative)
    monkeypatch.setattr(simplify, "MERGE_AHEAD_SEGMENTS", merge_ahead)
    monkeypatch.setattr(simplify, "fit", lambda *args: calls.append(1) or real_fit(*args))
    out = build_outlines(vector, "stacked", grid=grid, simplify=tolerance)
    monkeypatch.setattr(simplify, "fit", real_fit)
    return out, len(calls)


def _assert_same_outlines(a, b):
    for x, y in zip((a.kind, a.ctrl, a.ctrl2, a.end), (b.kind, b.ctrl, b.ctrl2, b.end)):
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")


@pytest.mark.parametrize("name", ["ghost.png", "mushroom.png", "potion_rgba.png"])
def test_fitting_ahead_saves_passes_and_changes_no_curve(name, monkeypatch):
    """The halving's and the merges' later ranges fitted ahead in one pass: fewer calls of
    curvefit.fit, the same curves as one pass per level."""
    vector = depixelize(load_image(FIXTURES / name)).vector
    runs = [_outlines_counting_passes(monkeypatch, vector, budget, budget, grid=1e-2, tolerance=0.25)
            for budget in (0, 1 << 30)]  # never ahead, always
    _assert_same_outlines(*(out for out, _ in runs))
    passes = [count for _, count in runs]
    assert passes[1] <= 2 < passes[0]


def test_the_last_levels_pass_fits_the_first_merges(monkeypatch):
    """mushroom at 0.1 px: the halving's last level (ranges of 2 segments) and the first merge
    pass in one call of curvefit.fit instead of two, the same curves."""
    vector = depixelize(load_image(FIXTURES / "mushroom.png")).vector
    speculative = simplify.SPECULATIVE_SEGMENTS
    runs = [_outlines_counting_passes(monkeypatch, vector, speculative, budget, grid=1e-3, tolerance=0.1)
            for budget in (-1, simplify.MERGE_AHEAD_SEGMENTS)]  # never, the default
    _assert_same_outlines(*(out for out, _ in runs))
    passes = [count for _, count in runs]
    assert passes == [3, 2]
