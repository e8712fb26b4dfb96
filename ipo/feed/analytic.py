"""The analytic path pieces' geometry, compiled: points, tangents and curvature vectors by arc length.

Every analytic piece (a line, a G2/G3 arc or helix, a circular G64 blend; ipo.feed.pieces)
is p(sigma) = c + r(phi) (cos(phi) e1 + sin(phi) e2) + w sigma with phi = omega sigma and
r(phi) = radius + dr phi. The planner evaluates it at millions of samples and periods, so the
formulas live here once, as scalar kernels, with the array forms `evaluate` and `frame` over
them. `Geometry` is the record the kernels take: the seven arrays of the pieces.
"""
from __future__ import annotations

from math import cos, sin
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.feed.lookahead import search_right_from


class Geometry(NamedTuple):
    """The arrays (P pieces) that define the analytic pieces' shape."""

    c: np.ndarray  # (P, 3)
    e1: np.ndarray  # (P, 3)
    e2: np.ndarray  # (P, 3)
    w: np.ndarray  # (P, 3)
    radius: np.ndarray
    dr: np.ndarray
    omega: np.ndarray


@njit(cache=True)
def point_into(g, i, sigma, out, row):
    """p(sigma) of piece i into out[row]."""
    phi = g.omega[i] * sigma
    r = g.radius[i] + g.dr[i] * phi
    rc = r * cos(phi)
    rs = r * sin(phi)
    for a in range(3):
        out[row, a] = g.c[i, a] + rc * g.e1[i, a] + rs * g.e2[i, a] + sigma * g.w[i, a]


@njit(cache=True)
def frame_into(g, i, sigma, t, kv, row):
    """Unit tangent and curvature vector d(tangent)/ds of piece i into t[row], kv[row] (the
    spiral term dr, at most microns over a whole arc, is left out)."""
    om = g.omega[i]
    if om == 0.0:
        for a in range(3):
            t[row, a] = g.w[i, a]
            kv[row, a] = 0.0
        return
    phi = om * sigma
    ro = g.radius[i] * om
    rk = -(ro * om)
    cs = cos(phi)
    sn = sin(phi)
    for a in range(3):
        t[row, a] = ro * (cs * g.e2[i, a] - sn * g.e1[i, a]) + g.w[i, a]
        kv[row, a] = rk * (cs * g.e1[i, a] + sn * g.e2[i, a])


@njit(cache=True)
def _evaluate(g, idx, sigma):
    out = np.empty((idx.shape[0], 3))
    for k in range(idx.shape[0]):
        point_into(g, idx[k], sigma[k], out, k)
    return out


@njit(cache=True)
def _frame(g, idx, sigma):
    t = np.empty((idx.shape[0], 3))
    kv = np.empty((idx.shape[0], 3))
    for k in range(idx.shape[0]):
        frame_into(g, idx[k], sigma[k], t, kv, k)
    return t, kv


def evaluate(g: Geometry, idx: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Points (N, 3) of analytic pieces idx at arc lengths sigma."""
    return _evaluate(g, np.asarray(idx, dtype=np.int64), np.asarray(sigma, dtype=np.float64))


def frame(g: Geometry, idx: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents and curvature vectors (N, 3) of analytic pieces idx at arc lengths sigma."""
    return _frame(g, np.asarray(idx, dtype=np.int64), np.asarray(sigma, dtype=np.float64))


@njit(cache=True)
def _clip(x, lo, hi):
    """np.clip of one float."""
    x = x if (x >= lo or x != x) else lo
    return x if (x <= hi or x != x) else hi


@njit(cache=True)
def points_along(g, pstart, length, sv):
    """The piece of each arc length sv (pieces starting at pstart; a point exactly on a
    boundary belongs to the piece it completes) and the point there, as the analytic form
    gives it (the caller replaces the points of NURBS and blend pieces)."""
    n = sv.shape[0]
    loc = np.empty(n, np.int64)
    pos = np.empty((n, 3))
    last = pstart.shape[0] - 1
    j, before = 0, np.nan
    for k in range(n):
        j = search_right_from(pstart, sv[k], j, before)
        before = sv[k]
        i = min(max(j - 1, 0), last)
        if i > 0 and sv[k] <= pstart[i] + 1e-12:
            i -= 1
        loc[k] = i
        point_into(g, i, _clip(sv[k] - pstart[i], 0.0, length[i]), pos, k)
    return loc, pos


@njit(cache=True)
def point_tangent(g, i, sigma):
    """Point and unit tangent of piece i at arc length sigma (one call, not evaluate and frame)."""
    p = np.empty((1, 3))
    t = np.empty((1, 3))
    point_into(g, i, sigma, p, 0)
    frame_into(g, i, sigma, t, np.empty((1, 3)), 0)
    return p[0], t[0]


@njit(cache=True)
def points_along_piece(g, i, base, sign, x, n):
    """evaluate(g, [i] * n, base + sign * np.linspace(0.0, x, n)) without the arrays: n points
    of piece i from arc length base over x in direction sign (the corner checks of
    ipo.feed.blends.curve_corner ask for 65 per side and try); linspace's arithmetic is numpy's,
    so the points are the same bits."""
    out = np.empty((n, 3))
    div = n - 1
    step = x / div if div > 0 else np.nan
    for k in range(n):
        if div <= 0:
            y = k * x
        elif step == 0.0:
            y = (k / div) * x
        else:
            y = k * step
        y += 0.0  # numpy adds the start
        if k == div and k > 0:
            y = x
        point_into(g, i, base + sign * y, out, k)
    return out
