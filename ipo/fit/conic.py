"""Conic spans: one rational quadratic piece between two junctions of a path, and its test.

A junction is a point on the path with a tangent direction. From a junction A (tangent ta)
to a junction B (tangent tb) the only quadratic that leaves A along ta and arrives at B
along tb has the control points A, C, B with C where the two tangent lines meet; one shape
weight rho is left (the middle weight, the end weights being 1):

    S(t) = ((1-t)^2 A + 2 t (1-t) rho C + t^2 B) / ((1-t)^2 + 2 t (1-t) rho + t^2)

(rho < 1 an ellipse, = 1 a parabola, > 1 a hyperbola; a circular arc of sweep phi has
rho = cos(phi / 2), so G2/G3 arcs and the fillets CAM systems write as G1 chords are
exact, and a large rho pulls the curve into a corner of the control polygon). rho is
set at the shoulder: S(1/2) = (M + rho C) / (1 + rho), M = (A + B) / 2, lies on the line
M -> C, and is put where the path crosses that line.

The span is accepted when the path between the junctions (vertices and points along
its longer segments) is within tol of the conic, and the conic (sampled) within tol of
the path. In 3-D the two tangent lines need not meet: C is the middle of their closest
points, accepted when those are at most `gap_mm` apart (the B-spline that joins the
spans moves the junctions by at most half of that, ipo.fit.quadratic, and is checked
again as written). Control points too close to an end (MIN_ARM of the chord) would
hide a corner in a tiny turn and are refused: corners are planned as corners; so are
those too far (MAX_ARM): a conic sweeping nearly 180 degrees is ill-conditioned.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.fit.distance import walk
from ipo.numpy_kernels import dot3, dot3_from

MAX_SAMPLES = 128  # curve samples per span at most
SAMPLE_SPACING_MM = 0.1  # along the control polygon
MIN_SAMPLES = 16
PROBES = 9  # curve points tested before the full test
DENSE_SPACING_MM = 0.05  # points checked along a path segment
MAX_DENSE = 8  # per segment
MIN_ARM, MAX_ARM = 0.02, 2.0  # |A - C| and |C - B| within these fractions of |A - B| (2: a 150 degree arc)
RHO_MIN, RHO_MAX = 0.1, 20.0  # the shape weight's range: beyond it the conic hides a corner at its ends or at C
PARALLEL = 1e-10  # 1 - (ta . tb)^2 below this: the tangent lines are parallel


@njit(cache=True)
def control_point(a, ta, b, tb, gap_mm, out):
    """C for the span A -> B into out[:3]; False where the tangents do not allow one conic
    (lines apart by more than gap_mm, C behind A or ahead of B, or parallel tangents that do
    not both lie on AB: that takes an inflection, two spans)."""
    ab = b - a
    chord = np.sqrt(dot3(ab, ab))
    if chord == 0.0:
        return False
    c12 = dot3(ta, tb)
    det = 1.0 - c12 * c12
    if det < PARALLEL:
        # a straight span: both tangents along AB
        along = dot3(ta, ab) / chord
        if along < 1.0 - 1e-9 or dot3(tb, ab) / chord < 1.0 - 1e-9:
            return False
        out[:3] = 0.5 * (a + b)
        return True
    b1, b2 = dot3(ta, ab), dot3(tb, ab)
    s = (b1 - c12 * b2) / det
    r = (c12 * b1 - b2) / det  # B + r tb is the closest point on B's line; r < 0 behind B
    if not (MIN_ARM * chord <= s <= MAX_ARM * chord and MIN_ARM * chord <= -r <= MAX_ARM * chord):
        return False
    p = a + s * ta
    qq = b + r * tb
    d = p - qq
    if dot3(d, d) > gap_mm * gap_mm:
        return False
    out[:3] = 0.5 * (p + qq)
    return True


@njit(cache=True)
def shoulder_rho(path, count, c):
    """rho that puts S(1/2) where the path (count points, A first, B last) crosses the line M -> C
    (in the span's plane); 1 for a straight span or where the path does not cross it."""
    a, b = path[0], path[count - 1]
    m = 0.5 * (a + b)
    mc = c - m
    lm = np.sqrt(dot3(mc, mc))
    if lm < 1e-12:
        return 1.0
    side = np.cross(mc, np.cross(c - a, b - a))  # in the span's plane, perpendicular to M -> C
    fp = dot3_from(path[0], m, side)
    for k in range(1, count):
        fc = dot3_from(path[k], m, side)
        if (fp <= 0.0 < fc) or (fp >= 0.0 > fc):
            x = path[k - 1] + (fp / (fp - fc)) * (path[k] - path[k - 1])
            f = dot3_from(x, m, mc) / (lm * lm)
            f = min(max(f, RHO_MIN / (1.0 + RHO_MIN)), RHO_MAX / (1.0 + RHO_MAX))
            return f / (1.0 - f)
        fp = fc
    return 1.0


@njit(cache=True)
def sample(a, c, b, rho, n, out):
    """n points of the conic at t = i / (n - 1) into out[:n]."""
    for i in range(n):
        t = i / (n - 1)
        w0, w1, w2 = (1.0 - t) * (1.0 - t), 2.0 * t * (1.0 - t) * rho, t * t
        den = w0 + w1 + w2
        for d in range(3):
            out[i, d] = (w0 * a[d] + w1 * c[d] + w2 * b[d]) / den


@njit(cache=True)
def load_path(q, a, b, lo, count, path):
    """The span's path A, q[lo], q[lo + 1], ..., B (count points) into path[:count]."""
    path[0] = a
    for k in range(1, count - 1):
        path[k] = q[lo + k - 1]
    path[count - 1] = b


@njit(cache=True)
def _points_within(src, lo, hi, dst, n_dst, tol2):
    """Are src[lo:hi] all within sqrt(tol2) of the polyline dst[:n_dst] (walking along it)?"""
    j = 0
    for i in range(lo, hi):
        d, j = walk(src[i, 0], src[i, 1], src[i, 2], dst, n_dst, j)
        if d > tol2:
            return False
    return True


@njit(cache=True)
def span_within(path, count, c, rho, tol_mm, curve):
    """Are the conic A, C, B (rho; A and B the ends of path) and the path (count points) within tol_mm
    of each other both ways? curve is a scratch buffer (MAX_SAMPLES, 3)."""
    a, b = path[0], path[count - 1]
    tol2 = tol_mm * tol_mm
    # a few points of the curve first: most spans that fail, fail there, and cheaply
    sample(a, c, b, rho, PROBES, curve)
    if not _points_within(curve, 1, PROBES - 1, path, count, tol2):
        return False
    poly_len = np.sqrt(dot3_from(c, a, c - a)) + np.sqrt(dot3_from(b, c, b - c))
    n = min(MAX_SAMPLES, max(MIN_SAMPLES, int(np.ceil(poly_len / SAMPLE_SPACING_MM)) + 1))
    sample(a, c, b, rho, n, curve)
    # the path's vertices to the curve, the curve to the path, points along the path to the curve
    if not (_points_within(path, 1, count - 1, curve, n, tol2) and _points_within(curve, 0, n, path, count, tol2)):
        return False
    j = 0
    for k in range(count - 1):
        s0, s1, s2 = path[k + 1, 0] - path[k, 0], path[k + 1, 1] - path[k, 1], path[k + 1, 2] - path[k, 2]
        parts = min(MAX_DENSE, int(np.ceil(np.sqrt(s0 * s0 + s1 * s1 + s2 * s2) / DENSE_SPACING_MM)))
        for m in range(1, parts):
            f = m / parts
            d, j = walk(path[k, 0] + f * s0, path[k, 1] + f * s1, path[k, 2] + f * s2, curve, n, j)
            if d > tol2:
                return False
    return True


@njit(cache=True)
def fitting_rho(path, count, c, tol_mm, curve):
    """The weight of a span that fits (span_within), -1 where it does not: the shoulder's, or where
    that fits, the nearest to 1 of 1 (a parabola: no drift in the B-spline's weights,
    ipo.fit.weights) and the geometric mean of 1 and the shoulder's that fits as well."""
    shoulder = shoulder_rho(path, count, c)
    if not span_within(path, count, c, shoulder, tol_mm, curve):
        return -1.0
    if abs(np.log(shoulder)) < 0.01:
        return shoulder
    if span_within(path, count, c, 1.0, tol_mm, curve):
        return 1.0
    mid = np.sqrt(shoulder)
    if span_within(path, count, c, mid, tol_mm, curve):
        return mid
    return shoulder
