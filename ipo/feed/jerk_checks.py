"""S-curve mode's checks of one gap's segment (step 4 of ipo.feed.jerk_plan, and what steps 5 and 6
test their changes with): its speed against x_acc at every sample, and every axis's acceleration
and jerk with the curvature's terms, the curvature rate's and, at a piece joint, the step's.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.feed.jerk_profile import cruise_span, phases, state, time_at
from ipo.feed.limits import STEP_JERK_SHARE

# what a check finds over in a gap; each lowers its own scale (a straight gap that ends next to
# a curvature step keeps half the jerk there, but not half the acceleration)
ACC_OVER = 1
JERK_OVER = 2
_SLACK = 1e-9
_JOINT_MM = 1e-9  # samples closer than this are the two sides of one piece joint


class Segment(NamedTuple):
    """One gap's jerk-limited segment, as jerk_profile.phases takes it."""

    va: float  # start speed, mm/s
    vp: float  # peak speed
    vb: float  # end speed
    a: float  # path acceleration limit, mm/s^2
    j: float  # path jerk limit, mm/s^3


@njit(cache=True)
def nominal(t, lo, hi, a_axis, j_axis):
    """Step 2 of ipo.feed.jerk_plan: a gap's path acceleration and jerk limits before scaling."""
    a = 1e300
    j = 1e300
    for k in range(lo, hi + 1):
        for i in range(3):
            ti = abs(t[k, i])
            if ti > 1e-12:
                a = min(a, a_axis[i] / ti)
                j = min(j, j_axis[i] / ti)
    return a, j



@njit(cache=True, inline="always")
def _step(kv, k, other, i):
    """|kv_i| step where sample k meets the sample `other` at the same arc length (a piece
    joint), 0 where there is none."""
    if other < 0 or other >= kv.shape[0]:
        return 0.0
    return abs(kv[other, i] - kv[k, i])


@njit(cache=True)
def rates(s, kv):
    """|dkv_i/ds| at each sample from the neighbouring samples along the path (the larger side;
    a piece joint, two samples at one arc length, is a step, not a rate): once per plan, the
    checks read it at every sample of every round."""
    n = s.shape[0]
    rate = np.zeros((n, 3))
    for k in range(n - 1):
        ds = s[k + 1] - s[k]
        if ds > _JOINT_MM:
            for i in range(3):
                r = abs(kv[k + 1, i] - kv[k, i]) / ds
                rate[k, i] = max(rate[k, i], r)
                rate[k + 1, i] = r
    return rate


@njit(cache=True, inline="always")
def _axes_over(geo, rate, k, motion, lim, curved, step):
    """Which limits some axis is over with the geometry of sample k (rate: _rates) and the
    state motion = (v, acc, jk) (speed, path acceleration and jerk): ACC_OVER | JERK_OVER, 0
    if none; step: per axis, STEP_JERK_SHARE |dkv_i| / T where sample k is a piece joint at
    which the curvature steps by dkv (0 elsewhere). A jerk over its limit mostly through the coupling 3 kv_i v a is the
    acceleration's to lower too."""
    t, kv = geo.t, geo.kv
    v, acc, jk = motion
    over = 0
    for i in range(3):
        if abs(t[k, i] * acc + kv[k, i] * v * v) > lim.a_axis[i] * (1.0 + _SLACK):
            over |= ACC_OVER
        # axis jerk t_i j + 3 kv_i v a + kv_i' v^3, and where pieces meet the step's
        # STEP_JERK_SHARE v^2 |dkv_i| / T, which the periods around the joint see together
        # with the path's jerk on both sides (the caps hold it within half of J_i; at the
        # speed the segment has there it is often far less)
        budget = lim.j_axis[i] - step[i] * v * v - (rate[k, i] * v**3 if curved else 0.0)
        extra = 3.0 * abs(kv[k, i]) * v * abs(acc) if curved else 0.0
        if abs(t[k, i]) * abs(jk) + extra > budget * (1.0 + _SLACK):
            over |= JERK_OVER | (ACC_OVER if extra > 0.5 * budget else 0)
    return over


@njit(cache=True)
def _phases(seg, length):
    """jerk_profile.phases of the segment as tuples: passed by value, where the five arrays cost
    a reference count each per call of state and time_at, more than their arithmetic at a sample."""
    tt, ss, vv, aa, jj = phases(seg.va, seg.vp, seg.vb, length, seg.a, seg.j)
    return ((tt[0], tt[1], tt[2], tt[3], tt[4], tt[5], tt[6], tt[7]),
            (ss[0], ss[1], ss[2], ss[3], ss[4], ss[5], ss[6], ss[7]),
            (vv[0], vv[1], vv[2], vv[3], vv[4], vv[5], vv[6], vv[7]),
            (aa[0], aa[1], aa[2], aa[3], aa[4], aa[5], aa[6], aa[7]),
            (jj[0], jj[1], jj[2], jj[3], jj[4], jj[5], jj[6]))


