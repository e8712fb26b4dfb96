"""Whether ipo.feed.sampling.nurbs_table tables a rational quadratic NURBS, compiled.

`vcnc fit` asks the controller's check (ipo.feed.split.planning_problem) about every group it
writes, and `vcnc check` about every NURBS of a program: a real CAM program fitted has thousands
of groups and parts, and nurbs_table's numpy path spends most of its time in per-call overhead
on such short curves (CAMotics' cameo.nc: 36 of 44 s of CPU in the fit). `tabled` walks the
same steps with the same arithmetic, in the order numpy sums (its sums of three terms: norms
and the control-point sums left to right, the weight sums and the curvature's dot product first
plus last, then the middle one), without building the table:

1. the parameters: 16 equal steps per knot span (ipo.numpy_kernels: numpy's linspace and interp);
2. up to 6 rounds of splitting intervals whose tangent turns by more than MAX_TURN_RAD or
   that are longer than MAX_SPACING_MM (at most 64 parts);
3. _refine_arc's halving until the Hermite and Simpson arc lengths agree within ARC_TOL_MM;
4. the end samples;
5. the frames at the samples and midpoints, Simpson's arc length, and _check_resolved's tests.

It says yes only with room to spare on every test nurbs_table makes (SURE_* below), so that a
last-bit difference (numpy's arccos against libm's) cannot turn its yes into nurbs_table's
no; anything else, and every curve of another degree, is for nurbs_table itself to decide
(and to say why). tests/ipo/feed/test_table_verdict.py checks that the parameters are
nurbs_table's to the bit.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.feed.sampling import (_ARC_REFINE_ROUNDS_MAX, _CHORD_SLACK_MM, _END_LEVELS, _MAX_TABLE_SAMPLES,
                               _NURBS_REFINE_ROUNDS, _NURBS_START_PER_SPAN, ARC_TOL_MM, MAX_SPACING_MM,
                               MAX_TURN_RAD)
from ipo.numpy_kernels import interp_at, linspace_into

DEGREE = 2
SURE_ROUNDS = _ARC_REFINE_ROUNDS_MAX - 4  # arc refinement settled at least this many rounds before its end
SURE_SAMPLES = _MAX_TABLE_SAMPLES * 9 // 10
SURE_SPEED = 1e-9  # every sampled |C'| at least this fraction of the largest
SURE_SLACK = 0.5  # the chord and length tests pass within this fraction of their slack


@njit(cache=True, error_model="numpy")
def _basis2(knots, span, x, out):
    """The three degree-2 basis values and their first and second derivatives at x into out (3, 3), by
    The NURBS Book's A2.3 (ipo.nurbs.kernel.basis_derivs) unrolled for p = 2, operation for operation
    (its 0 + x sums kept: they turn -0 into 0)."""
    l1, r1 = x - knots[span], knots[span + 1] - x
    n10 = r1 + l1
    t = 1.0 / n10
    n01, n11 = 0.0 + r1 * t, l1 * t
    l2, r2 = x - knots[span - 1], knots[span + 2] - x
    n20 = r1 + l2
    t = n01 / n20
    n02, saved = 0.0 + r1 * t, l2 * t
    n21 = r2 + l1
    t = n11 / n21
    out[0, 0], out[0, 1], out[0, 2] = n02, saved + r2 * t, l1 * t
    a11 = -1.0 / n20  # the coefficients a[s][j] of A2.3, r = 0, 1, 2
    out[1, 0] = (0.0 + a11 * n01) * 2.0
    out[2, 0] = (0.0 + (-a11 / n10) * 1.0) * 2.0
    a10, a11 = 1.0 / n20, -1.0 / n21
    out[1, 1] = (a10 * n01 + a11 * n11) * 2.0
    out[2, 1] = (0.0 + ((a11 - a10) / n10) * 1.0) * 2.0
    a10 = 1.0 / n21
    out[1, 2] = (a10 * n11) * 2.0
    out[2, 2] = ((a10 / n10) * 1.0) * 2.0


@njit(cache=True, error_model="numpy")
def _derivs(knots, weights, points, u, n, out):
    """out[k, m] = k-th derivative of C at u[m] (k <= n <= 2), as ipo.nurbs.kernel.curve_derivs
    computes it for degree 2 (A4.2 on _basis2)."""
    last = knots.shape[0] - DEGREE - 2
    ders = np.empty((3, 3))
    wd = np.empty(3)
    for m in range(u.shape[0]):
        span = min(max(np.searchsorted(knots, u[m], side="right") - 1, DEGREE), last)
        _basis2(knots, span, u[m], ders)
        i0 = span - DEGREE
        w0, w1, w2 = weights[i0], weights[i0 + 1], weights[i0 + 2]
        for k in range(n + 1):
            wd[k] = (ders[k, 0] * w0 + ders[k, 2] * w2) + ders[k, 1] * w1
        for k in range(n + 1):
            for c in range(3):
                v = (ders[k, 0] * (points[i0, c] * w0) + ders[k, 1] * (points[i0 + 1, c] * w1)) \
                    + ders[k, 2] * (points[i0 + 2, c] * w2)
                for i in range(1, k + 1):
                    binom = 1.0 if i == k else float(k)
                    v -= binom * wd[i] * out[k - i, m, c]
                out[k, m, c] = v / wd[0]


@njit(cache=True, error_model="numpy")
def _norm(v):
    return np.sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2])


@njit(cache=True, error_model="numpy")
def _speeds(knots, weights, points, u):
    d = np.empty((2, u.shape[0], 3))
    _derivs(knots, weights, points, u, 1, d)
    sp = np.empty(u.shape[0])
    for m in range(u.shape[0]):
        sp[m] = _norm(d[1, m])
    return sp


@njit(cache=True, error_model="numpy")
def _frames(knots, weights, points, u):
    """Speed, unit tangent, curvature vector (sampling._nurbs_frame) and the points at u."""
    d = np.empty((3, u.shape[0], 3))
    _derivs(knots, weights, points, u, 2, d)
    n = u.shape[0]
    speed, t, kv = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    for m in range(n):
        sp = _norm(d[1, m])
        speed[m] = sp
        for c in range(3):
            t[m, c] = d[1, m, c] / sp
        dot = (d[2, m, 0] * t[m, 0] + d[2, m, 2] * t[m, 2]) + d[2, m, 1] * t[m, 1]
        for c in range(3):
            kv[m, c] = (d[2, m, c] - dot * t[m, c]) / (sp * sp)
    return speed, t, kv, d[0].copy()


@njit(cache=True, error_model="numpy")
def _sure_speeds(speed):
    top = 0.0
    for x in speed:
        if not x > 0 or not np.isfinite(x):
            return False
        top = max(top, x)
    for x in speed:
        if x < SURE_SPEED * top:
            return False
    return True


@njit(cache=True, error_model="numpy")
def _refined(knots, weights, points):
    """Steps 1 and 2: the parameters, or an empty array where a speed is not sure."""
    p = DEGREE
    brk = np.unique(knots[p:knots.shape[0] - p])
    u = np.empty((brk.shape[0] - 1) * (_NURBS_START_PER_SPAN + 1))
    for i in range(brk.shape[0] - 1):
        linspace_into(brk[i], brk[i + 1], _NURBS_START_PER_SPAN + 1, u, i * (_NURBS_START_PER_SPAN + 1))
    u = np.unique(u)
    for _ in range(_NURBS_REFINE_ROUNDS):
        speed, t, kv, _pts = _frames(knots, weights, points, u)
        if not _sure_speeds(speed):
            return np.empty(0)
        m = u.shape[0] - 1
        split = np.empty(m, np.int64)
        extra = 0
        for i in range(m):
            ds = 0.5 * (speed[i] + speed[i + 1]) * (u[i + 1] - u[i])
            kmax = max(_norm(kv[i]), _norm(kv[i + 1]))
            cos_t = (t[i, 0] * t[i + 1, 0] + t[i, 2] * t[i + 1, 2]) + t[i, 1] * t[i + 1, 1]
            turn = max(kmax * ds, np.arccos(min(max(cos_t, -1.0), 1.0)))
            f = max(np.ceil(turn / MAX_TURN_RAD), np.ceil(ds / MAX_SPACING_MM))
            split[i] = int(f) if f <= 64 else 64
            if split[i] > 1:
                extra += split[i] - 1
        if extra == 0:
            break
        out = np.empty(m + 1 + extra)
        out[:m + 1] = u
        at = m + 1
        line = np.empty(65)
        for i in range(m):
            if split[i] > 1:
                linspace_into(u[i], u[i + 1], split[i] + 1, line, 0)
                out[at:at + split[i] - 1] = line[1:split[i]]
                at += split[i] - 1
        u = np.unique(out)
    return u


@njit(cache=True, error_model="numpy")
def _arc_settled(knots, weights, points, u):
    """Step 3: the parameters once the arc length settles with rounds to spare, or an empty array."""
    for rnd in range(_ARC_REFINE_ROUNDS_MAX):
        m = u.shape[0] - 1
        q = np.empty(3 * m)
        for i in range(m):
            h = u[i + 1] - u[i]
            q[3 * i], q[3 * i + 1], q[3 * i + 2] = u[i] + h * 0.25, u[i] + h * 0.5, u[i] + h * 0.75
        sp = _speeds(knots, weights, points, u)
        sq = _speeds(knots, weights, points, q)
        bad = 0
        for i in range(m):
            h = u[i + 1] - u[i]
            left = h / 12 * ((sp[i] + 4 * sq[3 * i]) + sq[3 * i + 1])
            right = h / 12 * ((sq[3 * i + 1] + 4 * sq[3 * i + 2]) + sp[i + 1])
            hermite = 0.5 * (left + right) + h / 8 * (sp[i] - sp[i + 1])
            if not np.abs(hermite - left) <= ARC_TOL_MM:
                bad += 1
                q[3 * i] = np.nan  # marks the interval to halve
        if bad == 0:
            return u
        if rnd >= SURE_ROUNDS or m + 1 + bad > SURE_SAMPLES:
            return np.empty(0)
        out = np.empty(m + 1 + bad)
        out[:m + 1] = u
        at = m + 1
        for i in range(m):
            if np.isnan(q[3 * i]):
                if not (u[i] < q[3 * i + 1] < u[i + 1]):
                    return np.empty(0)
                out[at] = q[3 * i + 1]
                at += 1
        u = np.unique(out)
    return np.empty(0)


@njit(cache=True, error_model="numpy")
def _with_end_samples(knots, weights, points, u, gap_mm):
    """Step 4 (sampling._with_end_samples)."""
    speed = _speeds(knots, weights, points, u)
    s = np.empty(u.shape[0])
    s[0] = 0.0
    acc = 0.0
    for i in range(u.shape[0] - 1):
        acc += 0.5 * (speed[i] + speed[i + 1]) * (u[i + 1] - u[i])
        s[i + 1] = acc
    if s[-1] <= 3 * gap_mm:
        return u
    out = np.empty(u.shape[0] + 2 * _END_LEVELS)
    out[:u.shape[0]] = u
    for j in range(_END_LEVELS):
        d = gap_mm * 0.25 ** j
        out[u.shape[0] + j] = interp_at(d, s, u)
        out[u.shape[0] + _END_LEVELS + j] = interp_at(s[-1] - d, s, u)
    return np.unique(out)


@njit(cache=True, error_model="numpy")
def table_parameters(knots, weights, points, gap_mm):
    """The parameters nurbs_table samples a degree-2 NURBS at (steps 1-4), or an empty array where
    a step is not sure to pass."""
    u = _refined(knots, weights, points)
    if u.shape[0] == 0:
        return u
    u = _arc_settled(knots, weights, points, u)
    if u.shape[0] == 0 or gap_mm <= 0:
        return u
    return _with_end_samples(knots, weights, points, u, gap_mm)


@njit(cache=True, error_model="numpy")
def tabled(knots, weights, points, gap_mm):
    """True where nurbs_table surely tables the degree-2 NURBS (knots, weights, points) with end gap
    gap_mm; False where that is not sure (nurbs_table decides)."""
    u = table_parameters(knots, weights, points, gap_mm)
    if u.shape[0] == 0:
        return False
    speed, _t, _kv, pts = _frames(knots, weights, points, u)
    m = u.shape[0] - 1
    mid = np.empty(m)
    for i in range(m):
        mid[i] = 0.5 * (u[i] + u[i + 1])
    mid_speed, _t, _kv, _pts = _frames(knots, weights, points, mid)
    if not (_sure_speeds(speed) and _sure_speeds(mid_speed)):
        return False
    total = 0.0
    for i in range(m):
        ds = (speed[i] + 4 * mid_speed[i] + speed[i + 1]) / 6 * (u[i + 1] - u[i])
        total += ds
        chord = _norm(pts[i + 1] - pts[i])
        if not chord - ds <= SURE_SLACK * (_CHORD_SLACK_MM + 1e-6 * chord):
            return False
    polygon = 0.0
    for i in range(points.shape[0] - 1):
        polygon += _norm(points[i + 1] - points[i])
    return total <= polygon * (1 + SURE_SLACK * 1e-6) + SURE_SLACK * _CHORD_SLACK_MM
