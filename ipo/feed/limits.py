"""Feed limits at the path samples, as caps on x = v^2 (the phase-plane variable), each
with its reason code (ipo/contracts.py LIMIT_*).

All functions are pure and work on arrays of samples: unit tangent t (K, 3), curvature
vector kv = dt/ds (K, 3), per-axis limits V (3,) mm/s and A (3,) mm/s^2.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_AXIS, LIMIT_CHORD, LIMIT_CURVATURE, LIMIT_DWELL, LIMIT_ROUGHNESS
from ipo.feed.cap_kernels import (CORNER_SHARE, NEGLIGIBLE_STEP, CapRule, SampleGeometry, axis_cap_at, combined_caps,
                                  geometric_caps)
from ipo.roughness import inclination_rad, roughness_feed_mm_s

# The roughness cap is planned a hair below its value: the profile meets it at samples and
# the per-period feed is a mean over the period, which may otherwise exceed it by ~1e-5.
ROUGHNESS_USE = 0.9999
# An acceleration step da between two periods shows in the third finite difference of the
# per-period positions (the jerk) weighted by the quadratic B-spline of the three periods
# around it: at most 3/4 da / T, when the step falls mid-period.
STEP_JERK_SHARE = 0.75
# S-curve mode: a corner blend crossed below this multiple of ramp_x is slower than
# stopping at the corner (single 30 and 90 degree corners between 10 mm lines at F6000 broke
# even near a blend cap of 7.8 mm/s, 1.56 sqrt(ramp_x))
G2_BLEND_MIN_X = 2.5
# S-curve mode: the curvature's own rate of change, v^3 |kv_i'| (the centripetal acceleration
# turning and growing along a curve), may take this multiple of the steps' share of J (half):
# 0.9 J, where the path's own jerk and its coupling, checked with the rate as it is
# (ipo.feed.jerk_plan), keep to the rest
RATE_OVER_STEP = 1.8


@njit(cache=True)
def axis_velocity_cap(t, v_max):
    """v |t_i| <= V_i on every axis."""
    out = np.empty(t.shape[0])
    for k in range(t.shape[0]):
        out[k] = axis_cap_at(t, k, v_max)
    return out


def ramp_x(a_max: np.ndarray, j_max: np.ndarray) -> float:
    """S-curve mode: (A^2 / 2J)^2, the square of the speed a jerk-limited ramp gains while its
    acceleration rises to A (A the largest axis acceleration, J the curvature terms' jerk
    share): a corner blend whose caps lie below about this crawls through its curvature
    steps for longer than a stop at the corner would take."""
    a = float(a_max.max())
    return (a * a / (4.0 * float(j_max.min()))) ** 2


def min_blend_radius_mm(a_max: np.ndarray, j_max: np.ndarray | None, period_s: float) -> float:
    """S-curve mode: the smallest corner blend of radius R crossed without stopping. Below it
    the blend's caps, where it meets a move v^2 / R <= J T (its curvature steps), along it
    v^2 / R <= A and v^3 / R^2 <= J, lie under ramp_x: the unblended corner, which stops
    once, is as fast. 0 in trapezoid mode (j_max None)."""
    if j_max is None:
        return 0.0
    x_low, j = ramp_x(a_max, j_max), float(j_max.min())
    return max(x_low / (j * period_s), x_low / float(a_max.min()), float(np.sqrt(x_low**1.5 / j)))


def g2_blend_limits(a_max: np.ndarray, j_max: np.ndarray | None,
                    period_s: float) -> tuple[float, float, float, float] | None:
    """S-curve mode: (a, j, x_min, step) for pieces.build's curvature-continuous corner
    blends: the smallest acceleration limit and the curvature terms' jerk share, the lowest
    cap on v^2 at which crossing such a blend beats stopping at the corner (G2_BLEND_MIN_X
    ramp_x), and what a circular blend's curvature step 1/R allows, v^2 / R <= J T /
    STEP_JERK_SHARE (sample_caps). None in trapezoid mode (circular blends)."""
    if j_max is None:
        return None
    j = float(j_max.min())
    return (float(a_max.min()), RATE_OVER_STEP * j, G2_BLEND_MIN_X * ramp_x(a_max, j_max),
            j * period_s / STEP_JERK_SHARE)


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


def step_caps(s: np.ndarray, kv: np.ndarray, edge: np.ndarray, j_max: np.ndarray, period_s: float) -> np.ndarray:
    """S-curve mode: cap on v^2 at each piece joint (samples edge, edge + 1) where the
    curvature vector steps by dk: v^2 |dk_i| <= J_i T / STEP_JERK_SHARE. A piece shorter than
    a period between two joints (a polyline's micron remnant of a straight between two
    blends) is a pulse of the acceleration, not two steps: of height v^2 |dk_i| for delta / v,
    it shows in the third difference as at most v |dk_i| delta / T^2 (the quadratic
    B-spline's slope is at most 1 / T), so v |dk_i| delta <= J_i T^2, with the net step across
    the piece held like a step."""
    with np.errstate(divide="ignore", invalid="ignore"):
        dk = np.abs(kv[edge + 1] - kv[edge])
        x_step = np.min(j_max[None, :] * period_s / (STEP_JERK_SHARE * dk), axis=1)
        if len(edge) < 2:
            return x_step
        a, b = edge[:-1], edge[1:]  # the piece between joints a and b spans samples a + 1 .. b
        delta = s[b] - s[a + 1]
        net = np.abs(kv[b + 1] - kv[a])
        height = np.maximum(dk[:-1], dk[1:])
        x_pulse = np.min((j_max[None, :] * period_s**2 / (height * delta[:, None])) ** 2, axis=1)
        x_pair = np.minimum(x_pulse, np.min(j_max[None, :] * period_s / (STEP_JERK_SHARE * net), axis=1))
    pulse = delta < np.sqrt(np.minimum(x_pair, 1e300)) * period_s
    out = x_step.copy()
    lifted = np.full(len(edge), np.inf)  # an edge between two short pieces takes the lower pair cap
    lifted[:-1] = np.where(pulse, x_pair, np.inf)
    lifted[1:] = np.minimum(lifted[1:], np.where(pulse, x_pair, np.inf))
    in_pair = np.zeros(len(edge), bool)
    in_pair[:-1] |= pulse
    in_pair[1:] |= pulse
    out[in_pair] = lifted[in_pair]
    return out


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
    geo = SampleGeometry(smp.s, smp.t, smp.kv, smp.piece)
    rule = CapRule(v_max, a_max, (1.0 - CORNER_SHARE) * a_max * period_s, NEGLIGIBLE_STEP * room, period_s, delta_mm,
                   delta_mm**2)
    x_axis, x_curv, x_corner, corner, edge, sharp = geometric_caps(geo, pc.corner_tol_mm, rule)
    if j_max is not None:
        x_jerk = np.where(sharp, 0.0, step_caps(smp.s, smp.kv, edge, j_max, period_s))
        x_corner[edge] = np.minimum(x_corner[edge], x_jerk)
        x_corner[edge + 1] = np.minimum(x_corner[edge + 1], x_jerk)
        # the centripetal acceleration turns with the tangent: its rate is v^3 kappa^2
        kappa = np.linalg.norm(smp.kv, axis=1)
        j_rate = RATE_OVER_STEP * j_max
        with np.errstate(divide="ignore"):
            x_corner = np.minimum(x_corner, (j_rate.min() / kappa**2) ** (2.0 / 3.0))
        x_corner = np.minimum(x_corner, curvature_rate_cap(smp.s, smp.kv, smp.piece, j_rate))
    rows = [x_axis, x_curv, x_corner, x_corner]  # row 3: the chord cap, filled in by combined_caps
    codes = [LIMIT_AXIS, LIMIT_CURVATURE, LIMIT_CURVATURE, LIMIT_CHORD]
    if finishing is not None:
        r, pick, target, flutes = finishing
        rpm = pc.rpm[smp.piece]
        active = ~pc.rapid[smp.piece] & (rpm > 0)
        f = roughness_feed_mm_s(r, pick, target, flutes, rpm, _least_inclination(smp.t)) * ROUGHNESS_USE
        rows.append(np.where(active, f**2, np.inf))
        codes.append(LIMIT_ROUGHNESS)
    cap, reason = combined_caps(geo, pc.stop_after, edge, np.vstack(rows), np.array(codes, np.int8), rule, LIMIT_DWELL)
    return cap, reason, corner
