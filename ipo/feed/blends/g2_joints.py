"""Curvature-continuous (G2) joints next to arcs and NURBS, for S-curve mode.

Where a line meets an arc, an arc another arc or a NURBS anything -- tangentially or at a
corner -- the curvature steps: from 0 to 1/R where a line runs into an arc, and at both
ends of the cubic that blends a corner (ipo.feed.pieces). The jerk limit holds such a step
to v^2 |dk| <= J T / STEP_JERK_SHARE (ipo.feed.limits.step_caps): R = 5 mm lead-in arcs at
J = 1e5 mm/s^3 and T = 1 ms cross their ends at 26 mm/s where the arcs allow 70.

This joint trims the move before it by d_a and the one after it by d_b (arc length) and
joins the two trimmed ends with the quintic Bezier that matches point, unit tangent and
curvature vector at both (G2 Hermite interpolation): with h the chord between the ends,
C'(0) = h t_a, C''(0) = h^2 k_a (k_a perpendicular to t_a, so the curvature there is k_a)
and the same at u = 1,

    P1 = P0 + h t_a / 5, P2 = 2 P1 - P0 + h^2 k_a / 20, P4 = P5 - h t_b / 5, P3 = 2 P4 - P5 + h^2 k_b / 20

(the Bernstein form's end derivatives, C'(0) = 5 (P1 - P0), C''(0) = 20 (P2 - 2 P1 + P0)).
The derivative scale h (the chord) gave the lowest peak |dkappa/ds| of the scales 0.8 to
1.5 h on line-arc joints, within 2.3x of a clothoid's constant rate over the same length.

d_a and d_b grow together (each up to its move's reach) to the largest that keeps the
quintic within P of the programmed path (ipo.feed.blends.curve_corner.deviation): the
longer the joint, the gentler its curvature ramp. A corner between moves of uneven reach
also tries the shorter one whole with only the longer one shrunk, and keeps the faster
(g1_lhchips4's lead-out arcs meet 0.3 mm polyline moves: 1.2 % off its first 400 lines' cycle). It is taken only where its cap on v^2
beats the alternative: at a tangent joint the curvature step's cap, at a corner the stop
(x_min) and the cubic's cap (its steps and its peak curvature).
"""
from __future__ import annotations

from math import comb

import numpy as np

from ipo.feed.blends.compiled import bezier_frame
from ipo.feed.blends.curvature_continuous import arc_blend_x, g2_corner_x, g2_reach_mm
from ipo.feed.blends.curve_corner import Side, deviation

_CHECK = 65  # points checked along the quintic for its deviation
_CAP_SAMPLES = 257  # points of the quintic its curvature caps are read from
_TRIES = 12  # shrinks of the joint's reach before it is given up
_UNEVEN = 2.0  # a corner whose moves' reaches differ more than this also tries the short one whole
_TOL_USE = 0.99  # the sampled deviation is kept this far within P (the samples miss a hair between them)
_SAGITTA_SHARE = 0.002  # of P: how far the moves' checking polylines may cut inside their curves
_SIDE_POINTS_MIN, _SIDE_POINTS_MAX = 65, 4097
_U_CHECK = np.linspace(0.0, 1.0, _CHECK)
_BERNSTEIN = np.array([[comb(5, i) * u**i * (1 - u) ** (5 - i) for i in range(6)] for u in _U_CHECK])
# the quintic as a polyline the moves' points are measured against, both ways within P (chords this
# short cut a hair inside it: the sagitta of 1/256 of a joint bent by at most a radian or so)
_BERNSTEIN_FINE = np.array([[comb(5, i) * u**i * (1 - u) ** (5 - i) for i in range(6)] for u in np.linspace(0, 1, 257)])


def hermite_quintic(p_a, t_a, k_a, p_b, t_b, k_b) -> np.ndarray:
    """Control points (6, 3) of the quintic from p_a to p_b with unit tangents t_a, t_b and
    curvature vectors k_a, k_b at its ends."""
    h = float(np.linalg.norm(p_b - p_a))
    p1, p4 = p_a + h * t_a / 5.0, p_b - h * t_b / 5.0
    return np.array([p_a, p1, 2.0 * p1 - p_a + h * h * k_a / 20.0, 2.0 * p4 - p_b + h * h * k_b / 20.0, p4, p_b])


def quintic_x(ctrl: np.ndarray, a_mm_s2: float, j_mm_s3: float) -> float:
    """Cap on v^2 along the quintic from its sampled curvature kappa and curvature rate
    kappa': v^2 kappa <= a, v^3 kappa^2 <= j, v^3 kappa' <= j (as g2_corner_x has them for
    the line-line quintic); 0 where its derivative vanishes."""
    speed, _, kv, ok = bezier_frame(ctrl, np.linspace(0.0, 1.0, _CAP_SAMPLES))
    if not ok:
        return 0.0
    kappa = np.linalg.norm(kv, axis=1)
    ds = 0.5 * (speed[1:] + speed[:-1]) / (_CAP_SAMPLES - 1)
    rate = float(np.max(np.abs(np.diff(kappa)) / ds))
    k_max = float(kappa.max())
    with np.errstate(divide="ignore"):
        return float(min(a_mm_s2 / k_max, (j_mm_s3 / k_max**2) ** (2.0 / 3.0), (j_mm_s3 / rate) ** (2.0 / 3.0)))


