"""Curvature-continuous (G2) corner blends between two lines, for S-curve mode.

A circular blend steps the curvature from 0 to 1/R where it meets a line, which the jerk
limit caps at v^2 / R <= J T: the machine crawls through it. This blend is a symmetric
quintic Bezier whose first three and last three control points lie on the two lines,

    P0 = V - d t1, P1 = V - C1 d t1, P2 = V - C2 d t1,  P3 = V + C2 d t2, P4 = V + C1 d t2, P5 = V + d t2

(V the corner, t1 / t2 the unit directions in and out, d the length it takes of each
line), so its curvature is 0 at both ends (C'' is parallel to C' there) and ramps up and
down inside, where the planner's curvature caps see it as a smooth curve. C1, C2: a grid
search for the highest corner speed under v^2 kappa <= A, v^3 kappa^2 <= J and
v^3 |dkappa/ds| <= J gave C1 = 0.6, C2 = 0.15 to 0.35 at 30 and 90 degrees; of those and
their neighbours (C1 0.4 to 0.65, C2 0.1 to 0.3), 0.55 / 0.2 ran g1_lhchips4 fastest in
S-curve mode (409 s against 429 s for 0.6 / 0.25 and 432 s for 0.5 / 0.1, measured with every
line-line corner a candidate, chained arcs included).
By symmetry the point nearest V is C(1/2), at d K sin(theta / 2) / 16 from it with
K = 1 + 5 C1 + 10 C2 (the Bernstein weights 1, 5, 10 / 32 of each side's points).
"""
from __future__ import annotations

from functools import cache
from math import comb

import numpy as np

C1, C2 = 0.55, 0.2
_K = 1.0 + 5.0 * C1 + 10.0 * C2
BEZIER5_KNOTS = np.array([0.0] * 6 + [1.0] * 6)  # one quintic Bezier span
# a straight shorter than this share of its move between two arcs counts as none: a polyline's
# rounded coordinates leave micron gaps (circle360: 0.1745 mm moves differing by 1.7 um)
_CHAIN_GAP_SHARE = 0.01


def g2_reach_mm(theta: np.ndarray, tol_mm: np.ndarray, avail_mm: np.ndarray) -> np.ndarray:
    """Length d the blend takes of each line: its deviation from the corner,
    d K sin(theta / 2) / 16, within tol_mm, and d within avail_mm."""
    return np.minimum(avail_mm, 16.0 * tol_mm / (_K * np.sin(0.5 * theta)))


def g2_control_points(vertex: np.ndarray, t1: np.ndarray, t2: np.ndarray, d: float) -> np.ndarray:
    """The six control points (6, 3) of the blend at corner `vertex` between unit
    directions t1 (in) and t2 (out), taking d of each line."""
    return np.array([vertex - d * t1, vertex - C1 * d * t1, vertex - C2 * d * t1,
                     vertex + C2 * d * t2, vertex + C1 * d * t2, vertex + d * t2])


def _shape_factors(theta: np.ndarray, n: int = 2001) -> tuple[np.ndarray, np.ndarray]:
    """Peak curvature times d and peak |dkappa/ds| times d^2 of the blend of d = 1 at each
    corner angle theta (the shape only depends on theta), from n samples of the planar curve."""
    u = np.linspace(0.0, 1.0, n)
    bern = [np.array([comb(m, i) * u**i * (1 - u) ** (m - i) for i in range(m + 1)]) for m in (4, 3)]
    k_d, dk_d2 = np.empty(len(theta)), np.empty(len(theta))
    for i, th in enumerate(theta):
        ctrl = g2_control_points(np.zeros(3), np.array([1.0, 0, 0]), np.array([np.cos(th), np.sin(th), 0]), 1.0)
        q1 = 5 * np.diff(ctrl, axis=0)
        d1, d2 = bern[0].T @ q1, bern[1].T @ (4 * np.diff(q1, axis=0))
        speed = np.linalg.norm(d1, axis=1)
        kappa = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed**3
        s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(u))])
        k_d[i], dk_d2[i] = kappa.max(), np.max(np.abs(np.diff(kappa)) / np.diff(s))
    return k_d, dk_d2


_THETA_GRID = np.linspace(1e-3, np.pi - 1e-3, 360)


@cache
def _shape_table() -> tuple[np.ndarray, np.ndarray]:
    """_shape_factors on _THETA_GRID, made on first use (S-curve mode), not at every start-up."""
    return _shape_factors(_THETA_GRID)


