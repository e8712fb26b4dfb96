"""Curvature-continuous chains through runs of short lines, for S-curve mode.

A CAM polyline along a curve (g1_lhchips4: 0.3 mm moves turning by 3 degrees each) blended corner by
corner returns its curvature to 0 at every move (the line-line quintic ends flat,
ipo.feed.blends.curvature_continuous) or steps it where two circular blends of different radius
meet: the jerk limit's caps on the curvature's rate of change, v^3 |dk/ds|, and on its steps,
v^2 |dk| <= J T / STEP_JERK_SHARE, then hold the machine far below the curve's own v^2 kappa <= A.

Here each corner of such a run (turns below CHAIN_MAX_RAD) is replaced by the G2 Hermite quintic
(ipo.feed.blends.g2_joints.hermite_quintic) from the midpoint of the move before it to the midpoint
of the move after it, both as the run's smoothing fit within P moved them, with its tangents there
(ipo.feed.blends.chain_fit), and every such midpoint gets one curvature vector, shared by the two
quintics that meet there, fitted over the run (_midpoint_curvatures; about 1 / R on a polyline
inscribed in a circle of radius R). The run becomes one curve whose curvature follows the fitted
polyline's, continuous and without a return to 0 at each move. A midpoint next to a corner outside
the run (or on a move whose other corner is not known yet, the window's held-back move) keeps its
place and gets curvature 0, as the line-line quintic ends, so the run meets whatever blends its
ends.

A run is chained where one of its corners' own blends holds the machine below the programmed feed
(chain_runs). A corner stays in it only while its quintic keeps within P of the programmed corner
(both ways, by distance between polylines) and its caps (peak curvature, v^3 kappa^2,
v^3 |dkappa/ds|, as g2_joints.quintic_x) beat a stop at the corner; dropping one changes the run's
midpoints, so the check repeats until none drops. Against each corner's own blend the chain is not
compared one by one: its worth is the run's (a per-corner comparison with the arc or line-line
quintic dropped more corners and ran g1_lhchips4's first 3000 lines 64.22 s against 63.81 s).
"""
from __future__ import annotations

from math import sqrt

import numpy as np
from numba import njit

from ipo.feed.blends.chain_fit import FIT_SHARE, SMOOTH_MM, fitted_midpoints
from ipo.segments import segment_distance

_CURVE_POINTS = 65  # points of each quintic checked against the corner's two half moves, and its caps read from
_SIDE_POINTS = 17  # points of each half move checked against the quintic
# the weight of the change of curvature against the turn's in the midpoint curvatures: of 0, 1/50,
# 1/16, 1/4, 1 and 4 (with weights 1, 1/l and 1/l^2), 1/16 with 1/l^2 ran g1_lhchips4's first 3000
# lines fastest (63.81 s; the central difference of the tangents 65.34 s, 0 went 72.46 s)
_MU2 = 1.0 / 16.0
_SEARCH = 12  # chords either side of the last nearest one searched for the next side point
CHAIN_MAX_RAD = np.radians(30.0)  # sharper corners end a run (g1_lhchips4's first 3000 lines: 63.52 s
# for 10 degrees, 63.36 for 20 and 30, 63.81 for 90; finish_g01's 90-degree raster ends would join)
_TOL_USE = 0.99  # the sampled deviation is kept this far within P
_BOUND_SLACK = 1e-12  # relative to the coordinates: far above the rounding of a distance


@njit(cache=True)
def _bezier5(ctrl, u, out_p, out_d1, out_d2):
    """Point, first and second derivative of the quintic Bezier ctrl (6, 3) at u (de Casteljau's
    differences: C' = 5 sum B4_i dP_i, C'' = 20 sum B3_i d2P_i)."""
    v = 1.0 - u
    b5 = (v**5, 5 * u * v**4, 10 * u**2 * v**3, 10 * u**3 * v**2, 5 * u**4 * v, u**5)
    b4 = (v**4, 4 * u * v**3, 6 * u**2 * v**2, 4 * u**3 * v, u**4)
    b3 = (v**3, 3 * u * v**2, 3 * u**2 * v, u**3)
    for a in range(3):
        p = 0.0
        for i in range(6):
            p += b5[i] * ctrl[i, a]
        d1 = 0.0
        for i in range(5):
            d1 += b4[i] * (ctrl[i + 1, a] - ctrl[i, a])
        d2 = 0.0
        for i in range(4):
            d2 += b3[i] * (ctrl[i + 2, a] - 2 * ctrl[i + 1, a] + ctrl[i, a])
        out_p[a], out_d1[a], out_d2[a] = p, 5 * d1, 20 * d2


@njit(cache=True)
def _hermite(p_a, t_a, k_a, p_b, t_b, k_b, ctrl):
    """g2_joints.hermite_quintic into ctrl (6, 3)."""
    h = sqrt((p_b[0] - p_a[0]) ** 2 + (p_b[1] - p_a[1]) ** 2 + (p_b[2] - p_a[2]) ** 2)
    for a in range(3):
        p1 = p_a[a] + h * t_a[a] / 5.0
        p4 = p_b[a] - h * t_b[a] / 5.0
        ctrl[0, a], ctrl[1, a], ctrl[4, a], ctrl[5, a] = p_a[a], p1, p4, p_b[a]
        ctrl[2, a] = 2.0 * p1 - p_a[a] + h * h * k_a[a] / 20.0
        ctrl[3, a] = 2.0 * p4 - p_b[a] + h * h * k_b[a] / 20.0


