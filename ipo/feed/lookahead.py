"""Look-ahead velocity profile over path samples and its time parameterisation.

The profile lives in the phase plane x(s) = v(s)^2, linear in s between samples (a
constant path acceleration s'' = dx/ds / 2 in each interval). A backward scan from the
window's end velocity bounds every sample by what the machine can still brake from, a
forward scan from the start velocity by what it can reach; both respect the per-axis
acceleration limits A_i through |t_i s'' + kv_i x| <= A_i (tangential plus centripetal
share of each axis), so the profile never exceeds the caps and is reachable. The limits
hold at both ends of every interval with its one s'': where the s'' allowed at one sample
misses the one allowed at the next (near a curvature cap whose binding axes change along
the path), the profile stays below the cap until one s'' fits both (a 2-variable linear
programme per interval in the backward pass).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.feed.interval_lp import end_range, interval_rows, max_start_from

_BIG = 1e300


@njit(cache=True)
def _bounds(t, kv, k, x, a_max, scale):
    """Range [lo, hi] of the path acceleration s'' allowed at sample k and speed^2 x, with
    the tangential share of the axis limits scaled by `scale`."""
    lo = -_BIG
    hi = _BIG
    for i in range(3):
        ti = t[k, i]
        if abs(ti) > 1e-12:
            c = -kv[k, i] * x / ti
            hw = scale * a_max[i] / abs(ti)
            lo = max(lo, c - hw)
            hi = min(hi, c + hw)
    if lo > hi:  # x sits (numerically) on the curvature cap: no room either way
        lo = hi = 0.5 * (lo + hi)
    return lo, hi


@njit(cache=True)
def backward(s, t, kv, cap, a_max, ascale, x_end):
    """Largest x at each sample from which the machine can still meet every later cap, with
    one constant s'' per interval that keeps the axis limits at both of its ends."""
    n = s.shape[0]
    xb = np.empty(n)
    xb[n - 1] = min(cap[n - 1], x_end)
    rows = np.empty((12, 3))
    unit = np.empty((16, 3))
    near = np.empty(16, np.bool_)
    pairs = np.full(4, -1, np.int64)  # the rows of the last optima: the next interval's first guesses
    for k in range(n - 2, -1, -1):
        xn = xb[k + 1]
        ds = s[k + 1] - s[k]
        if ds <= 0.0:
            xb[k] = min(cap[k], xn)
            continue
        m = interval_rows(t, kv, k, 2.0 * ds, a_max, ascale[k], rows)
        xk = max_start_from(rows, m, min(cap[k], _BIG), xn, unit, pairs, near)
        xb[k] = max(xk, 0.0)  # 0 always meets the rows (s'' = 0 between two stops)
    return xb


@njit(cache=True)
def forward(s, t, kv, xb, a_max, ascale, x0):
    """Fastest profile from x0 under the backward bound xb. If x0 lies above xb (the feed
    override dropped), the machine brakes at its limit until it is back under the bound."""
    n = s.shape[0]
    x = np.empty(n)
    x[0] = x0
    rows = np.empty((12, 3))
    for k in range(n - 1):
        xk = x[k]
        ds = s[k + 1] - s[k]
        if ds <= 0.0:
            x[k + 1] = min(xk, xb[k + 1])
            continue
        m = interval_rows(t, kv, k, 2.0 * ds, a_max, ascale[k], rows)
        lo, hi = end_range(rows, m, xk)
        if lo <= hi + 1e-9 * max(1.0, hi):  # riding a cap, the range closes to rounding
            # above xb only while braking at the limit
            x[k + 1] = max(min(hi, xb[k + 1]), min(lo, hi))
            continue
        # no single s'' fits both ends from xk (xk above the bound after an override drop):
        # brake as hard as the start allows
        f = ascale[k]
        lo0 = _bounds(t, kv, k, xk, a_max, f)[0]
        x[k + 1] = max(min(xb[k + 1], xk + 2.0 * ds * _bounds(t, kv, k, xk, a_max, f)[1]),
                       xk + 2.0 * ds * lo0, 0.0)
    return x


def plan(s, t, kv, cap, a_max, ascale, x0: float, x_end: float) -> np.ndarray:
    """The look-ahead profile x = v^2 at every sample; ascale (K-1,) scales the path
    acceleration in each interval (halved next to sharp corners)."""
    xb = backward(s, t, kv, cap, a_max, ascale, x_end)
    return forward(s, t, kv, xb, a_max, ascale, x0)


@njit(cache=True)
def np_max(a, b):
    """np.maximum of two floats (a NaN in a wins, -0.0 against 0.0 keeps a)."""
    return a if (a >= b or a != a) else b


@njit(cache=True)
def np_min(a, b):
    """np.minimum of two floats."""
    return a if (a <= b or a != a) else b


@njit(cache=True)
def search_right_from(a, x, j, x_before):
    """np.searchsorted(a, x, side="right") for an ascending a, given j, its value for
    x_before: a walk on from j when x >= x_before (periods come in time and path order),
    else the binary search. Over a batch of ascending x the walk costs O(len(x) + the
    samples passed) instead of a search of the whole window per period."""
    if not x >= x_before:  # a step back, or NaN on either side
        return np.searchsorted(a, x, side="right")
    n = a.shape[0]
    while j < n and a[j] <= x:
        j += 1
    return j


@njit(cache=True)
def _sample_times(s, x):
    n = s.shape[0]
    tc = np.empty(n)
    tc[0] = 0.0
    acc = 0.0
    v0 = np.sqrt(np_max(x[0], 0.0))
    for k in range(n - 1):
        v1 = np.sqrt(np_max(x[k + 1], 0.0))
        ds = s[k + 1] - s[k]
        vsum = v0 + v1
        if ds > 0 and vsum <= 0:
            return tc, k
        dt = 2.0 * ds / vsum if ds > 0 else 0.0
        acc = acc + dt if k > 0 else dt
        tc[k + 1] = acc
        v0 = v1
    return tc, -1


def sample_times(s: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Time at each sample from the first, with constant s'' in each interval."""
    tc, stuck = _sample_times(s, x)
    if stuck >= 0:
        raise RuntimeError(f"look-ahead profile stands still inside the path at s = {s[stuck]:.6f} mm")
    return tc


