"""Compiled or vectorised forms of the feed stage's per-chunk and per-round numpy steps, bit for bit
against numpy's own: the NURBS driver's chunk of steps (ipo.feed.nurbs_driver._chunk_steps) against
the same formulas in numpy (np.interp, np.maximum), and nurbs_table's refinement points
(ipo.feed.sampling._inner_points) against np.linspace. Bit for bit, because the per-period output
must not change with them."""
from __future__ import annotations

import numpy as np

from ipo.feed.nurbs_driver import _chunk_shape, _chunk_steps
from ipo.feed.sampling import _inner_points


def numpy_steps(target, s_planned, tab_s, tab_kappa, gain_used, gain, lag, lead, snap_from, snap_step):
    """The chunk's steps in numpy: the chord of an arc of length d at the table's curvature halfway
    along it, d (1 - (kappa d)^2 / 24), times the gain moving linearly to its new value over the
    chunk, plus the lag spread as a sin^2 bump; the lead on the first step; where the chunk reaches
    the curve's end, each period there at least snap_step."""
    d = np.maximum(target - np.concatenate(([s_planned], target[:-1])), 0.0)
    kappa = np.interp(target - 0.5 * d, tab_s, tab_kappa)
    chord = d * (1.0 - (kappa * d) ** 2 / 24.0)
    n = len(target)
    ramp, bump = np.arange(1, n + 1), np.sin(np.pi * (np.arange(n) + 0.5) / n) ** 2
    steps = np.maximum(chord * (gain_used + (gain - gain_used) * ramp / n) + lag * bump / bump.sum(), 0.0)
    steps[0] += lead
    if target[-1] >= snap_from:
        end = target >= snap_from
        steps[end] = np.maximum(steps[end], snap_step)
    return steps, chord


def test_the_drivers_chunk_of_steps_is_numpys_to_the_bit():
    rng = np.random.default_rng(19)
    for trial in range(2000):
        tab_s = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-4, 0.5, rng.integers(2, 200)))])
        tab_kappa = rng.uniform(0, 10, len(tab_s)) ** rng.uniform(1, 4)
        n = int(rng.integers(1, 33))
        s_planned = rng.uniform(0, tab_s[-1])
        # steps of 0-0.2 mm, some backwards (clipped to 0), running past the table's end
        target = s_planned + np.cumsum(rng.uniform(-0.01, 0.2, n))
        snap_from = tab_s[-1] - 1e-9 if trial % 3 else target[-1] - rng.uniform(0, 0.3)
        args = (target, s_planned, tab_s, tab_kappa, rng.uniform(0.99, 1.01), rng.uniform(0.99, 1.01),
                rng.uniform(-1e-3, 1e-3), float(rng.uniform(0, 0.05) if trial % 2 else 0.0), snap_from,
                2.0 * tab_s[-1] + 1.0)
        want = numpy_steps(*args)
        ramp, bump, bump_sum = _chunk_shape(n)
        got = _chunk_steps(*args[:7], ramp, bump, bump_sum, *args[7:])
        for w, g in zip(want, got):
            assert np.array_equal(w.view(np.int64), g.view(np.int64)), trial


def test_the_tables_refinement_points_are_linspaces_to_the_bit():
    rng = np.random.default_rng(7)
    total = 0
    for trial in range(2000):
        scale = 10.0 ** rng.uniform(-8, 3)
        u = np.unique(np.cumsum(rng.uniform(0, 1, rng.integers(2, 60)) ** rng.uniform(1, 8)) * scale
                      + rng.uniform(-5, 5))
        split = rng.integers(0, 65, len(u) - 1)
        want = np.concatenate([np.zeros(0)] + [np.linspace(u[i], u[i + 1], split[i] + 1)[1:-1]
                                               for i in np.flatnonzero(split > 1)])
        got = _inner_points(u, split)
        assert np.array_equal(want.view(np.int64), got.view(np.int64)), trial
        total += len(got)
    assert total > 500_000
