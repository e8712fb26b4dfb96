"""S-curve mode's step 6 (ipo.feed.jerk_plan): a staircase of monotone gaps merged into one speed change.

Where the speed changes through a row of anchors close together (the valleys of a polyline's
blends, 0.01-0.6 mm apart on g1_lhchips4, often on the way into a tight corner), steps 1-5 leave
one speed change per gap, each with zero acceleration at both ends: over a gap that lasts tau the
speed then changes by at most J tau^2 / 4, a mean acceleration of J tau / 4 (250 mm/s^2 at
J = 1e5 mm/s^3 and tau = 10 ms) however much the axes allow. Anchors that carried an acceleration
of their own would not help while each gap still passes through zero acceleration between them
(two halves from (v0, a0) to (vp, 0) and back change the speed by the same J tau^2 / 4 at best);
one speed change over the whole row does. So each run of consecutive gaps that only rise (or only
fall, or keep their speed; a peak within _RISE of the higher end counts as none) with the same
straight or curved kind becomes one gap between its first and last anchor, with the same end
speeds, no peak, and the highest limits up to the run's nominal ones that pass every check of step
4 (the lowest that still fit the run's length give the lowest speed everywhere along it, so they
are tried before the bisection); it is kept only where that is quicker, else its halves are tried.
The end anchors keep their speeds and zero acceleration, so no other gap changes. An anchor where
the curvature steps at a piece joint stays (the checks charge a step's jerk at a gap's ends only),
unless the step is rounding (a curvature-continuous joint's, 1e-11 / mm).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.feed.jerk_checks import Segment, check, nominal
from ipo.feed.jerk_profile import phases, transition_distance
from ipo.feed.limits import STEP_JERK_SHARE

_RUN_STEPS = 5  # of the bisection on a merged run's limits
_FIT_STEPS = 30  # of the search for the lowest limits that fit the run's length
_RISE = 0.1  # a peak this much (relative) over the higher end speed is no rise
_GAIN_S = 1e-6  # s; a merge must be quicker than its gaps by this much
_TRY_MIN_S = 2e-5  # s; a run its nominal limits would make quicker by less is not tried
_STEP_NEGLIGIBLE = 1e-6


@njit(cache=True)
def _direction(w, vp, length):
    """+1 for a gap that only rises, -1 only falls, 2 keeps its speed, 0 otherwise."""
    if length < 0.0 or (length == 0.0 and w[0] != w[1]) or vp > max(w[0], w[1]) * (1.0 + _RISE):
        return 0
    if w[1] > w[0]:
        return 1
    if w[1] < w[0]:
        return -1
    return 2


@njit(cache=True)
def _joint_step(s, kv, k, dkv_max):
    """Whether sample k is a piece joint (two samples at one arc length) where the curvature steps
    by more than dkv_max (a curvature-continuous joint steps by rounding, 1e-11 / mm)."""
    for o in (k - 1, k + 1):
        if 0 <= o < s.shape[0] and abs(s[o] - s[k]) <= 1e-9:
            for i in range(3):
                if abs(kv[o, i] - kv[k, i]) > dkv_max:
                    return True
    return False


@njit(cache=True)
def _passes(geo, rate, x, lim, curved, lo, hi, seg):
    worst, over = check(geo, rate, x, lo, hi, seg, lim, curved, True)
    return worst < 0 and over == 0


@njit(cache=True)
def _try_merge(geo, rate, x, lim, curved, idx, w, vp, ag, jg, a, b):
    """One gap over anchors a..b in place of gaps a..b-1: (its acceleration, or 0 if none passes or
    gains, its jerk and peak)."""
    s = geo.s
    lo, hi = idx[a], idx[b]
    length = s[hi] - s[lo]
    va, vb = w[a], w[b]
    top = max(va, vb)
    a_nom, j_nom = nominal(geo.t, lo, hi, lim.a_axis, lim.j_axis)
    old = 0.0
    for g in range(a, b):
        old += phases(w[g], vp[g], w[g + 1], s[idx[g + 1]] - s[idx[g]], ag[g], jg[g])[0][7]
    if phases(va, top, vb, length, a_nom, j_nom)[0][7] >= old - _TRY_MIN_S or \
            transition_distance(va, vb, a_nom, j_nom) > length:
        return 0.0, 0.0
    if _passes(geo, rate, x, lim, curved, lo, hi, Segment(va, top, vb, a_nom, j_nom)):
        return a_nom, j_nom
    fits, short = 1.0, 0.0  # the lowest share of the nominal limits whose speed change fits the run
    for _ in range(_FIT_STEPS):
        mid = 0.5 * (fits + short)
        if transition_distance(va, vb, mid * a_nom, mid * j_nom) <= length:
            fits = mid
        else:
            short = mid
    if not _passes(geo, rate, x, lim, curved, lo, hi, Segment(va, top, vb, fits * a_nom, fits * j_nom)):
        return 0.0, 0.0
    ok, bad = fits, 1.0
    for _ in range(_RUN_STEPS):
        mid = 0.5 * (ok + bad)
        if _passes(geo, rate, x, lim, curved, lo, hi, Segment(va, top, vb, mid * a_nom, mid * j_nom)):
            ok = mid
        else:
            bad = mid
    if phases(va, top, vb, length, ok * a_nom, ok * j_nom)[0][7] >= old - _GAIN_S:
        return 0.0, 0.0
    return ok * a_nom, ok * j_nom


@njit(cache=True)
def merge_runs(geo, rate, x, lim, curved, idx, w, vp, ag, jg):
    """Step 6 over a converged plan (anchors idx with speeds w, per gap vp, ag, jg; rate and the
    checks as in step 4): the plan with its monotone runs merged where that is quicker."""
    s, kv = geo.s, geo.kv
    m = idx.shape[0]
    # a step whose jerk STEP_JERK_SHARE v^2 |dkv| / T stays below _STEP_NEGLIGIBLE of the smallest
    # axis jerk at the window's highest speed is rounding, not a step
    dkv_max = _STEP_NEGLIGIBLE * lim.j_axis.min() * lim.period_s / (STEP_JERK_SHARE * max(x.max(), 1e-300))
    keep = np.ones(m, np.bool_)
    vp, ag, jg = vp.copy(), ag.copy(), jg.copy()
    stack = np.empty((max(m, 1), 2), np.int64)
    g = 0
    while g < m - 1:
        d = _direction(w[g:g + 2], vp[g], s[idx[g + 1]] - s[idx[g]])
        e = g + 1
        while d != 0 and e < m - 1 and curved[idx[e]] == curved[idx[g]] and \
                not _joint_step(s, kv, idx[e], dkv_max):
            de = _direction(w[e:e + 2], vp[e], s[idx[e + 1]] - s[idx[e]])
            if de == 0 or (de != 2 and d != 2 and de != d):
                break
            if d == 2:
                d = de
            e += 1
        top = 0
        if e - g >= 2:
            stack[0, 0], stack[0, 1] = g, e
            top = 1
        while top > 0:
            top -= 1
            a, b = stack[top, 0], stack[top, 1]
            if b - a < 2:
                continue
            acc, jerk = _try_merge(geo, rate, x, lim, curved[idx[a]], idx, w, vp, ag, jg, a, b)
            if acc > 0.0:
                keep[a + 1:b] = False
                ag[a], jg[a], vp[a] = acc, jerk, max(w[a], w[b])
            elif b - a >= 3:
                c = (a + b) // 2
                stack[top, 0], stack[top, 1] = c, b
                stack[top + 1, 0], stack[top + 1, 1] = a, c
                top += 2
        g = e
    gaps = keep[:m - 1].copy()
    return idx[keep], w[keep], vp[gaps], ag[gaps], jg[gaps]