@njit(cache=True)
def _joint(ctrl, p_a, vertex, p_b, tol, a_lim, j_lim):
    """The cap on v^2 of the quintic ctrl (v^2 kappa <= a_lim, v^3 kappa^2 <= j_lim,
    v^3 |dkappa/ds| <= j_lim, kappa and its rate from _CURVE_POINTS samples), or -1 where it
    leaves P of the corner p_a - vertex - p_b (either way) or its derivative vanishes."""
    pts = np.empty((_CURVE_POINTS, 3))
    p, d1, d2 = np.empty(3), np.empty(3), np.empty(3)
    k_max, rate, k_prev, s_prev = 0.0, 0.0, 0.0, 0.0
    for m in range(_CURVE_POINTS):
        _bezier5(ctrl, m / (_CURVE_POINTS - 1), p, d1, d2)
        pts[m] = p
        if min(segment_distance(p, p_a, vertex), segment_distance(p, vertex, p_b)) > _TOL_USE * tol:
            return -1.0
        speed = sqrt(d1[0] ** 2 + d1[1] ** 2 + d1[2] ** 2)
        if not speed > 0:
            return -1.0
        c0 = d1[1] * d2[2] - d1[2] * d2[1]
        c1 = d1[2] * d2[0] - d1[0] * d2[2]
        c2 = d1[0] * d2[1] - d1[1] * d2[0]
        kappa = sqrt(c0 * c0 + c1 * c1 + c2 * c2) / speed**3
        if m > 0:
            rate = max(rate, abs(kappa - k_prev) / (0.5 * (speed + s_prev) / (_CURVE_POINTS - 1)))
        k_max, k_prev, s_prev = max(k_max, kappa), kappa, speed
    # the half moves against the quintic's polyline: both run along the corner, so each point's
    # nearest chord lies next to the last one's (a chord missed only overstates the distance)
    chord = np.empty(_CURVE_POINTS - 1)
    size = 0.0  # the largest coordinate: the scale of the rounding
    for i in range(_CURVE_POINTS - 1):
        chord[i] = sqrt((pts[i + 1, 0] - pts[i, 0]) ** 2 + (pts[i + 1, 1] - pts[i, 1]) ** 2
                        + (pts[i + 1, 2] - pts[i, 2]) ** 2)
    for i in range(_CURVE_POINTS):
        size = max(size, abs(pts[i, 0]), abs(pts[i, 1]), abs(pts[i, 2]))
    q = np.empty(3)
    near = 0
    for side in range(2):
        a, b = (p_a, vertex) if side == 0 else (vertex, p_b)
        for m in range(1, _SIDE_POINTS):
            f = m / (_SIDE_POINTS - 1)
            for c in range(3):
                q[c] = a[c] + f * (b[c] - a[c])
            near, best = _nearest_chord(q, pts, chord, near, size)
            if best > _TOL_USE * tol:
                return -1.0
    x = np.inf
    if k_max > 0:
        x = min(a_lim / k_max, (j_lim / (k_max * k_max)) ** (2.0 / 3.0))
    if rate > 0:
        x = min(x, (j_lim / rate) ** (2.0 / 3.0))
    return x


@njit(cache=True)
def _nearest_chord(q, pts, chord, near, size):
    """The first of the chords pts[i]-pts[i + 1] within _SEARCH of chord `near` nearest to q, and
    its distance (inf if none is a number). Chord i is no nearer than |q - pts[i]| - chord[i]; where
    that is farther than the chord `near` or the nearest so far (beyond the rounding of either),
    it is not measured: the same chord and distance as measuring all, in a fraction of the time."""
    bound = segment_distance(q, pts[near], pts[near + 1])
    margin = _BOUND_SLACK * (1.0 + size + abs(q[0]) + abs(q[1]) + abs(q[2]))
    best = np.inf
    for i in range(max(near - _SEARCH, 0), min(near + _SEARCH, _CURVE_POINTS - 1)):
        reach = min(best, bound) + chord[i] + margin
        if (q[0] - pts[i, 0]) ** 2 + (q[1] - pts[i, 1]) ** 2 + (q[2] - pts[i, 2]) ** 2 > reach * reach:
            continue
        dist = segment_distance(q, pts[i], pts[i + 1])
        if dist < best:
            best, near = dist, i
    return near, best


