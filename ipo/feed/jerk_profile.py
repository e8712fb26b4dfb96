"""S-curve mode's speed profile: jerk-limited transitions between anchors, planned on the path.

Why this form. The look-ahead (ipo.feed.lookahead) gives the time-optimal acceleration-limited
profile x(s) = v^2 under every cap. A jerk-limited profile lies below it. Its valleys (where a
cap holds the speed down) and its stops are where the acceleration passes through zero, so
they are natural anchors; between two anchors the fastest jerk-limited motion along a straight
stretch is a speed change up to a peak and a speed change down, each with zero acceleration at
both ends: the classic seven-phase double-S profile (Biagiotti & Melchiorri, Trajectory Planning
for Automatic Machines, 2008, sec. 3.4), which is what ruckig returns for the same limits (the
tests compare the two). Its distance and duration are closed forms, so the anchor speeds
follow from a backward and a forward pass like the look-ahead's, with "reachable within this
distance" taken from the jerk-limited transition instead of the constant-acceleration one. A
third-order phase-plane method would follow the caps more closely on curves, but has no such
closed form; ruckig per segment would be the same profile through a library call per segment.

Limits per segment. On a straight stretch the path acceleration and jerk are the axis limits
over the direction cosines, A_i / |t_i| and J_i / |t_i|: the whole budget, nothing is split.
Where the path curves (an arc, a blend, a NURBS, including short straights between curved
pieces), axis i sees t_i s'' + kv_i v^2 and t_i s''' + 3 kv_i v s'' + kv_i' v^3: the caps of
ipo.feed.limits hold the curvature terms within their share of J (j_max), and the segment's
path acceleration and jerk take what is left at the speeds the look-ahead allows there. The
boundaries between straight and curved stretches are anchors too, so a long line next to a
tight blend accelerates with the line's whole budget.

Every segment's speed is checked against the acceleration-limited profile at the samples inside
it; where it would pass above, that sample becomes one more anchor at its speed.
"""
from __future__ import annotations

import numpy as np
from numba import njit

_BISECT = 60


@njit(cache=True)
def transition_time(dv, a, j):
    """Duration of the fastest change of speed by dv >= 0 with zero acceleration at both
    ends, |s''| <= a, |s'''| <= j."""
    if dv * j >= a * a:
        return dv / a + a / j
    return 2.0 * np.sqrt(dv / j)


@njit(cache=True)
def transition_distance(va, vb, a, j):
    """Path length of that change from va to vb: the speed is point-symmetric about the
    middle of the change, so the mean speed is (va + vb) / 2."""
    return 0.5 * (va + vb) * transition_time(abs(vb - va), a, j)


@njit(cache=True)
def _boundary(v, d, a, j, ok, bad):
    """Bisection between a speed w = ok with transition_distance(v, w) <= d and one, bad,
    beyond: the last speed that still fits."""
    for _ in range(_BISECT):
        mid = 0.5 * (ok + bad)
        if transition_distance(v, mid, a, j) <= d:
            ok = mid
        else:
            bad = mid
    return ok


@njit(cache=True)
def reach(v, d, a, j):
    """The largest w >= v with transition_distance(v, w) <= d (the same as the largest speed
    from which v is reached within d: the distance is symmetric in its speeds). Closed form:
    the look-ahead's passes call this once per anchor and round, so it is most of the plan.
    With dv = w - v, d = (v + dv / 2) T(dv): a quadratic in dv where the change reaches a
    (dv >= a^2 / j), else with u = sqrt(dv) the cubic u^3 + 2 v u = d sqrt(j), one real root."""
    if d <= 0.0:
        return v
    dv_a = a * a / j
    if d >= (v + 0.5 * dv_a) * 2.0 * a / j:
        # dv^2 / (2a) + (v / a + a / (2j)) dv + (v a / j - d) = 0, the positive root without cancellation
        b = v / a + 0.5 * a / j
        c = d - v * a / j
        dv = 2.0 * c / (b + np.sqrt(b * b + 2.0 * c / a))
    else:
        p, q = 2.0 * v, d * np.sqrt(j)
        r = np.sqrt(0.25 * q * q + p**3 / 27.0)
        m = np.cbrt(0.5 * q + r)
        u = m - p / (3.0 * m) if m > 0.0 else 0.0
        for _ in range(3):  # Newton polishes Cardano's root where p dominates and it cancels
            u = max(u - (u**3 + p * u - q) / (3.0 * u * u + p), 0.0)
        dv = u * u
    w = v + dv
    while w > v and transition_distance(v, w, a, j) > d:  # rounding: the speed must still fit
        w = max(np.nextafter(w, 0.0), v)
    return w


