"""Feed limits at the path samples, as caps on x = v^2 (the phase-plane variable), each
with its reason code (ipo/contracts.py LIMIT_*).

All functions are pure and work on arrays of samples: unit tangent t (K, 3), curvature
vector kv = dt/ds (K, 3), per-axis limits V (3,) mm/s and A (3,) mm/s^2.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_AXIS, LIMIT_CHORD, LIMIT_CURVATURE, LIMIT_DWELL, LIMIT_ROUGHNESS
from ipo.feed.cap_kernels import (CORNER_SHARE, NEGLIGIBLE_STEP, axis_cap_at, combined_caps, curvature_cap_at,
                                  geometric_caps)
from ipo.roughness import inclination_rad, roughness_feed_mm_s

# The roughness cap is planned a hair below its value: the profile meets it at samples and
# the per-period feed is a mean over the period, which may otherwise exceed it by ~1e-5.
ROUGHNESS_USE = 0.9999
# An acceleration step da between two periods shows in the third finite difference of the
# per-period positions (the jerk) weighted by the quadratic B-spline of the three periods
# around it: at most 3/4 da / T, when the step falls mid-period.
STEP_JERK_SHARE = 0.75
# S-curve mode: a corner blend crossed below this multiple of lowest_smooth_x is slower than
# stopping at the corner (single 30 and 90 degree corners between 10 mm lines at F6000 broke
# even near a blend cap of 7.8 mm/s, 1.56 sqrt(lowest_smooth_x))
G2_BLEND_MIN_X = 2.5


@njit(cache=True)
def axis_velocity_cap(t, v_max):
    """v |t_i| <= V_i on every axis."""
    out = np.empty(t.shape[0])
    for k in range(t.shape[0]):
        out[k] = axis_cap_at(t, k, v_max)
    return out


@njit(cache=True)
def curvature_cap(t, kv, a_max):
    """Largest x for which some path acceleration s'' keeps every axis within its limit.

    Axis i needs |t_i s'' + kv_i x| <= A_i: an interval for s'' centred on -kv_i x / t_i
    with half-width A_i / |t_i|. All intervals meet iff every pair does, which bounds x
    pairwise; an axis with t_i = 0 needs |kv_i| x <= A_i on its own.
    """
    out = np.empty(t.shape[0])
    for k in range(t.shape[0]):
        out[k] = curvature_cap_at(t, kv, k, a_max)
    return out


@njit(cache=True)
def spread_min(s, cap, span_s, period_s, accel):
    """Each cap also holds wherever the moving-average filter (S-curve mode, m periods of
    span_s = m T) mixes planned speeds into the output at that point.

    The output position p is the mean of the last m planned positions and its speed the
    mean planned speed over those periods plus one: a window of W <= span + 2 T in which the
    planned trajectory passes p. Either end of the window lies (1/W) int tau v(tau) dtau
    from p (the mean, tau counted from the far end). With the speed held to v_c within the
    reach R >= v_c W / 2, leaving it takes W / 2 at least, and from there the speed grows
    by accel (|s''| <= |a| <= ||A||) at most: R = v_c W / 2 + 5 accel W^2 / 48. v^2 being
    linear between samples, the samples are capped up to the first one beyond R."""
    n = s.shape[0]
    out = cap.copy()
    for k in range(n):
        if not (0.0 < cap[k] < 1e300):
            continue  # no cap, or a stop: the filter is run out at stops
        w = span_s + 2.0 * period_s
        reach = np.sqrt(cap[k]) * w / 2.0 + 5.0 * accel * w * w / 48.0
        j = k - 1
        while j >= 0:
            out[j] = min(out[j], cap[k])
            if s[k] - s[j] > reach:
                break
            j -= 1
        j = k + 1
        while j < n:
            out[j] = min(out[j], cap[k])
            if s[j] - s[k] > reach:
                break
            j += 1
    return out


def lowest_smooth_x(fir, a_max: np.ndarray, period_s: float) -> float:
    """S-curve mode: the lowest cap on v^2 the moving-average filter `fir` crosses smoothly,
    what it mixes in over its span at the path acceleration, (A span / 2)^2."""
    return (0.5 * float(a_max.max()) * fir.m * period_s) ** 2


def low_caps_to_stops(cap: np.ndarray, piece: np.ndarray, x_low: float) -> np.ndarray:
    """S-curve mode: a cap below x_low (lowest_smooth_x: too low for the filter to cross a
    step of the curvature smoothly) becomes a stop where pieces meet and at the window's
    ends, so the curvature steps at standstill; inside a piece the curvature is continuous
    and the low cap is crossed as it is, not stopped at sample by sample."""
    edge = np.ones(len(piece), bool)
    edge[1:-1] = (piece[1:-1] != piece[:-2]) | (piece[1:-1] != piece[2:])
    return np.where((cap < x_low) & edge, 0.0, cap)


def min_blend_radius_mm(fir, a_max: np.ndarray, j_max: np.ndarray | None, period_s: float) -> float:
    """S-curve mode: the smallest corner blend of radius R crossed without stopping. Below it
    the blend's caps, where it meets a move v^2 / R <= J T (its curvature steps), along it
    v^2 / R <= A and v^3 / R^2 <= J, lie under lowest_smooth_x: it would be stopped at both
    ends, where the unblended corner stops once. 0 without the filter (trapezoid mode)."""
    if fir is None:
        return 0.0
    x_low, j = lowest_smooth_x(fir, a_max, period_s), float(j_max.min())
    return max(x_low / (j * period_s), x_low / float(a_max.min()), float(np.sqrt(x_low**1.5 / j)))


def g2_blend_limits(fir, a_max: np.ndarray, j_max: np.ndarray | None,
                    period_s: float) -> tuple[float, float, float, float] | None:
    """S-curve mode: (a, j, x_min, step) for pieces.build's curvature-continuous corner
    blends: the smallest path acceleration and jerk limits, the lowest cap on v^2 at which
    crossing such a blend beats stopping at the corner (G2_BLEND_MIN_X lowest_smooth_x), and
    what a circular blend's curvature step 1/R allows, v^2 / R <= J T / STEP_JERK_SHARE
    (sample_caps). None without the filter (trapezoid mode keeps its circular blends)."""
    if fir is None:
        return None
    j = float(j_max.min())
    return (float(a_max.min()), j, G2_BLEND_MIN_X * lowest_smooth_x(fir, a_max, period_s),
            j * period_s / STEP_JERK_SHARE)


def jerk_accel_scale(t: np.ndarray, kv: np.ndarray, x_cap: np.ndarray, a_max: np.ndarray,
                     j_mm_s3: float) -> np.ndarray:
    """Share of the path acceleration in each of the K - 1 intervals (S-curve mode) that keeps
    the rate of change of the centripetal acceleration from speeding up on a curve,
    d(v^2 kappa)/dt = 2 v s'' kappa, within j_mm_s3: v from the cap at either end, s'' up to
    what the axis limits allow along the tangent, min_i A_i / |t_i|."""
    with np.errstate(divide="ignore"):
        a_path = np.min(a_max[None, :] / np.abs(t), axis=1)
        w = np.sqrt(np.minimum(x_cap, 1e12)) * np.linalg.norm(kv, axis=1) * np.minimum(a_path, 1e12)
        rate = 2.0 * np.maximum(w[:-1], w[1:])
        return np.minimum(1.0, j_mm_s3 / rate)


def curvature_rate_cap(s: np.ndarray, kv: np.ndarray, piece: np.ndarray, j_max: np.ndarray) -> np.ndarray:
    """S-curve mode: along a piece the centripetal acceleration kv_i v^2 changes at the rate
    v^3 dkv_i/ds (its turning with the tangent and the change of the curvature itself),
    kept within J_i; dkv/ds from the samples, the larger of the intervals either side."""
    ds = np.diff(s)
    inner = (ds > 0) & (piece[1:] == piece[:-1])
    rate = np.zeros((len(s), kv.shape[1]))
    d = np.abs(np.diff(kv, axis=0)) / np.where(inner, ds, 1.0)[:, None] * inner[:, None]
    rate[:-1] = d
    rate[1:] = np.maximum(rate[1:], d)
    with np.errstate(divide="ignore"):
        return np.min((j_max[None, :] / rate) ** (2.0 / 3.0), axis=1)


def _least_inclination(t: np.ndarray) -> np.ndarray:
    """Smallest inclination on the intervals next to each sample (0 where the tangent
    crosses the horizontal), so that the cap at the samples holds in between too."""
    alpha = inclination_rad(t)
    tz = t[:, 2]
    lo = alpha.copy()
    for a, b in ((slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None))):
        cross = np.sign(tz[a]) != np.sign(tz[b])
        lo[a] = np.where(cross, 0.0, np.minimum(lo[a], alpha[b]))
    return lo


def sample_caps(smp, pc, v_max: np.ndarray, a_max: np.ndarray, period_s: float, delta_mm: float,
                finishing: tuple[float, float, float, int] | None, j_max: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cap on v^2 at every sample from all limits except the programmed feed, its reason,
    and which samples sit on a sharp (unblended) corner.

    `finishing` = (ball radius, pick feed, roughness target, flutes) switches on 002's
    limiter for feed moves while the spindle turns; None switches it off. With j_max
    (S-curve mode) a jump of the curvature vector where pieces meet, which steps each
    axis acceleration within a period, is kept within the jerk limit,
    v^2 |dkv_i| <= J_i T / STEP_JERK_SHARE, the turning of the centripetal acceleration along a curve too,
    v^3 kappa^2 <= J, and the machine stops at an unblended corner (crossing it would
    step the velocity itself).
    """
    room = a_max * period_s if j_max is None else np.minimum(a_max * period_s, j_max * period_s**2)
    x_axis, x_curv, x_corner, corner, edge, sharp = geometric_caps(
        smp.t, smp.kv, smp.piece, pc.corner_tol_mm, v_max, a_max, (1.0 - CORNER_SHARE) * a_max * period_s,
        NEGLIGIBLE_STEP * room, period_s, delta_mm)
    if j_max is not None:
        with np.errstate(divide="ignore"):
            dk = np.abs(smp.kv[edge + 1] - smp.kv[edge])
            x_jerk = np.min(j_max[None, :] * period_s / (STEP_JERK_SHARE * dk), axis=1)
        x_jerk = np.where(sharp, 0.0, x_jerk)
        x_corner[edge] = np.minimum(x_corner[edge], x_jerk)
        x_corner[edge + 1] = np.minimum(x_corner[edge + 1], x_jerk)
        # the centripetal acceleration turns with the tangent: its rate is v^3 kappa^2
        kappa = np.linalg.norm(smp.kv, axis=1)
        with np.errstate(divide="ignore"):
            x_corner = np.minimum(x_corner, (j_max.min() / kappa**2) ** (2.0 / 3.0))
        x_corner = np.minimum(x_corner, curvature_rate_cap(smp.s, smp.kv, smp.piece, j_max))
    rows = [x_axis, x_curv, x_corner, x_corner]  # row 3: the chord cap, filled in by combined_caps
    codes = [LIMIT_AXIS, LIMIT_CURVATURE, LIMIT_CURVATURE, LIMIT_CHORD]
    if finishing is not None:
        r, pick, target, flutes = finishing
        rpm = pc.rpm[smp.piece]
        active = ~pc.rapid[smp.piece] & (rpm > 0)
        f = roughness_feed_mm_s(r, pick, target, flutes, rpm, _least_inclination(smp.t)) * ROUGHNESS_USE
        rows.append(np.where(active, f**2, np.inf))
        codes.append(LIMIT_ROUGHNESS)
    cap, reason = combined_caps(smp.s, smp.kv, smp.piece, pc.stop_after, edge, np.vstack(rows),
                                np.array(codes, np.int8), delta_mm, delta_mm**2, period_s, LIMIT_DWELL)
    return cap, reason, corner