@njit(cache=True)
def _x_ratio(v, xk):
    """v^2 / x_acc where the speed passes above x_acc at a sample (beyond rounding), else 1."""
    if v * v > xk * (1.0 + 1e-6) + 1e-9:
        return v * v / max(xk, 1e-300)
    return 1.0


@njit(cache=True)
def above_x(s, x, lo, hi, seg):
    """Whether the segment (Segment) passes above x_acc at some sample of its gap: the speeds
    alone, for the peak's bisection in step 4 (the axes are checked once, at the peak it
    settles on)."""
    length = s[hi] - s[lo]
    tt, ss, vv, aa, jj = _phases(seg, length)
    c0, c1 = cruise_span(tt, ss, vv, aa, jj)
    for k in range(lo, hi + 1):
        d = min(max(s[k] - s[lo], 0.0), length)
        v = vv[3] + 0.0 if c0 <= d < c1 else state(tt, ss, vv, aa, jj, time_at(tt, ss, vv, aa, jj, d))[1]
        if _x_ratio(v, x[k]) > 1.0:
            return True
    return False


@njit(cache=True)
def check(geo, rate, x, lo, hi, seg, lim, curved, first):
    """Step 4 for one gap: (worst sample over x_acc or -1, and which limits an axis is over). The
    axes are checked at every sample and, with the geometry of the samples either side, where
    each phase starts (the acceleration peaks between samples). With `first`, it returns at the first
    sample found over, for a caller that only asks whether the segment passes."""
    s, kv = geo.s, geo.kv
    length = s[hi] - s[lo]
    tt, ss, vv, aa, jj = _phases(seg, length)
    c0, c1 = cruise_span(tt, ss, vv, aa, jj)
    worst, worst_ratio = -1, 1.0
    axis_over = 0
    no_step = np.zeros(3)
    step = np.zeros(3)
    for k in range(lo, hi + 1):
        d = min(max(s[k] - s[lo], 0.0), length)
        if c0 <= d < c1:
            v, acc, jk = vv[3] + 0.0, 0.0, 0.0
        else:
            _, v, acc, jk = state(tt, ss, vv, aa, jj, time_at(tt, ss, vv, aa, jj, d))
        if k == hi:
            jk = jj[6]  # the end of the last ramp
        r = _x_ratio(v, x[k])
        if r > worst_ratio:
            worst, worst_ratio = k, r
        other = -1  # the sample across a piece joint at a gap's end
        if k == lo and k > 0 and s[k] - s[k - 1] <= _JOINT_MM:
            other = k - 1
        elif k == hi and k + 1 < s.shape[0] and s[k + 1] - s[k] <= _JOINT_MM:
            other = k + 1
        for i in range(3):
            step[i] = STEP_JERK_SHARE * _step(kv, k, other, i) / lim.period_s
        axis_over |= _axes_over(geo, rate, k, (v, acc, jk), lim, curved, step)
        if first and (worst >= 0 or axis_over != 0):
            return worst, axis_over
    k = lo
    for q in range(1, 7):
        d = ss[q]
        if not 0.0 < d < length:
            continue
        while k + 1 < hi and s[k + 1] - s[lo] < d:
            k += 1
        jq = max(abs(jj[q - 1]), abs(jj[q]))  # the axes see |jerk|: the larger one either side covers both
        axis_over |= _axes_over(geo, rate, k, (vv[q], aa[q], jq), lim, curved, no_step)
        axis_over |= _axes_over(geo, rate, k + 1, (vv[q], aa[q], jq), lim, curved, no_step)
    return worst, axis_over


@njit(cache=True)
def anchor_peaks(s, x, lo, hi, seg, anchor):
    """Make the worst sample of every run of samples where the segment (Segment) passes above
    x_acc an anchor; whether any was new."""
    length = s[hi] - s[lo]
    tt, ss, vv, aa, jj = _phases(seg, length)
    c0, c1 = cruise_span(tt, ss, vv, aa, jj)
    new = False
    best, best_r = -1, 1.0
    for k in range(lo, hi + 2):
        r = 1.0
        if k <= hi:
            d = min(max(s[k] - s[lo], 0.0), length)
            v = vv[3] + 0.0 if c0 <= d < c1 else state(tt, ss, vv, aa, jj, time_at(tt, ss, vv, aa, jj, d))[1]
            r = _x_ratio(v, x[k])
        if r > best_r:
            best, best_r = k, r
        elif r <= 1.0 and best >= 0:
            new |= not anchor[best]
            anchor[best] = True
            best, best_r = -1, 1.0
    return new
