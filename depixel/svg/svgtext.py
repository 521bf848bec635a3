"""Vectorized text for the SVG writer: many short ASCII strings in one byte buffer.

A 256×224 frame gives about a million path tokens; building each with Python string
operations costs a microsecond or more apiece, mostly in cache misses. Here a table of
strings is a flat ``uint8`` buffer plus start offsets and lengths, and formatting numbers,
concatenating columns and writing a token sequence are whole-array numpy operations.
"""
from __future__ import annotations

from collections.abc import Sequence
from copy import copy
from dataclasses import dataclass
from itertools import accumulate

import numpy as np

from ..arrays import consecutive_slices

#: segments are copied in chunks of about this many bytes, to bound temporary memory
_CHUNK = 1 << 22


@dataclass(frozen=True, eq=False)
class Texts:
    """``n`` ASCII strings: string i is ``data[start[i] : start[i] + length[i]]``."""

    data: np.ndarray  # (total,) uint8
    start: np.ndarray  # (n,) int64
    length: np.ndarray  # (n,) int64

    def __len__(self) -> int:
        return int(self.start.size)

    @classmethod
    def of(cls, strings: Sequence[str]) -> Texts:
        """A table from Python strings (for constants and short lists)."""
        encoded = [s.encode("ascii") for s in strings]
        length = np.array([len(b) for b in encoded], dtype=np.int64)
        data = np.frombuffer(b"".join(encoded), dtype=np.uint8)
        return cls(data, length.cumsum() - length, length)

    def take(self, index: np.ndarray) -> Texts:
        """The strings at ``index``, sharing this table's buffer."""
        return Texts(self.data, self.start[index], self.length[index])

    def tobytes(self) -> bytes:
        """All strings concatenated in order."""
        return _copy_segments(self.data, self.start, self.length).tobytes()

    def tolist(self) -> list[str]:
        text = self.tobytes().decode("ascii")
        return [text[part] for part in consecutive_slices(self.length.tolist())]


def stack(tables: Sequence[Texts]) -> tuple[Texts, list[int]]:
    """One table holding the rows of every table in turn, and each table's first row.
    Tables that share a buffer (views made with :meth:`take`) share it here too."""
    buffers: list[np.ndarray] = []
    data_offset = []
    for t in tables:
        same = next((i for i, b in enumerate(buffers) if b is t.data), None)
        if same is None:
            buffers.append(t.data)
            same = len(buffers) - 1
        data_offset.append(sum(b.size for b in buffers[:same]))
    start = np.concatenate([t.start + off for t, off in zip(tables, data_offset)])
    length = np.concatenate([t.length for t in tables])
    first_rows = list(accumulate((len(t) for t in tables[:-1]), initial=0))  # (np.cumsum of a list: ~15 µs)
    return Texts(np.concatenate(buffers), start, length), first_rows


def numbers(values: np.ndarray, precision: int, prefix: str = "", compact: bool = False) -> Texts:
    """Fixed-precision decimals without trailing zeros (byte-stable, never "-0").

    ``values`` are rounded to ``precision`` decimals; 1.5 → "1.5", 2.0 → "2", -0.25 → "-0.25"
    (with ``compact``, as SVG path data allows: 0.25 → ".25", -0.25 → "-.25").
    A 1-d array gives one string per value; an ``(n, k)`` array one string per row, its k
    numbers separated by spaces. Every string starts with ``prefix``.
    """
    values = np.asarray(values, dtype=np.float64)
    n = len(values)
    k = int(np.prod(values.shape[1:], dtype=np.int64)) if values.ndim > 1 else 1
    decimals = Decimals.rounded(values.ravel(), precision)
    if k == 1 and not prefix:
        return decimals.texts(compact)
    return _rows(decimals, n, k, prefix, compact)


def _rows(decimals: Decimals, n: int, k: int, prefix: str, compact: bool) -> Texts:
    """:func:`numbers` by character planes: ``n`` strings of ``k`` numbers after ``prefix``."""
    digit_planes, keep_planes = _decimal_planes(decimals, compact)  # (W, n*k)
    digits, digits_keep = digit_planes.T, keep_planes.T  # (n*k, W)
    lead, width = len(prefix), digits.shape[1] + 1  # each number: a space, then its digits
    chars = np.empty((n, lead + k * width), dtype=np.uint8)
    keep = np.empty(chars.shape, dtype=bool)
    chars[:, :lead], keep[:, :lead] = np.frombuffer(prefix.encode("ascii"), np.uint8), True
    body, body_keep = chars[:, lead:].reshape(n, k, width), keep[:, lead:].reshape(n, k, width)
    body[..., 0], body_keep[..., 0] = ord(" "), True
    body_keep[:, 0, 0] = False  # no space before the first number of a row
    body[..., 1:], body_keep[..., 1:] = digits.reshape(n, k, width - 1), digits_keep.reshape(n, k, width - 1)
    length = keep.sum(axis=1)
    return Texts(chars.ravel().compress(keep.ravel()), length.cumsum() - length, length)


