"""S-curve mode's plan of one window (ipo.feed.jerk_plan) on an exact circular arc: the limits
that step 5 raises and the staircases that step 6 (ipo.feed.jerk_runs) merges, checked by finite
differences of positions on the arc itself and against ruckig."""
from __future__ import annotations

import numpy as np
import pytest

from ipo.feed import jerk_checks, jerk_plan, jerk_runs
from ipo.feed.jerk_profile import arc_lengths_at, durations, peak_speed, reach, transition_distance
from tests.ipo.feed.test_jerk_profile import ruckig_1d

R = 5.0  # mm, arc radius
DS = 0.05  # mm between samples
A = np.array([1000.0, 1000.0, 1000.0])
J = np.array([100000.0, 100000.0, 100000.0])
T = 1e-3
F = 100.0  # mm/s, programmed feed


def arc_window(feed=F):
    """Samples of a three-quarter circle in XY (s, t, kv exact) and an acceleration-limited x_acc
    from rest to rest: the curvature cap A / kappa and the feed, with tangential acceleration
    A / 2 (what jerk_plan is given; it need not be the look-ahead's own)."""
    s = np.linspace(0.0, 1.5 * np.pi * R, int(1.5 * np.pi * R / DS) + 1)
    phi = s / R
    t = np.c_[-np.sin(phi), np.cos(phi), np.zeros_like(phi)]
    kv = np.c_[-np.cos(phi), -np.sin(phi), np.zeros_like(phi)] / R
    cap = np.full(s.shape, min(feed * feed, A[0] * R))
    cap[0] = cap[-1] = 0.0
    x = cap.copy()
    for k in range(1, len(s)):
        x[k] = min(x[k], x[k - 1] + A[0] * (s[k] - s[k - 1]))
    for k in range(len(s) - 2, -1, -1):
        x[k] = min(x[k], x[k + 1] + A[0] * (s[k + 1] - s[k]))
    return jerk_plan.Geometry(s, t, kv), x


def positions(geo, idx, w, vp, ag, jg):
    """The plan's motion on the exact arc, one position per period."""
    t_start = np.r_[0.0, np.cumsum(durations(geo.s, idx, w, vp, ag, jg))]
    times = np.arange(0.0, t_start[-1], T)
    phi = arc_lengths_at(times, geo.s, idx, w, vp, ag, jg, t_start)[0] / R
    return np.c_[R * np.cos(phi), R * np.sin(phi)]


def test_raised_limits_keep_every_axis_within_its_limits_and_save_time():
    """Step 5 on the plan with every gap's limits taken down by 0.7 where its segment still fits
    (at a peak no higher): it raises each of them (never above the nominal A_i / |t_i|,
    J_i / |t_i|), no gap gets slower, and the motion on the exact arc, with the plan's own limits
    and with the raised ones, stays within each axis's acceleration and jerk. Central
    differences one period apart average the acceleration and jerk over their stencils, so they
    cannot exceed the largest value of the exact motion: the slack is what the checks miss
    between samples, the arc's turn over half a sample spacing, 1 - cos(DS / 2R) ~ 1.3e-5,
    and float rounding."""
    geo, x = arc_window()
    lim = jerk_plan.AxisLimits(A, J, T)
    idx, w, vp, ag, jg, ok = jerk_plan.plan(geo, x, lim, 0.0, 0.0, 0.5)
    assert ok
    # every gap whose segment still fits its length with 0.7 of its limits (at a peak no higher)
    lowered_a, lowered_j, lowered_vp = ag.copy(), jg.copy(), vp.copy()
    for g, (lo, hi) in enumerate(zip(idx[:-1], idx[1:])):
        length, a, j = geo.s[hi] - geo.s[lo], 0.7 * ag[g], 0.7 * jg[g]
        p = peak_speed(w[g], w[g + 1], length, vp[g], a, j)
        if transition_distance(w[g], p, a, j) + transition_distance(p, w[g + 1], a, j) <= length:
            lowered_a[g], lowered_j[g], lowered_vp[g] = a, j, p
    lowered = lowered_a < ag
    assert lowered.sum() >= 2
    ag2, jg2, vp2 = lowered_a.copy(), lowered_j.copy(), lowered_vp.copy()
    curved = np.ones(len(geo.s) - 1, np.bool_)
    jerk_plan._raise_limits(geo, jerk_checks.rates(geo.s, geo.kv), x, lim, curved, idx, w, vp2, ag2, jg2)
    nominal_a = np.array([jerk_checks.nominal(geo.t, lo, hi, A, J)[0] for lo, hi in zip(idx[:-1], idx[1:])])
    nominal_j = np.array([jerk_checks.nominal(geo.t, lo, hi, A, J)[1] for lo, hi in zip(idx[:-1], idx[1:])])
    assert np.all(ag2 >= lowered_a) and np.all(jg2 >= lowered_j)
    assert np.all(ag2 <= nominal_a) and np.all(jg2 <= nominal_j)
    assert np.all((ag2 > lowered_a) | (jg2 > lowered_j) | ~lowered)
    before = durations(geo.s, idx, w, lowered_vp, lowered_a, lowered_j)
    after = durations(geo.s, idx, w, vp2, ag2, jg2)
    assert np.all(after <= before * (1 + 1e-12))
    assert after.sum() < before.sum()
    slack = 1.0 + 1.3e-5 + 1e-9
    for plan in ((ag, jg, vp), (ag2, jg2, vp2)):
        pos = positions(geo, idx, w, plan[2], plan[0], plan[1])
        acc = (pos[2:] - 2 * pos[1:-1] + pos[:-2]) / T**2
        jerk = (pos[3:] - 3 * pos[2:-1] + 3 * pos[1:-2] - pos[:-3]) / T**3
        assert np.abs(acc).max() <= A[0] * slack, np.abs(acc).max()
        assert np.abs(jerk).max() <= J[0] * slack + 1e-6, np.abs(jerk).max()


