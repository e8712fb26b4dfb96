"""Min/max envelopes of per-period signals, built while the run streams.

Each bucket covers `width` consecutive periods and keeps, per signal, its minimum
and maximum and the period at which each occurred, so a line drawn through the
extremes in time order (the M4 idea: what one pixel column of a line chart can
show) loses no peak and no dip. A bucket also keeps the sample row of its first
period (position, distance, ...) and a count per category (the limiting reason).

Memory is fixed: when the periods outgrow the buckets, neighbouring buckets are
merged pairwise and the width doubles, so a 48-minute program ends with between
`max_buckets`/2 and `max_buckets` buckets, the same as a 10-second one.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def fold(values, first, width, lo, hi, arg_lo, arg_hi):
    """Fold values[k, j] (period first + k, signal j; NaN = undefined) into the buckets of `width`
    periods: bucket b covers periods [b·width, (b+1)·width). Ties keep the earlier period."""
    n, m = values.shape
    for k in range(n):
        p = first + k
        b = p // width
        for j in range(m):
            v = values[k, j]
            if v != v:
                continue
            if v < lo[b, j]:
                lo[b, j] = v
                arg_lo[b, j] = p
            if v > hi[b, j]:
                hi[b, j] = v
                arg_hi[b, j] = p


@njit(cache=True)
def merge_pairs(lo, hi, arg_lo, arg_hi, used):
    """Buckets 2b and 2b+1 become bucket b (in place); the rest is reset to empty."""
    half = (used + 1) // 2
    m = lo.shape[1]
    for b in range(half):
        a, c = 2 * b, 2 * b + 1
        for j in range(m):
            lo_v, lo_p, hi_v, hi_p = lo[a, j], arg_lo[a, j], hi[a, j], arg_hi[a, j]
            if c < used:
                if lo[c, j] < lo_v:
                    lo_v, lo_p = lo[c, j], arg_lo[c, j]
                if hi[c, j] > hi_v:
                    hi_v, hi_p = hi[c, j], arg_hi[c, j]
            lo[b, j], arg_lo[b, j], hi[b, j], arg_hi[b, j] = lo_v, lo_p, hi_v, hi_p
    for b in range(half, lo.shape[0]):
        for j in range(m):
            lo[b, j], hi[b, j] = np.inf, -np.inf
            arg_lo[b, j], arg_hi[b, j] = -1, -1
    return half


def column_envelope(y: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One signal into at most `columns` equal buckets: (lo, hi, arg_lo, arg_hi) per bucket."""
    env = Envelope(1, max_buckets=2 * columns)
    env.add(np.asarray(y, dtype=float).reshape(-1, 1))
    d = env.finish()
    return d.lo[:, 0], d.hi[:, 0], d.arg_lo[:, 0], d.arg_hi[:, 0]


class EnvelopeData:
    """What an envelope holds at the end: arrays over the used buckets."""

    def __init__(self, width, lo, hi, arg_lo, arg_hi, first_rows, counts, periods):
        self.width, self.periods = width, periods
        self.lo, self.hi, self.arg_lo, self.arg_hi = lo, hi, arg_lo, arg_hi
        self.first_rows, self.counts = first_rows, counts

    def __len__(self) -> int:
        return len(self.lo)

    def first_period(self) -> np.ndarray:
        return np.arange(len(self.lo), dtype=np.int64) * self.width

    def dominant(self) -> np.ndarray:
        """The category with most periods in each bucket."""
        return np.argmax(self.counts, axis=1).astype(np.int8)


class Envelope:
    """Streaming min/max of `signals` per-period signals, plus per-bucket first rows and category counts."""

    def __init__(self, signals: int, *, max_buckets: int = 8192, row_width: int = 0, categories: int = 0):
        if max_buckets < 2 or max_buckets % 2:
            raise ValueError(f"max_buckets must be an even number >= 2 (got {max_buckets})")
        self.cap, self.width, self.periods = max_buckets, 1, 0
        self.lo = np.full((max_buckets, signals), np.inf)
        self.hi = np.full((max_buckets, signals), -np.inf)
        self.arg_lo = np.full((max_buckets, signals), -1, dtype=np.int64)
        self.arg_hi = np.full((max_buckets, signals), -1, dtype=np.int64)
        self.first_rows = np.full((max_buckets, row_width), np.nan)
        self.counts = np.zeros((max_buckets, categories), dtype=np.int64)

    def _used(self) -> int:
        return -(-self.periods // self.width)

    def _make_room(self, last_period: int) -> None:
        while last_period // self.width >= self.cap:
            used = self._used()
            merge_pairs(self.lo, self.hi, self.arg_lo, self.arg_hi, used)
            half = (used + 1) // 2
            self.first_rows[:half] = self.first_rows[0:2 * half:2]
            self.first_rows[half:] = np.nan
            pair = self.counts[0:2 * half:2].copy()
            pair[: used // 2] += self.counts[1:used:2]
            self.counts[:half] = pair
            self.counts[half:] = 0
            self.width *= 2

    def add(self, values: np.ndarray, rows=None, category: np.ndarray | None = None) -> None:
        """The next len(values) periods: values (n, signals); rows(idx) gives the (len(idx), row_width)
        rows of those of the n periods (local indices) that open a bucket; category (n,) ints."""
        n = len(values)
        if n == 0:
            return
        first = self.periods
        self._make_room(first + n - 1)
        fold(np.ascontiguousarray(values, dtype=np.float64), first, self.width, self.lo, self.hi,
             self.arg_lo, self.arg_hi)
        if rows is not None:
            starts = np.arange(-first % self.width, n, self.width)
            if len(starts):
                self.first_rows[(first + starts) // self.width] = rows(starts)
        if category is not None:
            base, cats = first // self.width, self.counts.shape[1]
            bucket = (np.arange(first, first + n) // self.width - base) * cats
            span = (first + n - 1) // self.width - base + 1
            self.counts[base:base + span] += np.bincount(bucket + np.asarray(category, dtype=np.int64),
                                                         minlength=span * cats).reshape(span, cats)
        self.periods += n

    def finish(self) -> EnvelopeData:
        used = self._used()
        return EnvelopeData(self.width, self.lo[:used].copy(), self.hi[:used].copy(), self.arg_lo[:used].copy(),
                            self.arg_hi[:used].copy(), self.first_rows[:used].copy(), self.counts[:used].copy(),
                            self.periods)
