"""The per-sample feed limits, compiled: caps on x = v^2 at millions of samples per program.

ipo.feed.limits.sample_caps runs them in two passes around the S-curve mode's own caps:
`geometric_caps` (axis velocity, curvature, unblended corners) and `combined_caps` (chord
error over what the others allow, the pick of the binding cap, stops). The formulas and
their reasons are ipo.feed.limits's; the arithmetic follows numpy's element by element (a
sum of three squares as ((x^2 + y^2) + z^2), as np.linalg.norm sums), so the caps are the
same to the bit as the array forms they replace.
"""
from __future__ import annotations

from math import inf, isfinite, isnan, sqrt
from typing import NamedTuple

import numpy as np
from numba import njit

TINY = 1e-12
# Share of each axis limit left for the path acceleration next to an unblended corner,
# whose own velocity step takes the rest within one period (geometric_caps).
CORNER_SHARE = 0.5
# A tangent step below this share of an axis's per-period velocity change is no corner.
NEGLIGIBLE_STEP = 0.005


class SampleGeometry(NamedTuple):
    """The samples as the cap kernels read them."""

    s: np.ndarray  # arc length, mm
    t: np.ndarray  # unit tangent, (n, 3)
    kv: np.ndarray  # curvature vector, (n, 3), 1/mm
    piece: np.ndarray  # the piece each sample lies on


class CapRule(NamedTuple):
    """The machine's limits and the period's figures the caps are computed from."""

    v_max: np.ndarray  # per axis, mm/s
    a_max: np.ndarray  # per axis, mm/s^2
    corner_acc_t: np.ndarray  # (1 - CORNER_SHARE) A T per axis, mm/s
    step_room: np.ndarray  # NEGLIGIBLE_STEP times an axis's per-period velocity change, mm/s
    period_s: float
    delta_mm: float  # chord tolerance
    delta2_mm2: float  # delta_mm**2 as Python computes it


@njit(cache=True, error_model="numpy")
def axis_cap_at(t, k, v_max):
    """v |t_i| <= V_i on every axis, at sample k."""
    m = inf
    for a in range(3):
        z = v_max[a] / abs(t[k, a])
        m = min(m, z * z)
    return m


@njit(cache=True, error_model="numpy")
def curvature_cap_at(t, kv, k, a_max):
    """Largest x for which some path acceleration s'' keeps every axis within its limit, at
    sample k.

    Axis i needs |t_i s'' + kv_i x| <= A_i: an interval for s'' centred on -kv_i x / t_i
    with half-width A_i / |t_i|. All intervals meet iff every pair does, which bounds x
    pairwise; an axis with t_i = 0 needs |kv_i| x <= A_i on its own.
    """
    cap = inf
    for i in range(3):
        if not abs(t[k, i]) > TINY and abs(kv[k, i]) > TINY:
            cap = min(cap, a_max[i] / abs(kv[k, i]))
    for i in range(3):
        ti = t[k, i]
        if not abs(ti) > TINY:
            continue
        for j in range(i + 1, 3):
            tj = t[k, j]
            if not abs(tj) > TINY:
                continue
            gap = abs(kv[k, i] / ti - kv[k, j] / tj)
            if gap > TINY:
                cap = min(cap, (a_max[i] / abs(ti) + a_max[j] / abs(tj)) / gap)
    return cap


@njit(cache=True, error_model="numpy")
def geometric_caps(geo, corner_tol, rule):
    """Axis-velocity and curvature caps at every sample of geo (SampleGeometry) under rule
    (CapRule), and the corner caps where pieces meet at a sharp (unblended) corner, as
    limits.sample_caps defines them; corner_tol per piece.

    Returns (x_axis, x_curv, x_corner, corner, edge, sharp): edge holds the samples where a
    piece ends, sharp which of those corners are sharp."""
    t, kv, piece = geo.t, geo.kv, geo.piece
    v_max, a_max, corner_acc_t, step_room = rule.v_max, rule.a_max, rule.corner_acc_t, rule.step_room
    n = t.shape[0]
    x_axis = np.empty(n)
    x_curv = np.empty(n)
    x_corner = np.full(n, inf)
    corner = np.zeros(n, np.bool_)
    for k in range(n):
        x_axis[k] = axis_cap_at(t, k, v_max)
        x_curv[k] = curvature_cap_at(t, kv, k, a_max)
    n_edge = 0
    for k in range(n - 1):
        n_edge += piece[k + 1] != piece[k]
    edge = np.empty(n_edge, np.int64)
    sharp = np.zeros(n_edge, np.bool_)
    cap = np.empty(n_edge)
    e = 0
    for k in range(n - 1):
        if piece[k + 1] == piece[k]:
            continue
        edge[e] = k
        top = min(min(x_axis[k], x_curv[k]), min(x_axis[k + 1], x_curv[k + 1]))
        v_top = sqrt(min(top, 1e300))
        v_acc = inf
        d2 = 0.0
        for a in range(3):
            d = abs(t[k + 1, a] - t[k, a])
            sharp[e] |= v_top * d > step_room[a]
            v_acc = min(v_acc, corner_acc_t[a] / d)
            d2 += d * d
        if sharp[e]:
            # crossed within one period: half of each axis limit, and the period's chord
            # cuts the corner by (v T / 2) sin(theta / 2) <= tol
            tol = max(rule.delta_mm, corner_tol[piece[k]])
            v = min(v_acc, 4 * tol / (rule.period_s * sqrt(d2)))
            cap[e] = v * v
        e += 1
    for e in range(n_edge):  # both sides of a corner; the later side wins, as numpy assigns
        if sharp[e]:
            x_corner[edge[e]] = cap[e]
            corner[edge[e]] = True
    for e in range(n_edge):
        if sharp[e]:
            x_corner[edge[e] + 1] = cap[e]
            corner[edge[e] + 1] = True
    # every interval touching a corner sample is planned with CORNER_SHARE of the axis
    # limits (lookahead.plan's ascale): its ends must be reachable within that share
    a_corner = CORNER_SHARE * a_max
    for k in range(n):
        if corner[k] or (k > 0 and corner[k - 1]) or (k + 1 < n and corner[k + 1]):
            x_curv[k] = min(x_curv[k], curvature_cap_at(t, kv, k, a_corner))
    return x_axis, x_curv, x_corner, corner, edge, sharp