def number(value: float, precision: int) -> str:
    """:func:`numbers` of one value, in plain Python: for the few numbers of a document's
    head and attributes (the array path costs ~40 numpy calls, ~80 µs, whatever the count)."""
    scaled = round(value * 10**precision)  # (half to even, as numpy's round)
    whole, frac = divmod(abs(scaled), 10**precision)
    text = f"{whole}.{frac:0{precision}d}".rstrip("0") if frac else str(whole)
    return "-" + text if scaled < 0 else text


class Decimals:
    """Decimals of ``precision`` places given as integers ``scaled`` in 10^-precision units:
    their whole and fraction parts, and the characters a number can have (a sign,
    ``n_digits`` whole digits, a point, ``precision`` fraction digits). The SVG writer
    measures the texts of numbers (:meth:`digit_counts`) before it picks which to format."""

    def __init__(self, scaled: np.ndarray, precision: int) -> None:
        self.precision = precision
        self.scaled = scaled  # (n,) int64
        self.whole, self.frac = np.divmod(np.abs(scaled), 10**precision)
        self.n_digits = max(len(str(int(np.maximum.reduce(self.whole, initial=0)))), 1)

    @classmethod
    def rounded(cls, values: np.ndarray, precision: int) -> Decimals:
        """``values`` rounded to ``precision`` decimals (half to even)."""
        return cls((values * 10**precision).round().astype(np.int64), precision)

    @property
    def width(self) -> int:
        return 2 + self.n_digits + self.precision  # characters

    def take(self, index: np.ndarray) -> Decimals:
        """The numbers at ``index`` (``n_digits`` kept: a bound, the texts do not change)."""
        picked = copy(self)
        picked.scaled, picked.whole, picked.frac = (a.take(index) for a in (self.scaled, self.whole, self.frac))
        return picked

    def digit_counts(self) -> tuple[np.ndarray, np.ndarray]:
        """Each number's whole digits (1 for 0) and fraction digits up to its last nonzero
        one (0 without a fraction): its text is a sign, those, and a point between."""
        if self.n_digits <= _TABLE_DIGITS:
            n_whole = _digit_tables(self.n_digits)[1].take(self.whole)
        else:
            n_whole = 1 + sum((self.whole >= 10**i for i in range(1, self.n_digits)), np.int64(0))
        p, frac = self.precision, self.frac
        if p <= _TABLE_DIGITS:
            n_frac = _digit_tables(p)[2].take(frac) if p else np.zeros(frac.size, np.int64)
        else:  # the places less the fraction's trailing zeros
            n_frac = np.where(frac != 0, p - sum((frac % 10**i == 0 for i in range(1, p)), np.int64(0)), 0)
        return n_whole, n_frac

    def texts(self, compact: bool = False) -> Texts:
        """:func:`numbers` of these numbers, one a string."""
        if max(self.n_digits, self.precision) <= _TABLE_DIGITS:  # the path data's
            return _packed(self, compact)
        return _rows(self, self.scaled.size, 1, "", compact)


