"""Three-vectors as tuples of floats: the arithmetic of LinuxCNC's posemath (PmCartesian).

The twin plans one segment at a time, a few dozen vector operations each; plain tuples are
faster than small numpy arrays for that and keep the port close to the C it follows.
"""
from __future__ import annotations

import math

Vec = tuple[float, float, float]
DOUBLE_FUZZ = 2.2204460492503131e-16
CART_FUZZ = 1.0e-8  # posemath's "zero" for coordinates (the canon layer's too)


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a: Vec, k: float) -> Vec:
    return (a[0] * k, a[1] * k, a[2] * k)


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def mag(a: Vec) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def mag_sq(a: Vec) -> float:
    return a[0] * a[0] + a[1] * a[1] + a[2] * a[2]


def unit(a: Vec) -> Vec:
    """a / |a|; posemath leaves the zero vector as it is."""
    m = mag(a)
    if m == 0.0:
        return a
    return (a[0] / m, a[1] / m, a[2] / m)


def abs_max(a: Vec) -> float:
    return max(abs(a[0]), abs(a[1]), abs(a[2]))


def plane_proj(v: Vec, normal: Vec) -> Vec:
    """v without its component along the unit normal (pmCartPlaneProj)."""
    return sub(v, scale(normal, dot(v, normal)))


def parallel(u1: Vec, u2: Vec, tol_sq: float) -> bool:
    return mag_sq(sub(u1, u2)) < tol_sq


def anti_parallel(u1: Vec, u2: Vec, tol_sq: float) -> bool:
    return mag_sq(add(u1, u2)) < tol_sq


def colinear(u1: Vec, u2: Vec) -> bool:
    """Unit vectors along one line, either way (blendmath.c pmUnitCartsColinear)."""
    eps_sq = 1e-6 ** 2
    return parallel(u1, u2, eps_sq) or anti_parallel(u1, u2, eps_sq)
