"""S-curve mode over a look-ahead window: anchors, their speeds, and the segments between them.

Input: the window's samples (arc length s, unit tangent t, curvature vector kv), the
acceleration-limited profile x_acc = v^2 the look-ahead planned under every cap, the axis
limits, the speed the machine has at the first sample (with zero acceleration: the window
always starts at an anchor) and the v^2 it must end with.

1. Anchors (ipo.feed.jerk_anchors): the first and last sample, every stop, the ends of x_acc's
   valleys and of its plateaus that are not peaks, and where the path changes between straight
   and curved. Speeds at anchors: at most sqrt(x_acc), acceleration zero. x_acc is first held
   to what the curvature allows with no path acceleration, |kv_i| v^2 <= (1 - _CURVE_ROOM) A_i
   (the look-ahead may ride the curvature cap with some).
2. Path limits of each gap between anchors: A_i / |t_i| and J_i / |t_i|, straight or curved,
   each times its own scale that starts at 1 (step 4 lowers them: where the curvature's terms
   leave a curve less, the checks find it with the terms as they are).
3. Anchor speeds by a backward and a forward pass (jerk_profile.reach), then each gap's peak
   speed (jerk_profile.peak_speed, at most the highest sqrt(x_acc) inside it).
4. Checks (ipo.feed.jerk_checks) at every sample of every gap, with the segment's own speed,
   acceleration and jerk there: v^2 <= x_acc; |t_i a + kv_i v^2| <= A_i; |t_i j| + 3 |kv_i| v |a| + |kv_i'| v^3 <= J_i
   (kv' from the neighbouring samples; at a piece joint where the curvature steps by dkv_i,
   plus the step's STEP_JERK_SHARE v^2 |dkv_i| / T, which ipo.feed.limits' caps hold within
   J_i / 2).
   A speed over x_acc lowers the peak where a little (_PEAK_GIVE) is enough, else makes the
   worst sample an anchor; an axis over its acceleration lowers the gap's acceleration scale,
   over its jerk its jerk scale (and the acceleration's too where the coupling 3 kv_i v a is
   most of it): a straight next to a curvature step keeps its whole acceleration. Then back to 3,
   until every gap passes.
5. Scales fall by a whole _SCALE_STEP where less would do: each gap whose limits fell takes, by
   bisection, the highest ones up to its nominal that pass every check of step 4 with its anchor
   speeds as they are (higher limits still reach them, so no other gap changes); a gap its
   nominal limits would make quicker by at most _RAISE_MIN_S is left as it is (the limits are
   tried at the peak they allow, else at the gap's own). On g1_lhchips4 this took 251.4 s to
   247.6 s.
6. Runs of gaps that only rise or only fall, a staircase of speed changes each with zero
   acceleration at its ends, become one speed change where that passes every check and is
   quicker (ipo.feed.jerk_runs): on g1_lhchips4, 247.6 s to 246.8 s.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.feed.jerk_anchors import anchors, curved_intervals
from ipo.feed.jerk_checks import ACC_OVER, JERK_OVER, Segment, above_x, anchor_peaks, check, nominal, rates
from ipo.feed.jerk_runs import merge_runs
from ipo.feed.jerk_profile import peak_speed, phases, reach, reach_down, transition_distance

_ROUNDS = 40  # of steps 3 and 4; each round fixes something, and scales only fall; after half
# of them a gap that still fails has every sample as an anchor
_SCALE_STEP = 0.7
_PEAK_GIVE = 0.02
_PEAK_STEPS = 14  # of that bisection: the peak within (p - base) / 16384 below the highest that clears it
_RAISE_STEPS = 5  # of step 5's bisection
_RAISE_MIN_S = 2e-5  # s; most of lhchips4's gaps gain less, and their checks were a third of the plan
# share of an axis's acceleration x_acc leaves free where it rides that axis's curvature cap:
# with none, a segment through such a sample may have no path acceleration there at all, and
# its gap's scale fell by _SCALE_STEP for many rounds (down to the staircase) before it passed
_CURVE_ROOM = 1e-3


class Geometry(NamedTuple):
    """The window's samples as the kernels read them."""

    s: np.ndarray  # arc length, mm
    t: np.ndarray  # unit tangent, (n, 3)
    kv: np.ndarray  # curvature vector, (n, 3), 1/mm


