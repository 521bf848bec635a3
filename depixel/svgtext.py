"""Vectorized text for the SVG writer: many short ASCII strings in one byte buffer.

A 256×224 frame gives about a million path tokens; building each with Python string
operations costs a microsecond or more apiece, mostly in cache misses. Here a table of
strings is a flat ``uint8`` buffer plus start offsets and lengths, and formatting numbers,
concatenating columns and writing a token sequence are whole-array numpy operations.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

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
        return cls(data, np.cumsum(length) - length, length)

    def take(self, index: np.ndarray) -> Texts:
        """The strings at ``index``, sharing this table's buffer."""
        return Texts(self.data, self.start[index], self.length[index])

    def tobytes(self) -> bytes:
        """All strings concatenated in order."""
        return _copy_segments(self.data, self.start, self.length).tobytes()

    def tolist(self) -> list[str]:
        text = self.tobytes().decode("ascii")
        ends = np.cumsum(self.length).tolist()
        return [text[a:b] for a, b in zip([0] + ends[:-1], ends)]


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
    first_rows = np.cumsum([0] + [len(t) for t in tables[:-1]]).tolist()
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
    digit_planes, keep_planes = _decimal_planes(values.ravel(), precision, compact)  # (W, n*k)
    if k == 1 and not prefix:  # one number a string (the path data's): its characters alone
        length = keep_planes.sum(axis=0)
        chars = digit_planes.T.ravel()  # (n, W) in order, a copy
        return Texts(chars.compress(keep_planes.T.ravel()), np.cumsum(length) - length, length)
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
    return Texts(chars.ravel().compress(keep.ravel()), np.cumsum(length) - length, length)


def _decimal_planes(values: np.ndarray, precision: int, compact: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Characters ``(W, n) uint8`` of the formatted values, a plane per character position
    (contiguous rows: numpy writes and sums those several times faster than the columns of
    an (n, W) table), and which of them to keep (``compact``: no units digit "0" before a
    fraction)."""
    scaled = np.round(values * 10**precision).astype(np.int64)
    whole, frac = np.divmod(np.abs(scaled), 10**precision)
    n_digits = max(len(str(int(whole.max(initial=0)))), 1)
    # planes: sign, n_digits whole digits, ".", precision fraction digits
    chars = np.empty((2 + n_digits + precision, scaled.size), dtype=np.uint8)
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
    start, length = start[nonempty], length[nonempty]
    ends = np.cumsum(length)
    if ends.size == 0:
        return np.zeros(0, dtype=np.uint8)
    bounds = np.searchsorted(ends, np.arange(_CHUNK, int(ends[-1]), _CHUNK), side="right")
    parts = []
    bounds = bounds.tolist()
    for a, b in zip([0] + bounds, bounds + [start.size]):
        if a == b:
            continue
        s, ln = start[a:b], length[a:b]
        # source index: +1 within a segment, a jump to the next segment's start between them
        step = np.ones(int(ln.sum()), dtype=np.int32 if data.size < 2**31 else np.int64)
        first = np.cumsum(ln) - ln
        step[0] = s[0]
        step[first[1:]] = s[1:] - (s[:-1] + ln[:-1] - 1)
        parts.append(data[np.cumsum(step, out=step)])
    return np.concatenate(parts) if len(parts) > 1 else parts[0]