def _sized(before: Side, after: Side, corner: np.ndarray, tol_mm: float, reach_a: float, reach_b: float,
           shrink_a: bool = True, shrink_b: bool = True) -> tuple[float, float, np.ndarray] | None:
    """(d_a, d_b, control points) of a long joint within tol_mm: the reaches (those with
    shrink_a / shrink_b) scaled by one factor, from 1 down by the ratio of the deviation to P
    (the deviation grows about linearly with the scale at a corner, quadratically at a
    tangent joint: the square root of the ratio undershoots neither); None where _TRIES
    shrinks find none."""
    scale = 1.0
    curvature_a, curvature_b = np.linalg.norm(before.kv(0.0)), np.linalg.norm(after.kv(0.0))
    for _ in range(_TRIES):
        d_a, d_b = (scale if shrink_a else 1.0) * reach_a, (scale if shrink_b else 1.0) * reach_b
        p_a, t_a = before.at(d_a)
        p_b, t_b = after.at(d_b)
        k_a, k_b = before.kv(d_a), after.kv(d_b)
        ctrl = hermite_quintic(p_a, t_a, k_a, p_b, t_b, k_b)
        # the moves as polylines whose chords' sagitta k c^2 / 8 stays within _SAGITTA_SHARE P
        chords = max(d_a * np.sqrt(max(curvature_a, np.linalg.norm(k_a)) / (8.0 * _SAGITTA_SHARE * tol_mm)),
                     d_b * np.sqrt(max(curvature_b, np.linalg.norm(k_b)) / (8.0 * _SAGITTA_SHARE * tol_mm)))
        over = deviation(_BERNSTEIN @ ctrl, before, after, d_a, d_b, corner,
                         int(np.clip(np.ceil(chords) + 1, _SIDE_POINTS_MIN, _SIDE_POINTS_MAX)),
                         _BERNSTEIN_FINE @ ctrl) / (_TOL_USE * tol_mm)
        if over <= 1.0:
            return d_a, d_b, ctrl
        scale *= min(0.95, 1.0 / np.sqrt(over))
    return None


def g2_joint(before: Side, after: Side, corner: np.ndarray, tol_mm: float, reach_a: float, reach_b: float,
             cubic_radius_mm: float | None, x_moves: float, limits: tuple[float, float, float, float]
             ) -> tuple[float, float, np.ndarray] | None:
    """(d_a, d_b, control points) of the G2 joint at `corner` between the moves `before` and
    `after` (Sides with kv), or None where it does not beat the alternative:
    cubic_radius_mm None for a tangent joint (crossed with its curvature step), else the
    corner's cubic blend radius (0: the corner stops). x_moves is the two moves' own cap on
    v^2 (feed, arcs' curvature), which bounds either way; limits = (a, j, x_min, step) as
    ipo.feed.limits.g2_blend_limits gives them."""
    a, j, x_min, step = limits
    k_a, k_b = before.kv(0.0), after.kv(0.0)
    longest = reach_a + reach_b
    if cubic_radius_mm is None:
        dk = float(np.linalg.norm(k_a - k_b))
        with np.errstate(divide="ignore"):
            x_alt = step / dk
            x_hope = (j * longest / dk) ** (2.0 / 3.0)  # the step spread evenly over the longest joint
    else:
        x_alt = x_min
        if cubic_radius_mm > 0:
            k_cubic = 1.0 / cubic_radius_mm
            dk = max(abs(k_cubic - np.linalg.norm(k_a)), abs(k_cubic - np.linalg.norm(k_b)))
            x_alt = max(x_min, float(arc_blend_x(np.array(cubic_radius_mm), np.array(dk), a, j, step)))
        # the line-line quintic of the same turn, twice as long as P lets it be: no joint does much better
        theta = np.arccos(np.clip(np.dot(before.at(0.0)[1], after.at(0.0)[1]), -1.0, 1.0))
        d_hope = np.minimum(0.5 * longest, 2.0 * g2_reach_mm(theta, tol_mm, np.inf))
        x_hope = float(g2_corner_x(np.array([theta]), np.array([d_hope]), a, j)[0])
    corner_stop = x_min if cubic_radius_mm is not None else 0.0  # a corner's joint must beat its stop
    if not (min(x_hope, x_moves) > min(x_alt, x_moves) and x_hope >= corner_stop):
        return None  # not worth sizing: the joint could not beat the alternative
    if cubic_radius_mm is not None:
        # no longer than twice the line-line quintic of the same turn within P: a longer corner
        # joint may bunch its turn near one end (a 2.6 mm joint from a line into an R 7.9 mm arc
        # under P = 0.2 peaked at 4.3 /mm, 16 /mm^2, and its run went 6 % over the jerk limit)
        reach_a, reach_b = min(reach_a, 2.0 * float(g2_reach_mm(theta, tol_mm, np.inf))), \
            min(reach_b, 2.0 * float(g2_reach_mm(theta, tol_mm, np.inf)))
    found = [_sized(before, after, corner, tol_mm, reach_a, reach_b)]
    if cubic_radius_mm is not None and max(reach_a, reach_b) > _UNEVEN * min(reach_a, reach_b):
        # next to a short move the common scale leaves most of the long one unused: the short
        # one at its whole reach, only the long one shrunk
        found.append(_sized(before, after, corner, tol_mm, reach_a, reach_b, reach_a > reach_b, reach_b > reach_a))
    found = [f for f in found if f is not None]
    if not found:
        return None
    x_g2, found = max(((quintic_x(f[2], a, j), f) for f in found), key=lambda c: c[0])
    return found if min(x_g2, x_moves) > min(x_alt, x_moves) and x_g2 >= corner_stop else None