#: numbers whose whole and fraction parts have at most this many digits are formatted by
#: table look-ups (:func:`_packed`)
_TABLE_DIGITS = 3
_tables: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _digit_tables(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For every v < 10**k: its k digits (zero-padded, in reading order) as the bytes of a
    little-endian integer, its number of digits (1 for 0), and the number of digits of v as
    a fraction of k places up to its last nonzero one (0 for 0). Built on first use."""
    if k not in _tables:
        v = np.arange(10**k)
        digits = np.zeros(v.size, np.int64)
        n_whole, n_frac = np.ones(v.size, np.int64), np.zeros(v.size, np.int64)
        for i in range(k):  # the digit of place 10**i is the (k - 1 - i)-th character
            digit = v // 10**i % 10
            digits += (digit + ord("0")) << 8 * (k - 1 - i)
            n_whole += (v >= 10 ** (i + 1)) if i + 1 < k else 0
            n_frac = np.where((n_frac == 0) & (digit != 0), k - i, n_frac)
        _tables[k] = digits, n_whole, n_frac
    return _tables[k]


def _packed(d: Decimals, compact: bool) -> Texts:
    """:func:`numbers` of one number a string, without a prefix, when its whole and fraction
    parts have at most :data:`_TABLE_DIGITS` digits: each number's characters in one
    little-endian 8-byte integer, a character a byte in the places of :func:`_decimal_planes`'
    planes (the sign slot, the whole digits, the point, the fraction digits), from two table
    look-ups (no (W, n) planes to transpose, nor kept characters to gather); a number's text
    is the run of its word from its first character to its last, the sign written over the
    "0" just before its first digit kept."""
    whole, frac, n_digits, precision = d.whole, d.frac, d.n_digits, d.precision
    point = n_digits + 1
    whole_digits, n_whole, _ = _digit_tables(n_digits)
    word = whole_digits.take(whole) << 8  # after the sign slot
    word |= ord("0") | (ord(".") << 8 * point)
    first = point - n_whole.take(whole)  # the first significant whole digit
    if precision:
        frac_digits, _, n_frac = _digit_tables(precision)
        word |= frac_digits.take(frac) << 8 * (point + 1)
        n_frac = n_frac.take(frac)
        has_frac = n_frac != 0
        if compact:  # no units digit "0" before a fraction
            first[(whole == 0) & has_frac] = point
        last = point + n_frac - ~has_frac  # the last nonzero fraction digit, or the units digit
    else:
        last = np.full(whole.size, n_digits)
    minus = d.scaled < 0
    word -= (minus * (ord("0") - ord("-"))) << 8 * (first - 1)
    first -= minus
    return Texts(word.astype("<i8", copy=False).view(np.uint8), np.arange(0, 8 * whole.size, 8) + first,
                 last - first + 1)


def _decimal_planes(d: Decimals, compact: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Characters ``(W, n) uint8`` of the formatted values, a plane per character position
    (contiguous rows: numpy writes and sums those several times faster than the columns of
    an (n, W) table), and which of them to keep (``compact``: no units digit "0" before a
    fraction)."""
    scaled, whole, frac, n_digits = d.scaled, d.whole, d.frac, d.n_digits
    # planes: sign, n_digits whole digits, ".", precision fraction digits
    chars = np.empty((d.width, scaled.size), dtype=np.uint8)
    keep = np.empty(chars.shape, dtype=bool)
    chars[0], keep[0] = ord("-"), scaled < 0
    rest = whole
    for col in range(n_digits, 0, -1):  # least significant first; scalar divisors are fast
        rest, digit = np.divmod(rest, 10)
        np.add(digit, ord("0"), out=chars[col], casting="unsafe")
        np.greater_equal(whole, 10 ** (n_digits - col), out=keep[col])
    keep[n_digits] = ~((whole == 0) & (frac != 0)) if compact else True  # the units digit, even of 0
    chars[n_digits + 1] = ord(".")
    np.not_equal(frac, 0, out=keep[n_digits + 1])
    rest, nonzero_after = frac, np.zeros(scaled.size, dtype=bool)
    for col in range(chars.shape[0] - 1, n_digits + 1, -1):  # keep digits up to the last nonzero one
        rest, digit = np.divmod(rest, 10)
        np.add(digit, ord("0"), out=chars[col], casting="unsafe")
        nonzero_after |= digit != 0
        keep[col] = nonzero_after
    return chars, keep


def _copy_segments(data: np.ndarray, start: np.ndarray, length: np.ndarray) -> np.ndarray:
    """``data[start[i] : start[i] + length[i]]`` for every i, concatenated."""
    nonempty = length > 0
    start, length = start.compress(nonempty), length.compress(nonempty)
    ends = length.cumsum()
    if ends.size == 0:
        return np.zeros(0, dtype=np.uint8)
    bounds = ends.searchsorted(np.arange(_CHUNK, int(ends[-1]), _CHUNK), side="right")
    parts = []
    bounds = bounds.tolist()
    for a, b in zip([0] + bounds, bounds + [start.size]):
        if a == b:
            continue
        s, ln = start[a:b], length[a:b]
        # source index: +1 within a segment, a jump to the next segment's start between them
        run_end = ln.cumsum()
        step = np.ones(int(run_end[-1]), dtype=np.int32 if data.size < 2**31 else np.int64)
        first = run_end - ln
        step[0] = s[0]
        step[first[1:]] = s[1:] - (s[:-1] + ln[:-1] - 1)
        parts.append(data[step.cumsum(out=step)])
    return np.concatenate(parts) if len(parts) > 1 else parts[0]