def assert_within_axis_limits(geo, idx, w, vp, ag, jg):
    """The motion on the exact arc within each axis's acceleration and jerk (central differences
    one period apart, slack as derived in the test of step 5)."""
    pos = positions(geo, idx, w, vp, ag, jg)
    acc = (pos[2:] - 2 * pos[1:-1] + pos[:-2]) / T**2
    jerk = (pos[3:] - 3 * pos[2:-1] + 3 * pos[1:-2] - pos[:-3]) / T**3
    slack = 1.0 + 1.3e-5 + 1e-9
    assert np.abs(acc).max() <= A[0] * slack, np.abs(acc).max()
    assert np.abs(jerk).max() <= J[0] * slack + 1e-6, np.abs(jerk).max()


def test_a_staircase_of_rising_gaps_becomes_one_speed_change_within_the_limits():
    """Step 6 on a staircase: on the arc window at 40 mm/s (the centripetal acceleration 320 mm/s^2),
    anchors every 0.1 mm of the rise from rest, each gap the fastest change with zero acceleration
    at both ends (then a cruise), with 0.7 of the nominal limits (within every axis's: sqrt(700^2 + 320^2) mm/s^2,
    and 7e4 + 3 v a / R mm/s^3), to a speed under x_acc all along the gap. It merges gaps into
    fewer, quicker ones between anchors of the staircase, with their speeds; each merged gap is
    ruckig's time-optimal motion over its length between those speeds (its own limits, no speed
    above the higher end), and the whole motion keeps every axis within its limits and the speed
    under x_acc at every sample."""
    geo, x = arc_window(40.0)
    rise = int(np.argmax(x >= x.max()))  # where x_acc reaches the cruise; the window ends 1 mm on
    geo, x = jerk_plan.Geometry(*(v[:rise + 21] for v in geo)), x[:rise + 21]
    lim = jerk_plan.AxisLimits(A, J, T)
    s = geo.s
    a_nom, j_nom = jerk_checks.nominal(geo.t, 0, len(s) - 1, A, J)
    a, j = 0.7 * a_nom, 0.7 * j_nom
    idx = np.r_[np.arange(0, rise, 2), len(s) - 1]  # the last gap cruises at the speed reached
    w = np.zeros(len(idx))
    for g in range(len(idx) - 2):
        w[g + 1] = min(np.sqrt(x[idx[g]]), reach(w[g], s[idx[g + 1]] - s[idx[g]], a, j))
    w[-1] = w[-2]
    vp = np.maximum(w[:-1], w[1:])
    ag, jg = np.full(len(idx) - 1, a), np.full(len(idx) - 1, j)
    assert_within_axis_limits(geo, idx, w, vp, ag, jg)
    curved = np.ones(len(s) - 1, np.bool_)
    rate = jerk_checks.rates(s, geo.kv)
    idx2, w2, vp2, ag2, jg2 = jerk_runs.merge_runs(geo, rate, x, lim, curved, idx, w, vp, ag, jg)
    assert len(idx2) <= len(idx) // 2 and set(idx2) <= set(idx)
    assert np.array_equal(w2, w[np.isin(idx, idx2)])
    assert durations(s, idx2, w2, vp2, ag2, jg2).sum() < durations(s, idx, w, vp, ag, jg).sum()
    merged = np.diff(np.searchsorted(idx, idx2)) > 1
    for g in np.nonzero(merged)[0]:
        length = s[idx2[g + 1]] - s[idx2[g]]
        traj = ruckig_1d(length, w2[g], w2[g + 1], max(w2[g], w2[g + 1]), ag2[g], jg2[g])
        assert durations(s, idx2[g:g + 2], w2[g:g + 2], vp2[g:g + 1], ag2[g:g + 1], jg2[g:g + 1])[0] == \
            pytest.approx(traj.duration, rel=1e-9)
        assert ag2[g] <= a_nom and jg2[g] <= j_nom
    assert_within_axis_limits(geo, idx2, w2, vp2, ag2, jg2)
    t_start = np.r_[0.0, np.cumsum(durations(s, idx2, w2, vp2, ag2, jg2))]
    times = np.arange(0.0, t_start[-1], 1e-4)
    sv = arc_lengths_at(times, s, idx2, w2, vp2, ag2, jg2, t_start)[0]
    speed = np.diff(sv) / 1e-4  # the mean over 0.1 ms, under the largest x_acc at its samples
    k = np.searchsorted(s, sv[1:], side="right") - 1
    assert np.all(speed**2 <= np.maximum(x[k], x[np.minimum(k + 1, len(s) - 1)]) * (1 + 1e-9))
