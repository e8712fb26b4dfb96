"""Feed limits at the path samples, as caps on x = v^2 (the phase-plane variable), each
with its reason code (ipo/contracts.py LIMIT_*).

All functions are pure and work on arrays of samples: unit tangent t (K, 3), curvature
vector kv = dt/ds (K, 3), per-axis limits V (3,) mm/s and A (3,) mm/s^2.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_AXIS, LIMIT_CHORD, LIMIT_CURVATURE, LIMIT_DWELL, LIMIT_ROUGHNESS
from ipo.roughness import inclination_rad, roughness_feed_mm_s

_TINY = 1e-12
# The roughness cap is planned a hair below its value: the profile meets it at samples and
# the per-period feed is a mean over the period, which may otherwise exceed it by ~1e-5.
ROUGHNESS_USE = 0.9999
# Share of each axis limit left for the path acceleration next to an unblended corner,
# whose own velocity step takes the rest within one period (corner_cap).
CORNER_SHARE = 0.5
# A tangent step below this share of an axis's per-period velocity change is no corner.
NEGLIGIBLE_STEP = 0.005
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


def axis_velocity_cap(t: np.ndarray, v_max: np.ndarray) -> np.ndarray:
    """v |t_i| <= V_i on every axis."""
    with np.errstate(divide="ignore"):
        return np.min((v_max[None, :] / np.abs(t)) ** 2, axis=1)


def curvature_cap(t: np.ndarray, kv: np.ndarray, a_max: np.ndarray) -> np.ndarray:
    """Largest x for which some path acceleration s'' keeps every axis within its limit.

    Axis i needs |t_i s'' + kv_i x| <= A_i: an interval for s'' centred on -kv_i x / t_i
    with half-width A_i / |t_i|. All intervals meet iff every pair does, which bounds x
    pairwise; an axis with t_i = 0 needs |kv_i| x <= A_i on its own.
    """
    at = np.abs(t)
    moving = at > _TINY
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(moving, kv / np.where(moving, t, 1.0), 0.0)
        half = np.where(moving, a_max[None, :] / np.where(moving, at, 1.0), np.inf)
        cap = np.where(~moving & (np.abs(kv) > _TINY), a_max[None, :] / np.abs(kv), np.inf).min(axis=1)
        for i in range(3):
            for j in range(i + 1, 3):
                both = moving[:, i] & moving[:, j]
                gap = np.abs(ratio[:, i] - ratio[:, j])
                pair = np.where(both & (gap > _TINY), (half[:, i] + half[:, j]) / gap, np.inf)
                cap = np.minimum(cap, pair)
    return cap


@njit(cache=True)
def _window_max(s, kappa, reach):
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


def chord_cap(s: np.ndarray, kv: np.ndarray, delta_mm: float, period_s: float,
              x_other: np.ndarray) -> np.ndarray:
    """Chord error within delta for every chord a period can span.

    The formula V <= (2/T) sqrt(2 rho delta - delta^2) holds for a constant radius; on a
    real curve the chord spans varying curvature, so rho is taken as the smallest radius
    within one chord (at the speed the other limits allow) of the sample, iterated once
    with the reduced speed.
    """
    kappa = np.linalg.norm(kv, axis=1)
    reach = np.sqrt(np.minimum(x_other, 1e12)) * period_s
    cap = np.full(len(s), np.inf)
    for _ in range(2):
        k_eff = _window_max(s, kappa, reach)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = np.where(k_eff > _TINY, 1.0 / k_eff, np.inf)
            half = np.where(rho > delta_mm, 2 * rho * delta_mm - delta_mm**2, delta_mm**2)
            v = np.where(np.isfinite(rho), 2.0 / period_s * np.sqrt(half), np.inf)  # algorithms.md §6
        cap = v**2
        reach = np.sqrt(np.minimum(np.minimum(x_other, cap), 1e12)) * period_s
    return cap


def corner_cap(dt: np.ndarray, a_max: np.ndarray, period_s: float, tol_mm: np.ndarray) -> np.ndarray:
    """Speed cap at a corner crossed without a blend, with dt = t_out - t_in (J, 3).

    Crossing within one period changes each axis velocity by v |dt_i| over at most a
    period: v <= A_i T / (2 |dt_i|) leaves the other half of A_i for the path acceleration
    next to the corner (the planner halves it there). The period's chord cuts the corner by at most
    (v T / 2) sin(theta / 2) = v T |dt| / 4, kept within tol_mm.
    """
    with np.errstate(divide="ignore"):
        v_acc = np.min((1.0 - CORNER_SHARE) * a_max[None, :] * period_s / np.abs(dt), axis=1)
        v_cut = 4 * tol_mm / (period_s * np.linalg.norm(dt, axis=1))
    return np.minimum(v_acc, v_cut) ** 2


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


def _sharp(dt: np.ndarray, x_top: np.ndarray, a_max: np.ndarray, period_s: float,
           j_max: np.ndarray | None) -> np.ndarray:
    """Junctions whose tangent step dt (J, 3) matters: crossed at the top speed the other
    limits allow there (v^2 <= x_top), it steps some axis velocity by more than
    NEGLIGIBLE_STEP of what its acceleration (S-curve mode: its jerk) allows per period.
    Smaller steps (an arc's spiral term left out of its frame, float noise) fit in the
    planner's headroom below the limits."""
    step = np.sqrt(np.minimum(x_top, 1e300))[:, None] * np.abs(dt)
    room = a_max * period_s if j_max is None else np.minimum(a_max * period_s, j_max * period_s**2)
    return np.any(step > NEGLIGIBLE_STEP * room[None, :], axis=1)


def combine(caps: list[tuple[np.ndarray, int]]) -> tuple[np.ndarray, np.ndarray]:
    """Element-wise minimum of several caps and the reason code of the binding one."""
    stack = np.vstack([c for c, _ in caps])
    arg = np.argmin(stack, axis=0)
    codes = np.array([code for _, code in caps], dtype=np.int8)
    return stack[arg, np.arange(stack.shape[1])], codes[arg]


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
    x_axis = axis_velocity_cap(smp.t, v_max)
    x_curv = curvature_cap(smp.t, smp.kv, a_max)
    x_corner = np.full(len(smp), np.inf)
    edge = np.nonzero(smp.piece[1:] != smp.piece[:-1])[0]
    dt = smp.t[edge + 1] - smp.t[edge]
    sharp = _sharp(dt, np.minimum(np.minimum(x_axis, x_curv)[edge], np.minimum(x_axis, x_curv)[edge + 1]),
                   a_max, period_s, j_max)
    k = edge[sharp]
    tol = np.maximum(delta_mm, pc.corner_tol_mm[smp.piece[k]])
    c = corner_cap(dt[sharp], a_max, period_s, tol)
    x_corner[k] = c
    x_corner[k + 1] = c
    corner = np.zeros(len(smp), bool)
    corner[k] = corner[k + 1] = True
    # every interval touching a corner sample is planned with CORNER_SHARE of the axis
    # limits (lookahead.plan's ascale): its ends must be reachable within that share, or
    # the look-ahead finds no feasible path acceleration there
    near = corner.copy()
    near[1:] |= corner[:-1]
    near[:-1] |= corner[1:]
    if near.any():
        x_curv[near] = np.minimum(x_curv[near], curvature_cap(smp.t[near], smp.kv[near], CORNER_SHARE * a_max))
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
    caps = [(x_axis, LIMIT_AXIS), (x_curv, LIMIT_CURVATURE), (x_corner, LIMIT_CURVATURE)]
    x_chord = chord_cap(smp.s, smp.kv, delta_mm, period_s, combine(caps)[0])
    caps.append((x_chord, LIMIT_CHORD))
    if finishing is not None:
        r, pick, target, flutes = finishing
        rpm = pc.rpm[smp.piece]
        active = ~pc.rapid[smp.piece] & (rpm > 0)
        f = roughness_feed_mm_s(r, pick, target, flutes, rpm, _least_inclination(smp.t)) * ROUGHNESS_USE
        caps.append((np.where(active, f**2, np.inf), LIMIT_ROUGHNESS))
    cap, reason = combine(caps)
    last = np.concatenate([edge, [len(smp) - 1]])
    stops = last[pc.stop_after[smp.piece[last]]]
    cap[stops] = 0.0
    reason[stops] = LIMIT_DWELL
    nxt = stops[stops + 1 < len(smp)] + 1
    cap[nxt] = 0.0
    reason[nxt] = LIMIT_DWELL
    return cap, reason, corner
