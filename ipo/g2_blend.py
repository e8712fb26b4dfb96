"""Curvature-continuous (G2) corner blends between two lines, for S-curve mode.

A circular blend steps the curvature from 0 to 1/R where it meets a line, which the jerk
limit caps at v^2 / R <= J T: the machine crawls through it. This blend is a symmetric
quintic Bezier whose first three and last three control points lie on the two lines,

    P0 = V - d t1, P1 = V - C1 d t1, P2 = V - C2 d t1,  P3 = V + C2 d t2, P4 = V + C1 d t2, P5 = V + d t2

(V the corner, t1 / t2 the unit directions in and out, d the length it takes of each
line), so its curvature is 0 at both ends (C'' is parallel to C' there) and ramps up and
down inside, where the planner's curvature caps see it as a smooth curve. C1, C2 were
chosen by a grid search for the highest corner speed under v^2 kappa <= A,
v^3 kappa^2 <= J and v^3 |dkappa/ds| <= J at 30 and 90 degrees.
By symmetry the point nearest V is C(1/2), at d K sin(theta / 2) / 16 from it with
K = 1 + 5 C1 + 10 C2 (the Bernstein weights 1, 5, 10 / 32 of each side's points).
"""
from __future__ import annotations

from math import comb

import numpy as np

C1, C2 = 0.6, 0.25
_K = 1.0 + 5.0 * C1 + 10.0 * C2
BEZIER5_KNOTS = np.array([0.0] * 6 + [1.0] * 6)  # one quintic Bezier span


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
_K_D, _DK_D2 = _shape_factors(_THETA_GRID)


def g2_corner_x(theta: np.ndarray, d_mm: np.ndarray, a_mm_s2: float, j_mm_s3: float) -> np.ndarray:
    """Cap on v^2 inside the blend from its peak curvature kappa and curvature rate kappa':
    v^2 kappa <= a, v^3 kappa^2 <= j (the centripetal acceleration turning with the tangent)
    and v^3 kappa' <= j (limits.sample_caps' S-curve caps)."""
    with np.errstate(divide="ignore"):  # d = 0 where no blend fits: cap 0
        kappa = np.interp(theta, _THETA_GRID, _K_D) / d_mm
        rate = np.interp(theta, _THETA_GRID, _DK_D2) / d_mm**2
        return np.minimum(a_mm_s2 / kappa, np.minimum((j_mm_s3 / kappa**2), j_mm_s3 / rate) ** (2.0 / 3.0))


def arc_blend_x(radius_mm: np.ndarray, a_mm_s2: float, j_mm_s3: float, step_mm_s2: float) -> np.ndarray:
    """The same caps for a circular blend of radius R: v^2 / R <= a, v^3 / R^2 <= j, and its
    curvature steps where it meets a line, v^2 / R <= step_mm_s2 (limits.STEP_JERK_SHARE)."""
    with np.errstate(divide="ignore"):
        return np.minimum(np.minimum(a_mm_s2, step_mm_s2) * radius_mm, (j_mm_s3 * radius_mm**2) ** (2.0 / 3.0))
