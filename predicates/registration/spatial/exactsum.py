"""Exact sums of binary64 numbers, for means that do not depend on how the numbers are
ordered or split (docs/partitioned.md, section 2: the broad-phase grid's cell size is a
mean box extent; a partitioned plan combines per-partition sums of it).

Every finite binary64 number is an integer multiple of 2^-1074, so Σx is an exact
Python int in those units. :class:`ExactSum` gets there without a sort and without a
Python loop over the values: each value is split (Veltkamp, exact) into a high part of
at most 26 significant bits and a low remainder, and both are summed per binary
exponent of the value with ``np.bincount``. Inside one binade [2^e, 2^(e+1)) every high
part is a multiple of 2^(e−26) below 2^(e+1) and every low part a multiple of 2^(e−52)
below 2^(e−26) in magnitude, so up to 2^25 values per binade sum exactly in binary64;
the sums are moved into the Python int before that. Subnormals (and numbers too large
to split) are summed from their bits as integers. Sums of parts combine by integer
addition (:meth:`ExactSum.merge`), so the total — and :meth:`ExactSum.mean`, Σx/n
rounded once to nearest (CPython's int/int division is correctly rounded) — is the same
bit for bit for any order of the values and any split of them into blocks, threads or
workers.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ExactSum"]

_BINS = 2048  # biased binary64 exponents
_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's constant for a 26-bit high part
_BIG = 2.0 ** 995  # from here x·_SPLIT could overflow: summed from the bits
_FLUSH = 1 << 25  # values per binade the float accumulators hold exactly
_SPREAD = 9  # binades a block may span for two plain float sums (:meth:`_narrow`)
_TINY = 2.0 ** -1000  # the narrow path's values are normal, and so are their parts


class ExactSum:
    """Σ of non-negative binary64 values (−0.0 counts as 0), exactly, and their count.
    Infinities and NaN are kept apart: the sum is then inf or NaN, as a float sum."""

    def __init__(self, accelerate: bool = False):
        #: blocks that fit the narrow path checked and summed by one compiled kernel
        #: (predicates.compiled.cellsums.narrow_sums: the same exact sums)
        self.accelerate = accelerate
        self.units = 0  # Σ in units of 2^-1074 (flushed part)
        self.acc = np.zeros((2, _BINS))  # per-binade float sums of high and low parts
        self.pending = 0  # values in ``acc`` since the last flush
        self.n = 0
        self.bad = 0.0  # the float sum of the infinities / NaN seen, else 0.0

    def add(self, x: np.ndarray) -> "ExactSum":
        """Add the values of ``x`` (1D binary64, ≥ 0 or −0.0)."""
        x = np.asarray(x, dtype=np.float64)
        self.n += len(x)
        if self.accelerate:
            from predicates.compiled.cellsums import narrow_sums

            x = np.ascontiguousarray(x)
        for a in range(0, len(x), 1 << 16):
            if self.accelerate:
                status, *sums = narrow_sums(x[a:a + (1 << 16)], _BIG, _TINY, _SPREAD, _SPLIT)
                if status == 2:
                    self._add_floats(sums)
                if status:
                    continue
            self._block(x[a:a + (1 << 16)] + 0.0)  # + 0.0: −0.0 becomes +0.0
        return self

    def _add_floats(self, values) -> None:
        """Add binary64 values that are multiples of 2^-1074 (exact sums), exactly."""
        for v in values:
            num, den = float(v).as_integer_ratio()
            self.units += num * ((1 << 1074) // den)

    def _block(self, x: np.ndarray) -> None:
        if len(x) == 0:
            return
        top = float(x.max())
        if not top < _BIG:  # inf, NaN or huge values: those apart, the rest exactly
            odd = ~(x < np.inf)
            if odd.any():
                self.bad += float(x[odd].sum())
                x = x[~odd]
            big = x >= _BIG
            self._bits(x[big])
            x = x[~big]
        bits = x.view(np.int64)
        tiny = (bits > 0) & (bits < (1 << 52))
        if tiny.any():  # subnormals: integers in units of 2^-1074
            self._bits(x[tiny])
            x = x[~tiny]
            bits = x.view(np.int64)
        if self._narrow(x):
            return
        if self.pending + len(x) > _FLUSH:
            self._flush()
        expo = bits >> 52
        c = x * _SPLIT
        hi = c - (c - x)
        lo = x - hi
        self.acc[0] += np.bincount(expo, weights=hi, minlength=_BINS)
        self.acc[1] += np.bincount(expo, weights=lo, minlength=_BINS)
        self.pending += len(x)

    def _narrow(self, x: np.ndarray) -> bool:
        """Sum a block (≤ 2^16 finite normal values or zeros, below _BIG) whose
        non-zero values span at most :data:`_SPREAD` + 1 binades with two plain float
        sums, if so: every high part is then a multiple of 2^(e−25) (e: the least
        exponent) and the sum of 2^16 of them below 2^(e+_SPREAD+18), every low part a
        multiple of 2^(e−52) with a sum below 2^(e+_SPREAD−9) in magnitude — at most
        53 significant bits, so every partial sum is exact whatever the summation
        order, and the float sums are the exact ones. False: not summed."""
        if len(x) == 0:
            return True
        pos = x[x > 0]
        if len(pos) == 0:
            return True
        e_lo, e_hi = np.frexp(np.array([pos.min(), pos.max()]))[1]
        if pos.min() < _TINY or e_hi - e_lo > _SPREAD:
            return False
        c = x * _SPLIT
        hi = c - (c - x)
        self._add_floats((float(hi.sum()), float((x - hi).sum())))
        return True

    def _bits(self, x: np.ndarray) -> None:
        """Add finite values exactly, one by one (few: subnormals, huge values)."""
        for v in x.tolist():
            num, den = v.as_integer_ratio()  # den a power of two dividing 2^1074
            self.units += num * ((1 << 1074) // den)

    def _flush(self) -> None:
        for v in self.acc.ravel()[np.flatnonzero(self.acc.ravel())].tolist():
            num, den = v.as_integer_ratio()  # a multiple of 2^-1074: den divides 2^1074
            self.units += num * ((1 << 1074) // den)
        self.acc[:] = 0.0
        self.pending = 0

    def merge(self, other: "ExactSum") -> "ExactSum":
        """This sum plus ``other``'s (exact: integers)."""
        self._flush()
        other._flush()
        self.units += other.units
        self.n += other.n
        self.bad += other.bad
        return self

    def total(self) -> int:
        """Σx in units of 2^-1074 (an exact Python int; finite values only)."""
        self._flush()
        return self.units

    def mean(self) -> float:
        """Σx / n rounded once to nearest (0.0 for no values)."""
        if self.bad != 0.0 or self.bad != self.bad:
            return self.bad / max(self.n, 1)
        if self.n == 0:
            return 0.0
        return self.total() / (self.n << 1074)