class AxisLimits(NamedTuple):
    """Per axis acceleration and jerk limits, and the period (a curvature step's jerk)."""

    a_axis: np.ndarray  # mm/s^2
    j_axis: np.ndarray  # mm/s^3
    period_s: float


@njit(cache=True)
def plan(geo, x, lim, v0, x_end, straight_min_mm):
    """Anchors (sample indices), their speeds, and per gap the peak speed and the path
    acceleration and jerk limits, over the samples geo (Geometry) under lim (AxisLimits);
    converged is False if the rounds ran out."""
    s, t, kv = geo
    a_axis, j_axis = lim.a_axis, lim.j_axis
    n = s.shape[0]
    x = x.copy()
    for k in range(n):  # the look-ahead may ride a curvature cap with the help of s'' != 0
        for i in range(3):
            if kv[k, i] != 0.0:
                x[k] = min(x[k], (1.0 - _CURVE_ROOM) * a_axis[i] / abs(kv[k, i]))
    curved = curved_intervals(s, t, kv, straight_min_mm)
    rate = rates(s, kv)
    anchor = anchors(s, x, curved)
    scale_a = np.ones(max(n - 1, 1))
    scale_j = np.ones(max(n - 1, 1))
    # the last gap checked clean from each sample: (end, start and end speed, limits) -> its peak
    ok_hi = np.full(n, -1, np.int64)
    ok_key = np.zeros((n, 4))
    ok_vp = np.zeros(n)
    converged = False
    idx = np.nonzero(anchor)[0]
    m = idx.shape[0]
    w = np.zeros(m)
    vp = np.zeros(max(m - 1, 0))
    ag = np.zeros(max(m - 1, 0))
    jg = np.zeros(max(m - 1, 0))
    for rnd in range(_ROUNDS):
        idx = np.nonzero(anchor)[0]
        m = idx.shape[0]
        ag = np.zeros(m - 1)
        jg = np.zeros(m - 1)
        cv = np.zeros(m - 1, np.bool_)
        for g in range(m - 1):
            lo, hi = idx[g], idx[g + 1]
            cv[g] = curved[lo] if hi > lo else False
            a, j = nominal(t, lo, hi, a_axis, j_axis)
            if hi > lo:
                a *= scale_a[lo:hi].min()
                j *= scale_j[lo:hi].min()
            ag[g], jg[g] = a, j
        # 3. anchor speeds, backward then forward
        u = np.sqrt(np.maximum(x[idx], 0.0))
        u[m - 1] = min(u[m - 1], np.sqrt(max(x_end, 0.0)))
        vb = np.empty(m)
        vb[m - 1] = u[m - 1]
        for g in range(m - 2, -1, -1):
            vb[g] = min(u[g], reach(vb[g + 1], s[idx[g + 1]] - s[idx[g]], ag[g], jg[g]))
        w = np.empty(m)
        w[0] = v0
        for g in range(m - 1):
            length = s[idx[g + 1]] - s[idx[g]]
            w[g + 1] = min(vb[g + 1], reach(w[g], length, ag[g], jg[g]))
            if w[g] > w[g + 1] and transition_distance(w[g], w[g + 1], ag[g], jg[g]) > length:
                w[g + 1] = reach_down(w[g], length, ag[g], jg[g])  # braking from above the bound
        # 4. peaks and checks
        vp = np.zeros(m - 1)
        changed = False
        for g in range(m - 1):
            lo, hi = idx[g], idx[g + 1]
            length = s[hi] - s[lo]
            base = max(w[g], w[g + 1])
            if length <= 0.0:
                vp[g] = base
                continue
            if ok_hi[lo] == hi and ok_key[lo, 0] == w[g] and ok_key[lo, 1] == w[g + 1] and \
                    ok_key[lo, 2] == ag[g] and ok_key[lo, 3] == jg[g]:
                vp[g] = ok_vp[lo]
                continue
            top = max(np.sqrt(max(x[lo:hi + 1].max(), 0.0)), base)
            p = peak_speed(w[g], w[g + 1], length, top, ag[g], jg[g])
            worst, over = check(geo, rate, x, lo, hi, Segment(w[g], p, w[g + 1], ag[g], jg[g]), lim, cv[g], False)
            if worst >= 0 and p > base:
                low, high = base, p
                for _b in range(_PEAK_STEPS):
                    mid = 0.5 * (low + high)
                    if not above_x(s, x, lo, hi, Segment(w[g], mid, w[g + 1], ag[g], jg[g])):
                        low = mid
                    else:
                        high = mid
                if low >= (1.0 - _PEAK_GIVE) * p:  # a slightly lower peak clears it
                    p = low
                    worst, over = check(geo, rate, x, lo, hi, Segment(w[g], p, w[g + 1], ag[g], jg[g]), lim, cv[g],
                                        False)
            vp[g] = p
            if (worst >= 0 or over != 0) and rnd >= _ROUNDS // 2:
                anchor[lo:hi + 1] = True  # the last resort: a stop-free staircase, sample by sample
                changed = True
            elif worst >= 0:
                changed |= anchor_peaks(s, x, lo, hi, Segment(w[g], p, w[g + 1], ag[g], jg[g]), anchor)
            if over & ACC_OVER:
                scale_a[lo:hi] *= _SCALE_STEP
            if over & JERK_OVER:
                scale_j[lo:hi] *= _SCALE_STEP
            if over != 0:
                changed = True
            elif worst < 0:
                ok_hi[lo] = hi
                ok_key[lo, 0], ok_key[lo, 1], ok_key[lo, 2], ok_key[lo, 3] = w[g], w[g + 1], ag[g], jg[g]
                ok_vp[lo] = p
        if not changed:
            converged = True
            break
    if converged:
        _raise_limits(geo, rate, x, lim, curved, idx, w, vp, ag, jg)
        idx, w, vp, ag, jg = merge_runs(geo, rate, x, lim, curved, idx, w, vp, ag, jg)
    return idx, w, vp, ag, jg, converged


