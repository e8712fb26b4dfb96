"""Compiled kernels for the cubic (and quintic G2) Bezier corner blends (ipo.feed.pieces), which a raster program
has by the ten thousand: the arc-length table and the points at given arc lengths, the
same arithmetic as ipo.feed.sampling's generic numpy path (nurbs_table, NurbsTable.points_at)
without its per-call overhead.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ipo.segments import segment_distance

_BLOCK = 8  # segments per bounding box in polyline_distance
_BOX_SLACK = 1e-12  # relative to the coordinates: far above the rounding of a distance or a box


@njit(cache=True)
def power_coefs(p):
    """The power-basis coefficients of the Bezier with control points p (n + 1, 3), as _derivs_at
    takes them, (3, n + 1, 3): a cubic's p0, a1 = 3 (p1 - p0), a2 = 3 (p2 - 2 p1 + p0),
    a3 = p3 - 3 p2 + 3 p1 - p0 in [0]; any other degree's a_k = C(n, k) sum_i (-1)^(k - i) C(k, i) P_i
    (the quintic G2 blends, ipo.feed.blends.curvature_continuous) in [0], k a_k in [1] and
    k (k - 1) a_k in [2], the terms of its derivatives."""
    n = p.shape[0] - 1
    coef = np.zeros((3, n + 1, 3))
    if n == 3:
        for a in range(3):
            p0, p1, p2, p3 = p[0, a], p[1, a], p[2, a], p[3, a]
            coef[0, 0, a] = p0
            coef[0, 1, a] = 3 * (p1 - p0)
            coef[0, 2, a] = 3 * (p2 - 2 * p1 + p0)
            coef[0, 3, a] = p3 - 3 * p2 + 3 * p1 - p0
        return coef
    binom_n = 1.0
    for k in range(n + 1):
        binom_k = 1.0
        for i in range(k + 1):
            sign = 1.0 if (k - i) % 2 == 0 else -1.0
            for a in range(3):
                coef[0, k, a] += sign * binom_k * p[i, a]
            binom_k = binom_k * (k - i) / (i + 1)
        for a in range(3):
            coef[0, k, a] *= binom_n
            coef[1, k, a] = k * coef[0, k, a]
            coef[2, k, a] = k * (k - 1) * coef[0, k, a]
        binom_n = binom_n * (n - k) / (k + 1)
    return coef


@njit(cache=True)
def _derivs_at(coef, x, a):
    """Coordinate a of C(x), C'(x), C''(x) of the Bezier whose power_coefs are coef: a cubic in
    closed form, any other degree by Horner's rule."""
    n = coef.shape[1] - 1
    if n == 3:
        p0, a1, a2, a3 = coef[0, 0, a], coef[0, 1, a], coef[0, 2, a], coef[0, 3, a]
        return p0 + x * (a1 + x * (a2 + x * a3)), a1 + x * (2 * a2 + 3 * x * a3), 2 * a2 + 6 * x * a3
    c, d1, d2 = coef[0, n, a], coef[1, n, a], coef[2, n, a]
    for k in range(n - 1, 1, -1):
        c = c * x + coef[0, k, a]
        d1 = d1 * x + coef[1, k, a]
        d2 = d2 * x + coef[2, k, a]
    c = c * x + coef[0, 1, a]
    d1 = d1 * x + coef[1, 1, a]
    return c * x + coef[0, 0, a], d1, d2


@njit(cache=True)
def _speed_at(coef, x):
    """|C'(x)|."""
    n = coef.shape[1] - 1
    if n == 3:
        _, e0, _ = _derivs_at(coef, x, 0)
        _, e1, _ = _derivs_at(coef, x, 1)
        _, e2, _ = _derivs_at(coef, x, 2)
        return np.sqrt(e0 ** 2 + e1 ** 2 + e2 ** 2)
    e0, e1, e2 = coef[1, n, 0], coef[1, n, 1], coef[1, n, 2]
    for k in range(n - 1, 0, -1):
        e0 = e0 * x + coef[1, k, 0]
        e1 = e1 * x + coef[1, k, 1]
        e2 = e2 * x + coef[1, k, 2]
    return np.sqrt(e0 ** 2 + e1 ** 2 + e2 ** 2)


