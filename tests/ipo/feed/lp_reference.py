"""max_start, the definition ipo.feed.interval_lp.max_start_from is checked against to the bit:
the largest x_k (<= a_top) with some x_k+1 in [0, b_top] meeting every row of a look-ahead
interval's programme, by enumerating the vertices of every pair of rows (interval_lp's own
steps, without the hint and the certificate that make max_start_from fast).
"""
from __future__ import annotations

import numpy as np

from ipo.feed import interval_lp as lp


def max_start(rows, m, a_top, b_top):
    """Largest x_k (<= a_top) with some x_k+1 in [0, b_top] meeting every row: a 2-variable
    linear programme, solved at the vertices of its polygon. -1 if none is feasible."""
    r = np.empty((m + 4, 3))
    n = lp._unit_rows(rows, m, a_top, b_top, r)
    pair = np.zeros(2, np.int64)
    return min(lp._best_vertex(r, n, 1e-9 * max(1.0, b_top), -1.0, pair), a_top)
