"""lookahead.search_right_from, the period grid's walk along the window's samples and pieces,
is np.searchsorted(side="right") for every query: ascending runs, steps back, repeated values
in the array and among the queries, NaN, and queries beyond both ends."""
from __future__ import annotations

import numpy as np

from ipo.feed.lookahead import search_right_from


def test_walk_equals_searchsorted():
    rng = np.random.default_rng(5)
    for _ in range(200):
        a = np.sort(np.round(rng.uniform(0, 10, rng.integers(1, 60)), 1))  # repeats after rounding
        x = np.cumsum(rng.exponential(0.3, rng.integers(1, 80))) - 1.0  # ascending, from below a[0]
        if rng.random() < 0.5:  # steps back and repeats
            k = rng.integers(len(x), size=3)
            x[k] = x[k[::-1]]
        if rng.random() < 0.2:
            x[rng.integers(len(x))] = np.nan
        j, before = 0, np.nan
        for xi in x:
            j = search_right_from(a, xi, j, before)
            before = xi
            assert j == np.searchsorted(a, xi, side="right"), (a, x, xi)