@njit(cache=True)
def _frame_at(coef, u, i, speed, t, kv):
    """Speed |C'|, unit tangent and curvature vector at u[i] into row i; False where the derivative
    vanishes."""
    x = u[i]
    _, d10, d20 = _derivs_at(coef, x, 0)
    _, d11, d21 = _derivs_at(coef, x, 1)
    _, d12, d22 = _derivs_at(coef, x, 2)
    sp = np.sqrt(d10 * d10 + d11 * d11 + d12 * d12)
    speed[i] = sp
    if sp <= 0:
        return False
    t[i, 0], t[i, 1], t[i, 2] = d10 / sp, d11 / sp, d12 / sp
    dot = d20 * t[i, 0] + d21 * t[i, 1] + d22 * t[i, 2]
    kv[i, 0] = (d20 - dot * t[i, 0]) / (sp * sp)
    kv[i, 1] = (d21 - dot * t[i, 1]) / (sp * sp)
    kv[i, 2] = (d22 - dot * t[i, 2]) / (sp * sp)
    return True


@njit(cache=True)
def _frame(coef, u):
    n = u.shape[0]
    speed, t, kv = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    for i in range(n):
        if not _frame_at(coef, u, i, speed, t, kv):
            return speed, t, kv, False
    return speed, t, kv, True


@njit(cache=True)
def bezier_frame(p, u):
    """Speed |C'|, unit tangent and curvature vector at u of the Bezier with control points p, and
    False where the derivative vanishes."""
    return _frame(power_coefs(p), u)


@njit(cache=True)
def _increasing(u):
    for i in range(u.shape[0] - 1):
        if not u[i] < u[i + 1]:
            return False
    return True


@njit(cache=True)
def bezier_table(p, start_per_span, rounds, max_turn_rad, max_spacing_mm):
    """(s, u, speed, t, kv, ok) as ipo.feed.sampling.nurbs_table builds them; ok is False where
    the derivative vanishes.

    1. u: start_per_span + 1 equal steps.
    2. Up to `rounds` times: split every interval whose tangent turns by more than
       max_turn_rad or that is longer than max_spacing_mm (at most 64 parts); the frames of
       the parameters kept from the round before are reused, the new ones evaluated.
    3. Simpson's rule on |C'| over each interval: the arc length s."""
    coef = power_coefs(p)
    # 1. the start
    u = np.empty(start_per_span + 1)
    step = 1.0 / start_per_span
    for i in range(start_per_span + 1):
        u[i] = i * step
    u[start_per_span] = 1.0
    speed, t, kv, ok = _frame(coef, u)
    if not ok:
        return u, u, speed, t, kv, False
    # 2. refinement; an interval whose tangents' cosine is this far above cos(max_turn_rad) turns by
    # less than max_turn_rad, so its arc cosine cannot make it split or change its parts
    cos_within = np.cos(max_turn_rad * (1.0 - 1e-6))
    for _ in range(rounds):
        m = u.shape[0] - 1
        split = np.empty(m, np.int64)
        total = 0
        k1 = np.sqrt(kv[0, 0] ** 2 + kv[0, 1] ** 2 + kv[0, 2] ** 2)
        for i in range(m):
            ds = 0.5 * (speed[i] + speed[i + 1]) * (u[i + 1] - u[i])
            k0 = k1
            k1 = np.sqrt(kv[i + 1, 0] ** 2 + kv[i + 1, 1] ** 2 + kv[i + 1, 2] ** 2)
            cos_t = t[i, 0] * t[i + 1, 0] + t[i, 1] * t[i + 1, 1] + t[i, 2] * t[i + 1, 2]
            turn = max(k0, k1) * ds
            if not cos_t > cos_within:
                turn = max(turn, np.arccos(min(max(cos_t, -1.0), 1.0)))
            split[i] = int(max(np.ceil(turn / max_turn_rad), np.ceil(ds / max_spacing_mm)))
            total += min(split[i], 64) if split[i] > 1 else 1
        if total == m:
            break
        out = np.empty(total + 1)
        fresh = np.ones(total + 1, np.bool_)  # a parameter not kept from the round before
        j = 0
        for i in range(m):
            out[j] = u[i]
            fresh[j] = False
            j += 1
            if split[i] > 1:
                sp = min(split[i], 64)
                h = (u[i + 1] - u[i]) / sp
                for r in range(1, sp):
                    out[j] = r * h + u[i]
                    j += 1
        out[j] = u[m]
        fresh[j] = False
        if not _increasing(out):  # rounding made a duplicate: the sorted unique set, all evaluated
            u = np.unique(out)
            speed, t, kv, ok = _frame(coef, u)
            if not ok:
                return u, u, speed, t, kv, False
            continue
        speed_n, t_n, kv_n = np.empty(total + 1), np.empty((total + 1, 3)), np.empty((total + 1, 3))
        j = 0
        for i in range(total + 1):
            if fresh[i]:
                if not _frame_at(coef, out, i, speed_n, t_n, kv_n):
                    return out, out, speed_n, t_n, kv_n, False
            else:
                speed_n[i] = speed[j]
                t_n[i] = t[j]
                kv_n[i] = kv[j]
                j += 1
        u, speed, t, kv = out, speed_n, t_n, kv_n
    # 3. the arc length
    n = u.shape[0]
    s = np.empty(n)
    s[0] = 0.0
    acc = 0.0
    for i in range(n - 1):
        _, e0, _ = _derivs_at(coef, 0.5 * (u[i] + u[i + 1]), 0)
        _, e1, _ = _derivs_at(coef, 0.5 * (u[i] + u[i + 1]), 1)
        _, e2, _ = _derivs_at(coef, 0.5 * (u[i] + u[i + 1]), 2)
        mid_speed = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        if mid_speed <= 0:
            return u, u, speed, t, kv, False
        acc += (speed[i] + 4 * mid_speed + speed[i + 1]) / 6 * (u[i + 1] - u[i])
        s[i + 1] = acc
    return s, u, speed, t, kv, True


