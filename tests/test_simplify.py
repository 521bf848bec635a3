"""depixel/simplify.py's driver: which ranges of exact segments are fitted, and that fitting
some of them ahead of time (a speed choice) never shows in the result."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES
from hypothesis import given
from hypothesis import strategies as st

import depixel.simplify as simplify
from depixel import depixelize, load_image
from depixel.outlines import build_outlines
from depixel.simplify import _descendants, _halves, _next_merges, _range_keys


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


@pytest.mark.parametrize("name", ["ghost.png", "mushroom.png", "potion_rgba.png"])
def test_fitting_ahead_saves_passes_and_changes_no_curve(name, monkeypatch):
    """The halving's and the merges' later ranges fitted ahead in one pass: fewer calls of
    curvefit.fit, the same curves as one pass per level."""
    vector = depixelize(load_image(FIXTURES / name)).vector
    results, passes = [], []
    real_fit = simplify.fit
    for budget in (0, 1 << 30):  # never ahead, always
        calls = []
        monkeypatch.setattr(simplify, "SPECULATIVE_SEGMENTS", budget)
        monkeypatch.setattr(simplify, "fit", lambda *args, calls=calls: calls.append(1) or real_fit(*args))
        out = build_outlines(vector, "stacked", grid=1e-2, simplify=0.25)
        results.append((out.kind, np.nan_to_num(out.ctrl, nan=-1), np.nan_to_num(out.ctrl2, nan=-1), out.end))
        passes.append(len(calls))
    for a, b in zip(*results):
        assert a.shape == b.shape and np.array_equal(a, b)
    assert passes[1] <= 2 < passes[0]