def g2_corner_x(theta: np.ndarray, d_mm: np.ndarray, a_mm_s2: float, j_mm_s3: float) -> np.ndarray:
    """Cap on v^2 inside the blend from its peak curvature kappa and curvature rate kappa':
    v^2 kappa <= a, v^3 kappa^2 <= j (the centripetal acceleration turning with the tangent)
    and v^3 kappa' <= j (limits.sample_caps' S-curve caps)."""
    with np.errstate(divide="ignore"):  # d = 0 where no blend fits: cap 0
        k_d, dk_d2 = _shape_table()
        kappa = np.interp(theta, _THETA_GRID, k_d) / d_mm
        rate = np.interp(theta, _THETA_GRID, dk_d2) / d_mm**2
        return np.minimum(a_mm_s2 / kappa, np.minimum((j_mm_s3 / kappa**2), j_mm_s3 / rate) ** (2.0 / 3.0))


def arc_blend_x(radius_mm: np.ndarray, kappa_step: np.ndarray, a_mm_s2: float, j_mm_s3: float,
                step_mm_s2: float) -> np.ndarray:
    """The same caps for a circular blend of radius R: v^2 / R <= a, v^3 / R^2 <= j, and its
    curvature steps kappa_step (1/R where it meets a line) at its ends,
    v^2 kappa_step <= step_mm_s2 (limits.STEP_JERK_SHARE)."""
    with np.errstate(divide="ignore"):
        return np.minimum(np.minimum(a_mm_s2 * radius_mm, step_mm_s2 / kappa_step),
                          (j_mm_s3 * radius_mm**2) ** (2.0 / 3.0))


def g2_corners(theta: np.ndarray, tol_mm: np.ndarray, avail_mm: np.ndarray, arc_radius_mm: np.ndarray,
               arc_ok: np.ndarray, length_mm: np.ndarray, lead_trim_mm: float, tail_trim_mm: float,
               limits: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which of the J corners between J + 1 moves (of lengths length_mm) take the quintic,
    its reach d (g2_reach_mm) and the cap on v^2 of the blend each corner takes (0 where it
    stops); lead_trim_mm / tail_trim_mm are what blends outside
    take of the first / last move. Where its cap (g2_corner_x) is at least x_min, the cap
    below which stopping is faster, and at least the circular blend's (arc_blend_x; 0 where
    arc_ok is False: that corner would stop). limits = (a, j, x_min, step) as from
    ipo.feed.limits.g2_blend_limits. An arc that meets another arc with no straight left between
    them (a polyline along a curve, blends filling half of each short move) steps the
    curvature there only by the difference of the two (the held-back last move's next arc is
    taken as the same): a chain of quintics, whose curvature returns to 0 at every join,
    would be slower. Decided twice, the second time with the first's quintics as neighbours."""
    a, j, x_min, step = limits
    d = g2_reach_mm(theta, tol_mm, avail_mm)
    x_g2 = g2_corner_x(theta, d, a, j)
    d_arc = np.where(arc_ok, arc_radius_mm * np.tan(0.5 * theta), 0.0)
    with np.errstate(divide="ignore"):
        kappa_arc = np.where(arc_ok, 1.0 / arc_radius_mm, 0.0)
    g2 = np.zeros(len(theta), bool)
    for _ in range(2):
        reach, kappa = np.where(g2, d, d_arc), np.where(g2, 0.0, kappa_arc)  # a quintic ends flat
        rest = length_mm - np.concatenate([[lead_trim_mm], reach]) - np.concatenate([reach, [tail_trim_mm]])
        gap = rest <= _CHAIN_GAP_SHARE * length_mm
        before = np.concatenate([[np.nan], kappa[:-1]])
        after = np.concatenate([kappa[1:], [kappa[-1] if tail_trim_mm > 0 else np.nan]])
        steps = [np.where(g & (k > 0), np.abs(kappa_arc - k), kappa_arc)
                 for g, k in ((gap[:-1], before), (gap[1:], after))]
        x_arc = np.where(arc_ok, arc_blend_x(arc_radius_mm, np.maximum(*steps), a, j, step), 0.0)
        g2 = x_g2 >= np.maximum(x_min, x_arc)
    return g2, d, np.where(g2, x_g2, x_arc)