@njit(cache=True)
def bezier_tables(ctrl, start_per_span, rounds, max_turn_rad, max_spacing_mm):
    """bezier_table of each Bezier ctrl[b] (B, degree + 1, 3) in one call (a build has
    thousands): (s, u, speed, t, kv) of all, concatenated, with rows first[b]..first[b + 1]
    those of ctrl[b], and ok per curve."""
    n = ctrl.shape[0]
    tables = [bezier_table(ctrl[b], start_per_span, rounds, max_turn_rad, max_spacing_mm) for b in range(n)]
    first = np.zeros(n + 1, np.int64)
    ok = np.empty(n, np.bool_)
    for b in range(n):
        first[b + 1] = first[b] + tables[b][0].shape[0]
        ok[b] = tables[b][5]
    m = first[n]
    s, u, speed, t, kv = np.empty(m), np.empty(m), np.empty(m), np.empty((m, 3)), np.empty((m, 3))
    for b in range(n):
        a, z = first[b], first[b + 1]
        s[a:z], u[a:z], speed[a:z], t[a:z], kv[a:z] = tables[b][0], tables[b][1], tables[b][2], tables[b][3], tables[b][4]
    return s, u, speed, t, kv, first, ok


@njit(cache=True)
def _points_into(coef, s_tab, u_tab, s, xg, wg, out):
    """bezier_points_at of the Bezier whose power_coefs are coef, into out."""
    length = s_tab[-1]
    last = s_tab.shape[0] - 2
    for i in range(s.shape[0]):
        target = min(max(s[i], 0.0), length)
        k = min(max(np.searchsorted(s_tab, target, side="right") - 1, 0), last)
        h = s_tab[k + 1] - s_tab[k]
        q = (target - s_tab[k]) / h if h > 0 else 0.0
        uk, uk1, sk = u_tab[k], u_tab[k + 1], s_tab[k]
        u = uk + q * (uk1 - uk)
        for _ in range(3):
            du = u - uk
            quad = 0.0
            for j in range(xg.shape[0]):
                quad += _speed_at(coef, uk + 0.5 * du * (xg[j] + 1)) * wg[j]
            s_u = sk + 0.5 * (u - uk) * quad
            u = min(max(u - (s_u - target) / _speed_at(coef, u), uk), uk1)
        for a in range(3):
            out[i, a] = _derivs_at(coef, u, a)[0]


@njit(cache=True)
def bezier_points_at(p, s_tab, u_tab, s, xg, wg):
    """Points at arc lengths s on the Bezier with control points p: u from the table, then three
    Newton steps on the arc length (Gauss-Legendre nodes xg, weights wg from the table sample below)."""
    out = np.empty((s.shape[0], 3))
    _points_into(power_coefs(p), s_tab, u_tab, s, xg, wg, out)
    return out