@njit(cache=True)
def positions_at(times, s, x, tc):
    """Arc length and the sample interval at each time (times within [0, tc[-1]])."""
    n = times.shape[0]
    pos = np.empty(n)
    ks = np.empty(n, np.int64)
    last = s.shape[0] - 2
    j, before = 0, np.nan
    for i in range(n):
        j = search_right_from(tc, times[i], j, before)
        before = times[i]
        k = min(max(j - 1, 0), last)
        tau = times[i] - tc[k]
        ds = s[k + 1] - s[k]
        v0 = np.sqrt(np_max(x[k], 0.0))
        acc = (x[k + 1] - x[k]) / (2.0 * ds) if ds > 0 else 0.0
        pos[i] = np_max(np_min(s[k] + v0 * tau + 0.5 * acc * tau * tau, s[k + 1]), s[k])
        ks[i] = k
    return pos, ks


@njit(cache=True)
def refine(s, t, kv, x, cap, plateau, a_max, ascale):
    """Insert the profile's own corners inside straight intervals.

    Between two samples x is linear in s, but on a straight stretch (no curvature, one
    tangent) the best profile is min(accelerate from x_k, cap, brake into x_k+1): a
    line that reaches its cruise speed, or turns from accelerating to braking, between
    two samples gets the exact breakpoints. A cap of 0 (a stop) holds at its sample only;
    `plateau` is the cap inside an interval that starts at one (programmed feed and axis
    velocities). Returns (s, x, source interval)."""
    n = s.shape[0]
    so = np.empty(3 * n)
    xo = np.empty(3 * n)
    src = np.empty(3 * n, np.int64)
    m = 0
    for k in range(n - 1):
        # 1. the sample itself
        so[m] = s[k]
        xo[m] = x[k]
        src[m] = k
        m += 1
        # 2. a straight interval: no curvature and one tangent at both ends
        ds = s[k + 1] - s[k]
        straight = ds > 0.0
        for i in range(3):
            if kv[k, i] != 0.0 or kv[k + 1, i] != 0.0 or t[k, i] != t[k + 1, i]:
                straight = False
        if not straight:
            # 3. a curved interval gets corners only between two stops
            if ds > 0.0 and x[k] <= 0.0 and x[k + 1] <= 0.0:
                # a curved stretch between two stops: accelerate, then brake, within the
                # curvature cap of its ends
                lo0, hi0 = _bounds(t, kv, k, 0.0, a_max, ascale[k])
                lo1, hi1 = _bounds(t, kv, k + 1, 0.0, a_max, ascale[k])
                hi, lo = min(hi0, hi1), max(lo0, lo1)
                if hi > 0.0 and lo < 0.0:
                    sp = -lo * ds / (hi - lo)
                    xp = min(2.0 * hi * sp, plateau[k])
                    for i in range(3):
                        kmax = max(abs(kv[k, i]), abs(kv[k + 1, i]))
                        if kmax > 0.0:
                            xp = min(xp, 0.5 * a_max[i] / kmax)
                    so[m] = s[k] + min(sp, xp / (2.0 * hi))
                    xo[m] = xp
                    src[m] = k
                    m += 1
                    so[m] = s[k + 1] - xp / (-2.0 * lo)
                    xo[m] = xp
                    src[m] = k
                    m += 1
            continue
        # 4. a straight interval: reach the cap (s1) and brake from it (s2), or turn from
        # accelerating to braking below it (sp)
        lo, hi = _bounds(t, kv, k, 0.0, a_max, ascale[k])
        c0 = cap[k] if cap[k] > 0.0 else plateau[k]
        c1 = cap[k + 1] if cap[k + 1] > 0.0 else plateau[k]
        c = min(c0, c1)
        if hi <= 0.0 or lo >= 0.0:
            continue
        s1 = (c - x[k]) / (2.0 * hi)  # reaches the cap
        s2 = ds - (c - x[k + 1]) / (-2.0 * lo)  # starts braking from the cap
        if s1 < s2:
            if s1 > 0.0 and s1 < ds:
                so[m] = s[k] + s1
                xo[m] = c
                src[m] = k
                m += 1
            if s2 > max(s1, 0.0) and s2 < ds:
                so[m] = s[k] + s2
                xo[m] = c
                src[m] = k
                m += 1
        else:
            sp = (x[k + 1] - x[k] - 2.0 * lo * ds) / (2.0 * (hi - lo))  # accelerate, then brake
            xp = x[k] + 2.0 * hi * sp
            if sp > 0.0 and sp < ds and xp > max(x[k], x[k + 1]):
                so[m] = s[k] + sp
                xo[m] = xp
                src[m] = k
                m += 1
    # 5. the last sample
    so[m] = s[n - 1]
    xo[m] = x[n - 1]
    src[m] = n - 2
    m += 1
    return so[:m], xo[:m], src[:m]
