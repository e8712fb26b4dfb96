"""The cubic G64 blends of every corner of a build where an arc meets a line or an arc, at once.

The rule is ipo.feed.blends.curve_corner's (`corner_blend`): d = R tan(theta/2) with
R (sec(theta/2) - 1) = P, at most what either move may give up; the cubic of `arc_cubic`
from the point d before the corner to the point d after it; its deviation from the two
moves and the corner point checked against P, and d shrunk by min(0.99, 0.995 / worst)
until within P, at most _TRIES times. A raster program has these corners by the ten
thousand, so here the corners are arrays and each try is two compiled passes over the
corners still open: the ends and tangents at d (`_ends`), then the cubic and its deviation
(`_deviations`). The transcendental steps between them (arccos, cos and the square of
`arc_cubic`) stay numpy's, over arrays: numpy's value of an array is its value of each
element (numba's libm arccos differs in the last bit), so each corner's blend is the same
bits as corner_blend's, corner by corner. The corners next to a NURBS keep corner_blend.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.feed.analytic import Geometry, frame_into, point_into, points_along_piece
from ipo.feed.blends.compiled import blend_deviation, cubic_points
from ipo.feed.blends.curve_corner import _CHECK_BASIS, _CHECK_SIDE, _SLACK, _TRIES
from ipo.numpy_kernels import dot3


@njit(cache=True)
def _side_at(g, is_arc, start, unit, i, s, p, t, kv, row):
    """Point and unit tangent of move i (an arc of g or a line) at arc length s into p[row], t[row]
    (kv[row]: scratch for an arc's curvature vector)."""
    if is_arc[i]:
        point_into(g, i, s, p, row)
        frame_into(g, i, s, t, kv, row)
    else:
        for a in range(3):
            p[row, a] = start[i, a] + unit[i, a] * s
            t[row, a] = unit[i, a]


@njit(cache=True)
def _ends(g, is_arc, start, unit, length, js, d):
    """For corner k between moves js[k] and js[k] + 1: the points and tangents d[k] before and
    after it (pa, ta, pb, tb), the cosine of the tangents' angle clipped to [-1, 1] and the
    squared chord |pb - pa|^2 (the dot products as arc_cubic's: ipo.numpy_kernels.dot3)."""
    n = js.shape[0]
    pa, ta, pb, tb = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    cos_t, chord2 = np.empty(n), np.empty(n)
    chord, kv = np.empty(3), np.empty((n, 3))
    for k in range(n):
        j = js[k]
        _side_at(g, is_arc, start, unit, j, length[j] + -1.0 * d[k], pa, ta, kv, k)
        _side_at(g, is_arc, start, unit, j + 1, 0.0 + 1.0 * d[k], pb, tb, kv, k)
        c = dot3(ta[k], tb[k])
        c = -1.0 if -1.0 > c else c  # min(max(c, -1), 1) as Python's min and max take a NaN
        cos_t[k] = 1.0 if 1.0 < c else c
        for a in range(3):
            chord[a] = pb[k, a] - pa[k, a]
        chord2[k] = dot3(chord, chord)
    return pa, ta, pb, tb, cos_t, chord2


@njit(cache=True)
def _line_stretch(start, unit, i, base, sign, x):
    """The two ends of line i's stretch from arc length base over x in direction sign."""
    out = np.empty((2, 3))
    for k in range(2):
        s = base + sign * (x if k == 1 else 0.0)
        for a in range(3):
            out[k, a] = start[i, a] + unit[i, a] * s
    return out


@njit(cache=True)
def _stretch(g, is_arc, start, unit, i, base, sign, x):
    """Move i from arc length base over x in direction sign as a polyline: an arc's _CHECK_SIDE points."""
    if is_arc[i]:
        return points_along_piece(g, i, base, sign, x, _CHECK_SIDE)
    return _line_stretch(start, unit, i, base, sign, x)


@njit(cache=True)
def _deviations(g, is_arc, start, unit, length, corner, js, d, pa, ta, pb, tb, h, basis, ctrl):
    """The cubic of each corner k (handles h[k]; into ctrl[k]) and its deviation from the two
    moves' stretches of d[k] and from the corner point (curve_corner.deviation)."""
    out = np.empty(js.shape[0])
    for k in range(js.shape[0]):
        j = js[k]
        for a in range(3):
            ctrl[k, 0, a] = pa[k, a]
            ctrl[k, 1, a] = pa[k, a] + h[k] * ta[k, a]
            ctrl[k, 2, a] = pb[k, a] - h[k] * tb[k, a]
            ctrl[k, 3, a] = pb[k, a]
        out[k] = blend_deviation(cubic_points(basis, ctrl[k]),
                                 _stretch(g, is_arc, start, unit, j, length[j], -1.0, d[k]),
                                 _stretch(g, is_arc, start, unit, j + 1, 0.0, 1.0, d[k]), corner[j])
    return out


def arc_corner_blends(g: Geometry, is_arc: np.ndarray, start: np.ndarray, unit: np.ndarray, length: np.ndarray,
                      end: np.ndarray, js: np.ndarray, theta: np.ndarray, tol_mm: np.ndarray, d_max: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(found, d, ctrl (K, 4, 3)) for the corners js (move js[k] ends where js[k] + 1 starts, at
    end[js[k]]; turn theta[k], tolerance tol_mm[k], at most d_max[k] from either move), each
    move a line (start, unit, length) or an arc (row of g, where is_arc); found[k] False where
    no blend within tol_mm was found (as corner_blend's None)."""
    js = np.asarray(js, dtype=np.int64)
    half = 0.5 * theta
    radius = tol_mm / (1.0 / np.cos(half) - 1.0)  # R (sec(theta/2) - 1) <= P
    d = radius * np.tan(half)
    d = np.where(d_max < d, d_max, d)  # min(d, d_max) as Python's
    found = np.zeros(len(js), dtype=bool)
    ctrl = np.empty((len(js), 4, 3))
    todo = np.arange(len(js))
    for _ in range(_TRIES):
        todo = todo[d[todo] > 0]
        if not len(todo):
            break
        jt, dt = js[todo], d[todo]
        pa, ta, pb, tb, cos_t, chord2 = _ends(g, is_arc, start, unit, length, jt, dt)
        # arc_cubic's handles h = |b - a| / (3 cos^2(phi/4)), the square as numpy's scalar power (libm's pow)
        h = np.sqrt(chord2) / (3.0 * np.float_power(np.cos(0.25 * np.arccos(cos_t)), 2))
        ctrl_t = np.empty((len(todo), 4, 3))
        worst = _deviations(g, is_arc, start, unit, length, end, jt, dt, pa, ta, pb, tb, h, _CHECK_BASIS,
                            ctrl_t) / tol_mm[todo]
        ok = worst <= 1.0 + _SLACK
        found[todo[ok]] = True
        ctrl[todo[ok]] = ctrl_t[ok]
        shrink = 0.995 / worst[~ok]  # the deviation grows about linearly with d
        todo = todo[~ok]
        d[todo] *= np.where(shrink < 0.99, shrink, 0.99)  # min(0.99, shrink) as Python's
    return found, d, ctrl
