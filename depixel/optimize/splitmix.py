"""The relaxation's seeded random numbers: SplitMix64 in whole-array numpy operations.

``numpy.random`` costs ~13 ms of every conversion process to import (its bit generators,
``secrets``, ``hmac``, pickling support), more than a small sprite's relaxation spends
drawing numbers. The relaxation needs only uniform numbers and a shuffle, of no weight
beyond "spread evenly", so it draws them from SplitMix64 (Steele, Lea and Flood, "Fast
splittable pseudorandom number generators", OOPSLA 2014): draw ``k`` of a stream is a fixed
64-bit mix of ``seed + k·γ``, so a batch of draws is a handful of in-place array operations,
and the numbers depend only on the seed and on how many were drawn before.
"""
from __future__ import annotations

import numpy as np

_GAMMA = np.uint64(0x9E3779B97F4A7C15)  # 2⁶⁴ / golden ratio, odd: the stream's step
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_SHIFTS = (np.uint64(30), np.uint64(27), np.uint64(31))
_HALF, _LOW = np.uint64(32), np.uint64(0xFFFFFFFF)


class SplitMix64:
    """A seeded stream of random numbers; every call continues where the last one ended."""

    def __init__(self, seed: int) -> None:
        self._base = np.uint64(seed % 2**64)
        self._drawn = 0  # draws taken so far

    def bits(self, count: int) -> np.ndarray:
        """The next ``count`` 64-bit draws, ``(count,) uint64``."""
        z = np.arange(self._drawn + 1, self._drawn + count + 1, dtype=np.uint64)
        self._drawn += count
        z *= _GAMMA  # uint64 arithmetic wraps modulo 2⁶⁴, as the mix wants
        z += self._base
        shifted = z >> _SHIFTS[0]
        z ^= shifted
        z *= _MIX1
        np.right_shift(z, _SHIFTS[1], out=shifted)
        z ^= shifted
        z *= _MIX2
        np.right_shift(z, _SHIFTS[2], out=shifted)
        z ^= shifted
        return z

    def unit_pairs(self, count: int) -> np.ndarray:
        """``(count, 2) float64`` uniform in [0, 1): the two 32-bit halves of each of the next
        ``count`` draws (one draw per pair halves the mixing; 2⁻³² is far below any use here)."""
        z = self.bits(count)
        pairs = np.empty((count, 2))
        pairs[:, 0] = z >> _HALF  # by shifts, not a uint32 view: the same numbers on any byte order
        pairs[:, 1] = z & _LOW
        pairs *= 2.0**-32
        return pairs

    def permutation(self, n: int) -> np.ndarray:
        """A shuffled ``arange(n)``: the order of ``n`` random keys."""
        return self.bits(n).argsort(kind="stable")