@njit(cache=True)
def reach_down(v, d, a, j):
    """The smallest w <= v with transition_distance(v, w) <= d: braking as hard as the
    limits allow within d (0 if the machine can stop within d)."""
    if transition_distance(v, 0.0, a, j) <= d:
        return 0.0
    return _boundary(v, d, a, j, v, 0.0)


@njit(cache=True)
def peak_speed(va, vb, length, v_top, a, j):
    """Highest speed vp in [max(va, vb), v_top] of a segment that changes from va up to vp
    and down to vb within length (the rest at vp)."""
    lo = max(va, vb)
    if transition_distance(va, v_top, a, j) + transition_distance(v_top, vb, a, j) <= length:
        return v_top
    hi = v_top
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if transition_distance(va, mid, a, j) + transition_distance(mid, vb, a, j) <= length:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def phases(va, vp, vb, length, a, j):
    """The segment va -> vp -> vb of the given length as its seven phases of constant jerk
    (rising ramp, constant acceleration, falling ramp, cruise at vp, and the same down to vb):
    start times tt (8, the last the end), arc length ss, speed vv and acceleration aa at each
    start, and each phase's jerk jj (7)."""
    tt = np.zeros(8)
    ss = np.zeros(8)
    vv = np.zeros(8)
    aa = np.zeros(8)
    jj = np.zeros(7)
    d1 = transition_distance(va, vp, a, j)
    d2 = transition_distance(vp, vb, a, j)
    cruise = max((length - d1 - d2) / vp, 0.0) if vp > 0.0 else 0.0
    vv[0] = va
    q = 0
    for half in range(2):
        v_from, v_to = (va, vp) if half == 0 else (vp, vb)
        dv = abs(v_to - v_from)
        sg = 1.0 if v_to >= v_from else -1.0
        ap = min(a, np.sqrt(dv * j)) if dv > 0.0 else 0.0
        tj = ap / j
        tc = transition_time(dv, a, j) - 2.0 * tj if dv > 0.0 else 0.0
        durs = (tj, tc, tj)
        jerks = (sg * j, 0.0, -sg * j)
        for r in range(3):
            jj[q] = jerks[r]
            _advance(tt, ss, vv, aa, jj, q, durs[r])
            q += 1
        if half == 0:
            jj[q] = 0.0
            _advance(tt, ss, vv, aa, jj, q, cruise)
            q += 1
    return tt, ss, vv, aa, jj


@njit(cache=True)
def _advance(tt, ss, vv, aa, jj, q, dur):
    """Phase q + 1 starts where phase q (jerk jj[q], lasting dur) ends."""
    tt[q + 1] = tt[q] + dur
    ss[q + 1] = ss[q] + vv[q] * dur + 0.5 * aa[q] * dur * dur + jj[q] * dur**3 / 6.0
    vv[q + 1] = vv[q] + aa[q] * dur + 0.5 * jj[q] * dur * dur
    aa[q + 1] = aa[q] + jj[q] * dur if jj[q] != 0.0 else aa[q]
    if q == 2 or q == 6:
        aa[q + 1] = 0.0  # each speed change ends with zero acceleration (rounding)


@njit(cache=True, inline="always")
def state(tt, ss, vv, aa, jj, tau):
    """(arc length, speed, acceleration, jerk) at time tau of a segment given as phases."""
    q = 0
    while q < 6 and tau >= tt[q + 1]:
        q += 1
    u = min(max(tau - tt[q], 0.0), tt[q + 1] - tt[q])
    return (ss[q] + vv[q] * u + 0.5 * aa[q] * u * u + jj[q] * u**3 / 6.0, vv[q] + aa[q] * u + 0.5 * jj[q] * u * u,
            aa[q] + jj[q] * u, jj[q])