@njit(cache=True)
def window_max(s, kappa, reach):
    """max of kappa over the samples within s[k] +- reach[k]."""
    n = s.shape[0]
    out = np.empty(n)
    for k in range(n):
        m = kappa[k]
        j = k - 1
        while j >= 0 and s[k] - s[j] <= reach[k]:
            m = max(m, kappa[j])
            j -= 1
        if j >= 0:
            m = max(m, kappa[j])  # the sample just outside bounds the curvature in between
        j = k + 1
        while j < n and s[j] - s[k] <= reach[k]:
            m = max(m, kappa[j])
            j += 1
        if j < n:
            m = max(m, kappa[j])
        out[k] = m
    return out


@njit(cache=True, error_model="numpy")
def chord_cap(s, kv, delta_mm, delta2_mm2, period_s, x_other):
    """Chord error within delta for every chord a period can span.

    The formula V <= (2/T) sqrt(2 rho delta - delta^2) holds for a constant radius; on a
    real curve the chord spans varying curvature, so rho is taken as the smallest radius
    within one chord (at the speed the other limits allow) of the sample, iterated once
    with the reduced speed. delta2_mm2 = delta_mm**2 as Python computes it.
    """
    n = s.shape[0]
    kappa = np.empty(n)
    reach = np.empty(n)
    cap = np.full(n, inf)
    for k in range(n):
        kappa[k] = sqrt((kv[k, 0] * kv[k, 0] + kv[k, 1] * kv[k, 1]) + kv[k, 2] * kv[k, 2])
        reach[k] = sqrt(min(x_other[k], 1e12)) * period_s
    for _ in range(2):
        k_eff = window_max(s, kappa, reach)
        for k in range(n):
            rho = 1.0 / k_eff[k] if k_eff[k] > TINY else inf
            half = 2 * rho * delta_mm - delta2_mm2 if rho > delta_mm else delta2_mm2
            v = 2.0 / period_s * sqrt(half) if isfinite(rho) else inf  # algorithms.md §6
            cap[k] = v * v
            reach[k] = sqrt(min(min(x_other[k], cap[k]), 1e12)) * period_s
    return cap


@njit(cache=True)
def binding(caps, m):
    """Element-wise minimum of the first m rows of caps (C, K) and the row that binds: the
    first minimal one, a NaN before any number (np.argmin's choice)."""
    n = caps.shape[1]
    x = np.empty(n)
    arg = np.zeros(n, np.int64)
    for k in range(n):
        best = caps[0, k]
        for c in range(1, m):
            v = caps[c, k]
            if not isnan(best) and (isnan(v) or v < best):
                best = v
                arg[k] = c
        x[k] = best
    return x, arg


@njit(cache=True, error_model="numpy")
def combined_caps(geo, stop_after, edge, caps, codes, rule, dwell_code):
    """The chord cap (rule: CapRule) over what the caps in rows 0-2 of caps (C, K) allow at the
    samples geo (SampleGeometry), into row 3, then the binding cap of all C rows and its reason
    (codes[row]); zero with dwell_code at the samples where a piece that stops ends and at the
    sample after."""
    piece = geo.piece
    caps[3] = chord_cap(geo.s, geo.kv, rule.delta_mm, rule.delta2_mm2, rule.period_s, binding(caps, 3)[0])
    x, arg = binding(caps, caps.shape[0])
    reason = np.empty(x.shape[0], np.int8)
    for k in range(x.shape[0]):
        reason[k] = codes[arg[k]]
    n = x.shape[0]
    for e in range(edge.shape[0] + 1):
        k = edge[e] if e < edge.shape[0] else n - 1
        if stop_after[piece[k]]:
            x[k] = 0.0
            reason[k] = dwell_code
            if k + 1 < n:
                x[k + 1] = 0.0
                reason[k + 1] = dwell_code
    return x, reason
