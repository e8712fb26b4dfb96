"""The look-ahead's per-interval programme: the hinted solver returns the enumeration's value
to the bit (max_start, tests/ipo/feed/lp_reference.py, is checked against a grid search in test_accel_margin.py).

Intervals are drawn to be hard for the shortcut: tangents that differ by 1e-12..1e-2 (rows
nearly parallel), axes at rest, straight stretches (duplicate rows), sample spacings down
to 1e-6 mm, caps that bind and stops (b_top = 0), with random and stale hints.
"""
from __future__ import annotations

import numpy as np
import pytest

from ipo.feed import interval_lp as lp
from tests.ipo.feed.lp_reference import max_start

A_MAX = np.array([1000.0, 800.0, 1200.0]) * 0.985


def _interval(rng):
    t = rng.normal(size=(2, 3))
    if rng.random() < 0.3:
        t[1] = t[0] + rng.normal(size=3) * 10 ** rng.uniform(-12, -2)
    if rng.random() < 0.2:
        t[:, rng.integers(3)] = 0.0
    t /= np.linalg.norm(t, axis=1)[:, None]
    kv = rng.normal(size=(2, 3)) * 10 ** rng.uniform(-3, 2)
    if rng.random() < 0.3:
        kv[:] = 0.0
    kv -= np.einsum("ij,ij->i", kv, t)[:, None] * t
    return t, kv, 10 ** rng.uniform(-6, 0.5)


@pytest.mark.parametrize("seed", range(4))
def test_hinted_programme_is_the_enumeration_to_the_bit(seed):
    rng = np.random.default_rng(seed)
    rows, unit, near = np.empty((12, 3)), np.empty((16, 3)), np.empty(16, np.bool_)
    pairs = np.full(4, -1, np.int64)
    hinted = 0
    for _ in range(5000):
        t, kv, ds = _interval(rng)
        m = lp.interval_rows(t, kv, 0, 2 * ds, A_MAX, rng.choice([1.0, 0.5]), rows)
        cap = 10 ** rng.uniform(-2, 5) if rng.random() < 0.9 else 1e300
        b_top = 10 ** rng.uniform(-3, 5) if rng.random() < 0.9 else 0.0
        if rng.random() < 0.5:  # a random hint; else the last interval's optimum, as in the backward pass
            pairs[:2] = np.sort(rng.integers(0, m + 4, 2))
            pairs[2:] = np.sort(rng.integers(0, m + 4, 2))
        before = pairs.copy()
        got = lp.max_start_from(rows, m, cap, b_top, unit, pairs, near)
        assert got == max_start(rows, m, cap, b_top), (seed, t, kv, ds, cap, b_top, before)
        hinted += bool(np.array_equal(before[:2], pairs[:2]))
    assert hinted > 0  # the shortcut itself was taken


def test_vertex_guess_is_the_optimum_of_most_unhinted_intervals():
    """With no hint at all, the guess (_vertex_guess) is the optimal pair that the certificate
    accepts in most intervals, and the result is still the enumeration's to the bit."""
    rng = np.random.default_rng(7)
    rows, unit, near = np.empty((12, 3)), np.empty((16, 3)), np.empty(16, np.bool_)
    accepted = tried = 0
    for _ in range(3000):
        t, kv, ds = _interval(rng)
        m = lp.interval_rows(t, kv, 0, 2 * ds, A_MAX, 1.0, rows)
        cap, b_top = 10 ** rng.uniform(-2, 5), 10 ** rng.uniform(-3, 5)
        n = lp._unit_rows(rows, m, cap, b_top, unit)
        i, j = lp._vertex_guess(unit, n, m)
        tried += 1
        pair = np.zeros(2, np.int64)
        accepted += 0 <= i < j < n and lp._certified(unit, n, 1e-9 * max(1.0, b_top), cap, b_top, i, j, near,
                                                     pair) > -2.0
        got = lp.max_start_from(rows, m, cap, b_top, unit, np.full(4, -1, np.int64), near)
        assert got == max_start(rows, m, cap, b_top)
    assert accepted > 0.9 * tried, (accepted, tried)