@njit(cache=True)
def bezier_points_runs(ctrl, ctrl_first, s_tab, u_tab, tab_first, s, run_first, xg, wg):
    """bezier_points_at of many blends in one call (an emission batch crosses hundreds): run r
    is the Bezier ctrl[ctrl_first[r]:ctrl_first[r + 1]] with its table rows
    tab_first[r]..tab_first[r + 1] of s_tab and u_tab, at the arc lengths
    s[run_first[r]:run_first[r + 1]]."""
    out = np.empty((s.shape[0], 3))
    for r in range(run_first.shape[0] - 1):
        a, z = tab_first[r], tab_first[r + 1]
        _points_into(power_coefs(ctrl[ctrl_first[r]:ctrl_first[r + 1]]), s_tab[a:z], u_tab[a:z],
                     s[run_first[r]:run_first[r + 1]], xg, wg, out[run_first[r]:run_first[r + 1]])
    return out


@njit(cache=True)
def polyline_distance(q, poly):
    """Distance of each point q (M, 3) from the polyline through poly (N, 3): the smallest
    segment_distance, to the bit. The segments come in blocks of _BLOCK with their bounding
    boxes; a block whose box lies farther from q than the best distance so far (by more than
    the rounding of either) cannot hold the smallest and is skipped, and each point starts
    from the block that held its predecessor's (the G2 joints measure polylines of thousands
    of points against each other, point by point along them)."""
    n_seg = poly.shape[0] - 1
    n_blk = (max(n_seg, 0) + _BLOCK - 1) // _BLOCK
    lo, hi = np.empty((n_blk, 3)), np.empty((n_blk, 3))
    size = 0.0  # the largest coordinate: the scale of the rounding
    for b in range(n_blk):
        for a in range(3):
            lo[b, a] = hi[b, a] = poly[b * _BLOCK, a]
        for i in range(b * _BLOCK, min((b + 1) * _BLOCK, n_seg) + 1):
            for a in range(3):
                lo[b, a], hi[b, a] = min(lo[b, a], poly[i, a]), max(hi[b, a], poly[i, a])
                size = max(size, abs(poly[i, a]))
    out = np.empty(q.shape[0])
    start = 0
    for m in range(q.shape[0]):
        qm = q[m]
        margin = _BOX_SLACK * (1.0 + size + abs(qm[0]) + abs(qm[1]) + abs(qm[2]))
        best = np.inf
        first = start
        for k in range(n_blk):
            b = (first + k) % n_blk
            if k > 0 and best < np.inf:
                gap2 = 0.0
                for a in range(3):
                    e = max(lo[b, a] - qm[a], qm[a] - hi[b, a], 0.0)
                    gap2 += e * e
                if gap2 > (best + margin) ** 2:
                    continue
            for i in range(b * _BLOCK, min((b + 1) * _BLOCK, n_seg)):
                d = segment_distance(qm, poly[i], poly[i + 1])
                if d < best:
                    best = d
                    start = b
        out[m] = best
    return out


@njit(cache=True)
def cubic_points(basis, ctrl):
    """Points (M, 3) of the cubic Bezier ctrl (4, 3) at the M parameters whose Bernstein
    values are the rows of basis (M, 4), summed in the order of the array expression
    b0 c0 + b1 c1 + b2 c2 + b3 c3 (the same bits)."""
    q = np.empty((basis.shape[0], 3))
    for m in range(basis.shape[0]):
        for a in range(3):
            q[m, a] = (basis[m, 0] * ctrl[0, a] + basis[m, 1] * ctrl[1, a]
                       + basis[m, 2] * ctrl[2, a] + basis[m, 3] * ctrl[3, a])
    return q


@njit(cache=True)
def blend_deviation(q, side_a, side_b, corner):
    """The larger of the largest distance of the points q from the nearer of the polylines
    side_a and side_b and the smallest distance of q from the corner point (NaN propagates,
    as in numpy's minimum, max and min)."""
    from_a, from_b = polyline_distance(q, side_a), polyline_distance(q, side_b)
    far = -np.inf
    near = np.inf
    for m in range(q.shape[0]):
        a, b = from_a[m], from_b[m]
        d = a if (a <= b or a != a) else b
        if far == far and (d > far or d != d):  # once NaN, stays NaN
            far = d
        d0, d1, d2 = q[m, 0] - corner[0], q[m, 1] - corner[1], q[m, 2] - corner[2]
        c = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        if near == near and (c < near or c != c):
            near = c
    return near if near > far else far
