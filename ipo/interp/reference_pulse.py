"""Reference-pulse output, 000 §2.4: unit steps per axis by the 0.5 BLU rule, and the
distance of the resulting pulse path from the exact curve.

The machine stands on integer BLU positions. For each next curve point (the interpolator
walks with d = 1 BLU), every axis whose difference to the point is >= 0.5 BLU gets one
unit step (+1 or -1), all stepping axes at once: one of the seven combinations x, y, z,
xy, xz, yz, xyz. If a point is so far away that one step leaves an axis >= 0.5 BLU behind,
further steps follow for the same point, so each axis ends within 0.5 BLU of every point.
A difference of exactly -0.5 BLU does not step (the paper's rule reads >= 0.5 both ways):
otherwise a point exactly halfway would make the axis chatter +1, -1, +1 ... for ever;
so the lag stays in [-0.5, +0.5), rounding half up.

The paper's "within 0.5 BLU" holds per axis at every curve point. The distance of the
pulse path from the curve is the length of the per-axis lag vector's component normal to
the curve, bounded by 0.5*sqrt(2) BLU in a plane and 0.5*sqrt(3) BLU in space, and it does
exceed 0.5 BLU: measured 0.69 BLU on a 1 mm circle (over 6 % of the vertices above 0.5)
and 0.81 BLU on a 3-D NURBS at BLU = 1 um (tests/test_reference_output.py).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.errors import STUDY, IpoError
from ipo.interp.reference_word import checked_points
from ipo.segments import segment_distance


@njit(cache=True)
def _walk(pts_blu, start, out):
    """Apply the 0.5 BLU rule; fill out (if it has room) and return the number of steps."""
    cur = start.copy()
    m = 0
    for j in range(pts_blu.shape[0]):
        while True:
            moved = False
            for a in range(3):
                diff = pts_blu[j, a] - cur[a]
                s = 0
                if diff >= 0.5:  # 000 §2.4 rule, dX = +1
                    s = 1
                elif diff < -0.5:  # dX = -1 (strict: see the module note on ties)
                    s = -1
                if s != 0:
                    moved = True
                    cur[a] += s
                if m < out.shape[0]:
                    out[m, a] = s
            if not moved:
                break
            m += 1
    return m


def _blu(blu_mm: float) -> float:
    if not (np.isfinite(blu_mm) and blu_mm > 0):
        raise ValueError(f"blu_mm must be finite and > 0, got {blu_mm}")
    return float(blu_mm)


def _start(start_blu) -> np.ndarray:
    s = np.asarray(start_blu)
    if s.shape != (3,) or not np.issubdtype(s.dtype, np.integer):
        raise ValueError(f"start_blu must be three integers, got {start_blu!r}")
    return s.astype(np.int64)


def pulses(points_mm: np.ndarray, blu_mm: float, start_blu: np.ndarray) -> np.ndarray:
    """Unit steps (M, 3) int8, each row one of the seven non-zero combinations of -1/0/+1."""
    pts = checked_points(points_mm, "points_mm") / _blu(blu_mm)
    start = _start(start_blu)
    m = _walk(pts, start, np.empty((0, 3), dtype=np.int8))
    out = np.empty((m, 3), dtype=np.int8)
    _walk(pts, start, out)
    return out


def pulse_path(start_blu: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """BLU positions (M+1, 3) int64: the start, then the position after each step."""
    st = np.asarray(steps)
    if st.ndim != 2 or st.shape[1] != 3:
        raise ValueError(f"steps must have shape (M, 3), got {st.shape}")
    path = np.empty((len(st) + 1, 3), dtype=np.int64)
    path[0] = _start(start_blu)
    np.cumsum(st, axis=0, dtype=np.int64, out=path[1:])
    path[1:] += path[0]
    return path


# ---------------------------------------------------------------- deviation from the curve

@njit(cache=True)
def _cell_key(c, lo, dims):
    return (c[0] - lo[0]) + dims[0] * ((c[1] - lo[1]) + dims[1] * (c[2] - lo[2]))


@njit(cache=True)
def _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg):
    """Distance from q to the polyline `curve`, searching grid cells ring by ring: segments
    bucketed by their first point, so after ring r every unseen one is >= r*cell - max_seg away."""
    qc = np.floor(q / cell).astype(np.int64)
    best = np.inf
    c = np.empty(3, dtype=np.int64)
    r = 0
    while True:
        for i in range(-r, r + 1):
            for j in range(-r, r + 1):
                for k in range(-r, r + 1):
                    if max(abs(i), abs(j), abs(k)) != r:
                        continue
                    c[0], c[1], c[2] = qc[0] + i, qc[1] + j, qc[2] + k
                    inside = True
                    for a in range(3):
                        if c[a] < lo[a] or c[a] >= lo[a] + dims[a]:
                            inside = False
                    if not inside:
                        continue
                    key = _cell_key(c, lo, dims)
                    s0 = np.searchsorted(keys, key)
                    s1 = np.searchsorted(keys, key, side="right")
                    for s in range(s0, s1):
                        seg = order[s]
                        d = segment_distance(q, curve[seg], curve[seg + 1])
                        if d < best:
                            best = d
        if best <= r * cell - max_seg:
            return best
        outside = True  # the ring left the grid on every side: all segments were seen
        for a in range(3):
            if qc[a] - r > lo[a] or qc[a] + r < lo[a] + dims[a] - 1:
                outside = False
        if outside:
            return best
        r += 1


@njit(cache=True)
def _path_deviation(path, curve, keys, order, lo, dims, cell, max_seg, segments):
    worst = 0.0
    q = np.empty(3)
    n_sub = 8
    for i in range(path.shape[0]):
        worst = max(worst, _dist_to_curve(path[i], curve, keys, order, lo, dims, cell, max_seg))
        if not segments or i + 1 == path.shape[0]:
            continue
        # interior of the step: coarse samples, then a golden-section search at the best one
        a, b = path[i], path[i + 1]
        t_best, f_best = 0.0, -1.0
        for s in range(1, n_sub):
            t = s / n_sub
            q[:] = a + t * (b - a)
            f = _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg)
            if f > f_best:
                t_best, f_best = t, f
        lo_t, hi_t = max(t_best - 1.0 / n_sub, 0.0), min(t_best + 1.0 / n_sub, 1.0)
        g = 0.6180339887498949
        t1 = hi_t - g * (hi_t - lo_t)
        t2 = lo_t + g * (hi_t - lo_t)
        q[:] = a + t1 * (b - a)
        f1 = _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg)
        q[:] = a + t2 * (b - a)
        f2 = _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg)
        for _ in range(20):
            if f1 > f2:
                hi_t, t2, f2 = t2, t1, f1
                t1 = hi_t - g * (hi_t - lo_t)
                q[:] = a + t1 * (b - a)
                f1 = _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg)
            else:
                lo_t, t1, f1 = t1, t2, f2
                t2 = lo_t + g * (hi_t - lo_t)
                q[:] = a + t2 * (b - a)
                f2 = _dist_to_curve(q, curve, keys, order, lo, dims, cell, max_seg)
            f_best = max(f_best, f1, f2)
        worst = max(worst, f_best)
    return worst


def pulse_deviation_blu(path_blu: np.ndarray, curve_points_mm: np.ndarray, blu_mm: float,
                        segments: bool = True) -> float:
    """Largest distance in BLU from the pulse path to the curve given as dense samples.

    The curve is the polyline through curve_points_mm (sample it much finer than a BLU).
    With segments=True the path is the polyline of unit steps (a diagonal step moves its
    axes together); with segments=False only the BLU positions the machine stops at count.
    """
    blu = _blu(blu_mm)
    path = np.asarray(path_blu)
    if path.ndim != 2 or path.shape[1] != 3 or len(path) == 0:
        raise ValueError(f"path_blu must have shape (M, 3) with M >= 1, got {path.shape}")
    curve = checked_points(curve_points_mm, "curve_points_mm") / blu
    if len(curve) < 2:
        raise ValueError("curve_points_mm needs at least two points")
    seg_len = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    max_seg = float(seg_len.max())
    cell = max(1.0, 2.0 * max_seg)
    cells = np.floor(curve[:-1] / cell).astype(np.int64)
    lo = cells.min(axis=0)
    dims = cells.max(axis=0) - lo + 1
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:
        raise IpoError(STUDY, "curve too large for the deviation grid; sample it in pieces")
    keys = cells[:, 0] - lo[0] + dims[0] * ((cells[:, 1] - lo[1]) + dims[1] * (cells[:, 2] - lo[2]))
    order = np.argsort(keys, kind="stable")
    return float(_path_deviation(path.astype(np.float64), curve, keys[order], order, lo, dims,
                                 cell, max_seg, segments))