@njit(cache=True)
def _midpoint_curvatures(unit, length, chain):
    """The curvature vector k_m at the midpoint of each move m between two corners of the run
    `chain` (0 elsewhere), by least squares over the run:

        min sum_j ((k_j + k_(j+1)) / 2 - c_j)^2 / l_j^2 + MU2 (k_(j+1) - k_j)^2 / l_j^2

    over its corners j, c_j = (t_(j+1) - t_j) / l_j the corner's turn over l_j = (L_j + L_(j+1)) / 2.
    The first term is the quintic's mean curvature against the turn it must make (a mismatch
    bulges its curvature), the second the change of curvature across it; both divided by the
    quintic's length, as rates of change are. The normal equations are tridiagonal (Thomas's
    algorithm); each k_m then loses its part along t_m."""
    n = length.shape[0]
    diag, off, rhs = np.ones(n), np.zeros(n), np.zeros((n, 3))
    free = np.zeros(n, np.bool_)
    for m in range(1, n - 1):
        free[m] = chain[m - 1] and chain[m]
    for m in range(n):
        if free[m]:
            diag[m] = 0.0
    for j in range(n - 1):
        if not chain[j]:
            continue
        ell = 0.5 * (length[j] + length[j + 1])
        w = 1.0 / (ell * ell)
        for m in (j, j + 1):
            if free[m]:
                diag[m] += w * (0.5 + 2 * _MU2)
                for a in range(3):
                    rhs[m, a] += w * (unit[j + 1, a] - unit[j, a]) / ell
        if free[j] and free[j + 1]:
            off[j] += w * (0.5 - 2 * _MU2)
    cp = np.zeros(n)
    dp = np.zeros((n, 3))
    for m in range(n):
        sub = off[m - 1] if m > 0 else 0.0
        den = diag[m] - (sub * cp[m - 1] if m > 0 else 0.0)
        cp[m] = off[m] / den
        for a in range(3):
            dp[m, a] = (rhs[m, a] - (sub * dp[m - 1, a] if m > 0 else 0.0)) / den
    k = np.zeros((n, 3))
    for m in range(n - 1, -1, -1):
        for a in range(3):
            k[m, a] = dp[m, a] - (cp[m] * k[m + 1, a] if m < n - 1 else 0.0)
    for m in range(n):
        if not free[m]:
            k[m] = 0.0
            continue
        dot = k[m, 0] * unit[m, 0] + k[m, 1] * unit[m, 1] + k[m, 2] * unit[m, 2]
        for a in range(3):
            k[m, a] -= dot * unit[m, a]
    return k


@njit(cache=True)
def _check(start, unit, length, mid, tangent, chain, tol, a_lim, j_lim, ctrl, x):
    """Midpoint curvatures of the run `chain` (corner j joins moves j and j + 1) from the fitted
    midpoints' tangents (ipo.feed.blends.chain_fit) and each chain corner's quintic, from fitted
    midpoint to midpoint, into ctrl (J, 6, 3), and its cap into x (-1: outside P of the
    programmed corner)."""
    n = length.shape[0]
    kmid = _midpoint_curvatures(tangent, length, chain)
    p_a, p_b, vertex = np.empty(3), np.empty(3), np.empty(3)
    for j in range(n - 1):
        if not chain[j]:
            continue
        _hermite(mid[j], tangent[j], kmid[j], mid[j + 1], tangent[j + 1], kmid[j + 1], ctrl[j])
        for a in range(3):
            vertex[a] = start[j + 1, a]
            p_a[a] = vertex[a] - 0.5 * length[j] * unit[j, a]
            p_b[a] = vertex[a] + 0.5 * length[j + 1] * unit[j + 1, a]
        x[j] = _joint(ctrl[j], p_a, vertex, p_b, tol[j], a_lim, j_lim)


def chain_runs(small: np.ndarray, slow: np.ndarray) -> np.ndarray:
    """The corners of every maximal run of `small` corners (J,) that holds a `slow` one: a corner
    whose own blend holds the machine below the programmed feed. A run stays whole, since a
    chain that meets an arc blend midway steps the curvature there (0 to 1 / R): on circle360,
    chaining only its slow first and last corners and their neighbours ran 1.386 s, against
    1.350 s for none and 1.334 s for the whole run."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], small.astype(np.int8), [0]])))
    out = np.zeros(len(small), bool)
    for a, b in zip(edges[::2], edges[1::2]):
        out[a:b] = slow[a:b].any()
    return out


def g2_chains(start: np.ndarray, unit: np.ndarray, length: np.ndarray, candidate: np.ndarray, tol_mm: np.ndarray,
              limits: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Which of the J corners between J + 1 lines (start points, unit directions, lengths) join a
    run, from the candidates (chain_runs), and the control points (J, 6, 3) of their quintics;
    limits = (a, j, x_min, step) as ipo.feed.limits.g2_blend_limits gives them: each quintic's cap
    must reach x_min, below which a stop at the corner is faster."""
    a_mm_s2, j_mm_s3, x_min, _ = limits
    chain = candidate.copy()
    ctrl = np.zeros((len(chain), 6, 3))
    x = np.full(len(chain), -1.0)
    while True:  # each round drops at least one corner
        mid, tangent = fitted_midpoints(start, unit, length, chain, tol_mm, FIT_SHARE, SMOOTH_MM**6)
        _check(start, unit, length, mid, tangent, chain, tol_mm, a_mm_s2, j_mm_s3, ctrl, x)
        drop = chain & ~(x >= x_min)
        if not drop.any():
            return chain, ctrl
        chain &= ~drop