@njit(cache=True)
def _raise_limits(geo, rate, x, lim, curved, idx, w, vp, ag, jg):
    """Step 5: a gap whose scales fell by whole _SCALE_STEPs often passes with less taken off.
    With its anchor speeds kept (higher limits still reach them), each such gap takes the highest
    limits up to its nominal ones that pass every check of step 4, at the peak they allow or else
    at its own: the gap alone changes, so the passes need not run again."""
    s, t = geo.s, geo.t
    for g in range(idx.shape[0] - 1):
        lo, hi = idx[g], idx[g + 1]
        length = s[hi] - s[lo]
        if length <= 0.0:
            continue
        a_nom, j_nom = nominal(t, lo, hi, lim.a_axis, lim.j_axis)
        if ag[g] >= a_nom and jg[g] >= j_nom:
            continue
        top = max(np.sqrt(max(x[lo:hi + 1].max(), 0.0)), max(w[g], w[g + 1]))
        now = phases(w[g], vp[g], w[g + 1], length, ag[g], jg[g])[0][7]
        best = phases(w[g], peak_speed(w[g], w[g + 1], length, top, a_nom, j_nom), w[g + 1], length, a_nom,
                      j_nom)[0][7]
        if now - best <= _RAISE_MIN_S:
            continue
        ok, bad, ok_p = 1.0, max(a_nom / ag[g], j_nom / jg[g]), vp[g]
        for _b in range(_RAISE_STEPS):
            mid = 0.5 * (ok + bad)
            a, j = min(a_nom, ag[g] * mid), min(j_nom, jg[g] * mid)
            # the peak these limits allow, else the one the gap has (shorter speed changes fit)
            p = max(vp[g], peak_speed(w[g], w[g + 1], length, top, a, j))
            worst, over = check(geo, rate, x, lo, hi, Segment(w[g], p, w[g + 1], a, j), lim, curved[lo], True)
            if (worst >= 0 or over != 0) and p > vp[g]:
                p = vp[g]
                worst, over = check(geo, rate, x, lo, hi, Segment(w[g], p, w[g + 1], a, j), lim, curved[lo], True)
            if worst < 0 and over == 0:
                ok, ok_p = mid, p
            else:
                bad = mid
        if ok > 1.0:
            ag[g], jg[g], vp[g] = min(a_nom, ag[g] * ok), min(j_nom, jg[g] * ok), ok_p