@njit(cache=True)
def cruise_span(tt, ss, vv, aa, jj):
    """Arc lengths [from, to) at which state(time_at(dist)) is surely in the cruise (phase 3),
    whose speed, acceleration and jerk are vv[3] + 0, 0 and 0 at any time in it (its acceleration
    and jerk are exactly 0): time_at's phase by arc length is 3 there, and it solves to within
    1e-12 of dist, far from the phase's end (1e-6 of the length), so the time is in phase 3 too.
    Empty where the phases' start times are out of order (rounding of a vanishing phase). The
    checks read every sample of a gap, most of them often in its cruise: there they skip the
    solve (and the calls, whose five array arguments cost more than their arithmetic)."""
    if aa[3] == 0.0 and jj[3] == 0.0 and tt[1] <= tt[3] and tt[2] <= tt[3]:
        return max(ss[1], ss[2], ss[3]), ss[4] - 1e-6 * max(1.0, abs(ss[4]))
    return 1.0, 0.0


@njit(cache=True, inline="always")
def time_at(tt, ss, vv, aa, jj, dist):
    """When the segment has covered dist: the phase by its start, then Newton's method on that
    phase's cubic, kept within it by bisection."""
    q = 0
    while q < 6 and dist >= ss[q + 1]:
        q += 1
    lo, hi = tt[q], tt[q + 1]
    u = tt[q] + (dist - ss[q]) / vv[q] if vv[q] > 1e-9 else 0.5 * (lo + hi)
    u = min(max(u, lo), hi)
    for _ in range(_BISECT):
        sq, v, _, _ = state(tt, ss, vv, aa, jj, u)
        err = sq - dist
        if abs(err) <= 1e-12 * max(1.0, abs(dist)):
            return u
        if err > 0.0:
            hi = u
        else:
            lo = u
        nxt = u - err / v if v > 1e-12 else 0.5 * (lo + hi)
        u = nxt if lo < nxt < hi else 0.5 * (lo + hi)
        if hi - lo <= 1e-15:
            break
    return u


@njit(cache=True)
def durations(s, idx, w, vp, ag, jg):
    """Duration of each gap's segment: anchors at samples idx of arc lengths s, their speeds
    w, and per gap the peak speed vp and the path limits ag, jg (ipo.feed.jerk_plan.plan)."""
    m = idx.shape[0]
    out = np.zeros(m - 1)
    for g in range(m - 1):
        length = s[idx[g + 1]] - s[idx[g]]
        if length > 0.0:
            out[g] = phases(w[g], vp[g], w[g + 1], length, ag[g], jg[g])[0][7]
    return out


@njit(cache=True)
def arc_lengths_at(times, s, idx, w, vp, ag, jg, t_start):
    """Arc length at each time (from the first anchor; times ascending within the gaps'
    total) and the gap each falls in; t_start[g] is when gap g begins."""
    out = np.empty(times.shape[0])
    gap = np.empty(times.shape[0], np.int64)
    m = idx.shape[0]
    g = 0
    while g + 1 < m - 1 and t_start[g + 1] <= times[0]:
        g += 1
    length = s[idx[g + 1]] - s[idx[g]]
    tt, ss, vv, aa, jj = phases(w[g], vp[g], w[g + 1], max(length, 0.0), ag[g], jg[g])
    for q in range(times.shape[0]):
        tq = times[q]
        if g + 1 < m - 1 and t_start[g + 1] <= tq:
            while g + 1 < m - 1 and t_start[g + 1] <= tq:
                g += 1
            length = s[idx[g + 1]] - s[idx[g]]
            tt, ss, vv, aa, jj = phases(w[g], vp[g], w[g + 1], max(length, 0.0), ag[g], jg[g])
        if length <= 0.0:
            out[q] = s[idx[g + 1]]
        else:
            d = state(tt, ss, vv, aa, jj, tq - t_start[g])[0]
            out[q] = s[idx[g]] + min(max(d, 0.0), length)
        gap[q] = g
    return out, gap
