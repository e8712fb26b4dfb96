"""A smoothing fit of each G2 chain's run (ipo.feed.blends.g2_chains) within P: the points and
tangents its quintics pass through.

Through the programmed midpoints with the moves' own tangents, the chain's curvature copies the
polyline's variation: CAM noise, or a line meeting an arc within one 0.2 mm move (curvature 0 to
0.4 /mm), and a long move stays straight to its midpoint. The jerk limit caps the speed where the
curvature changes, v^3 |dkappa/ds| <= J; that cap held about 27 s of g1_lhchips4's S-curve cycle.
P leaves room to spread such a change: a transition of length l off a curve of curvature kappa
moves it by about kappa l^2 / 24, so 0.08 mm allows 2.2 mm at 0.4 /mm instead of 0.2 mm.

A run's points p (its vertices and its moves' midpoints) are replaced by the penalised least
squares q,

    min sum_i w_i |q_i - p_i|^2 + LAMBDA sum_r h_r |6 q[s_r .. s_(r+3)]|^2,

the second sum the third derivative (6 x the third divided difference in the arc length s) over
each four consecutive points, h_r their mean spacing, w_i each point's share of the length: a
discrete smoothing spline (Reinsch's, one order up, as the curvature's rate is the third
derivative). The normal equations are banded (half-bandwidth 3), symmetric positive definite:
Cholesky. The run's two end moves keep their points, so the chain still starts and ends at their
midpoints with their tangents. A point moved more than its share of P gets a heavier weight and
the fit is repeated; what still exceeds it is pulled back to the share. The chain's quintics then
run from fitted midpoint to fitted midpoint and are each checked within P of the programmed corner
both ways (g2_chains), so the fit's bound only leaves them room, it does not stand for the check.
On g1_lhchips4 (S-curve) this took the cycle from 227.083 s to 198.300 s.
"""
from __future__ import annotations

from math import sqrt

import numpy as np
from numba import njit

SMOOTH_MM = 1.5  # LAMBDA = SMOOTH_MM^6, the cut-off wavelength about 2 pi SMOOTH_MM (g1_lhchips4: 1.5 198.30 s, 2 199.04, 3 199.20)
FIT_SHARE = 0.9  # of P the points may move (g1_lhchips4: 0.8 198.30 s, 0.9 197.87, 0.95 198.17)
_SPACING_MIN_MM = 0.05  # a shorter move counts as this long in the divided differences (conditioning)
_ROUNDS = 6  # reweighting rounds against the share
_TURN_MAX_COS = 0.5  # a fitted move may turn at most 60 degrees from its programmed direction


@njit(cache=True)
def _fit(p, bound, lam, n_lo, n_hi, q):
    """The fitted points q (m, 3) of the programmed p (m, 3) (module docstring, LAMBDA = lam): the
    first n_lo and the last n_hi kept, each other one within bound of its own."""
    m = p.shape[0]
    s = np.zeros(m)
    for i in range(1, m):
        d = sqrt((p[i, 0] - p[i - 1, 0]) ** 2 + (p[i, 1] - p[i - 1, 1]) ** 2 + (p[i, 2] - p[i - 1, 2]) ** 2)
        s[i] = s[i - 1] + max(d, _SPACING_MIN_MM)
    w = np.empty(m)
    for i in range(m):
        w[i] = 0.5 * (s[min(i + 1, m - 1)] - s[max(i - 1, 0)])
    band = np.zeros((m, 4))  # band[i, k] = A(i, i - k)
    for r in range(m - 3):
        c = np.empty(4)
        for a in range(4):
            den = 1.0
            for b in range(4):
                if b != a:
                    den *= s[r + a] - s[r + b]
            c[a] = 6.0 / den
        h = lam * (s[r + 3] - s[r]) / 3.0
        for a in range(4):
            for b in range(a + 1):
                band[r + a, a - b] += h * c[a] * c[b]
    for i in range(m):
        q[i] = p[i]
    chol = np.empty((m, 4))
    rhs = np.empty((m, 3))
    for _ in range(_ROUNDS):
        # the kept vertices' terms move to the right-hand side; their rows become the identity
        for i in range(m):
            for a in range(3):
                rhs[i, a] = w[i] * p[i, a]
            for k in range(4):
                chol[i, k] = band[i, k]
            chol[i, 0] += w[i]
        for i in range(m):
            kept_i = i < n_lo or i >= m - n_hi
            for k in range(1, 4):
                j = i - k
                if j < 0:
                    break
                kept_j = j < n_lo or j >= m - n_hi
                if kept_i and not kept_j:
                    for a in range(3):
                        rhs[j, a] -= chol[i, k] * p[i, a]
                elif kept_j and not kept_i:
                    for a in range(3):
                        rhs[i, a] -= chol[i, k] * p[j, a]
                if kept_i or kept_j:
                    chol[i, k] = 0.0
            if kept_i:
                chol[i, 0] = 1.0
                for a in range(3):
                    rhs[i, a] = p[i, a]
        for i in range(m):  # banded Cholesky, L in place: chol[i, k] = L(i, i - k)
            for k in range(min(i, 3), -1, -1):
                j = i - k
                acc = chol[i, k]
                for t in range(max(j - 3, 0, i - 3), j):
                    acc -= chol[i, i - t] * chol[j, j - t]
                chol[i, k] = sqrt(acc) if k == 0 else acc / chol[j, 0]
        for i in range(m):
            for a in range(3):
                acc = rhs[i, a]
                for t in range(max(i - 3, 0), i):
                    acc -= chol[i, i - t] * q[t, a]
                q[i, a] = acc / chol[i, 0]
        for i in range(m - 1, -1, -1):
            for a in range(3):
                acc = q[i, a]
                for t in range(i + 1, min(i + 4, m)):
                    acc -= chol[t, t - i] * q[t, a]
                q[i, a] = acc / chol[i, 0]
        over = False
        for i in range(n_lo, m - n_hi):
            d = sqrt((q[i, 0] - p[i, 0]) ** 2 + (q[i, 1] - p[i, 1]) ** 2 + (q[i, 2] - p[i, 2]) ** 2)
            if d > bound:
                w[i] *= 4.0 * (d / bound) ** 2
                over = True
        if not over:
            break
    for i in range(n_lo, m - n_hi):
        d = sqrt((q[i, 0] - p[i, 0]) ** 2 + (q[i, 1] - p[i, 1]) ** 2 + (q[i, 2] - p[i, 2]) ** 2)
        if d > bound:
            for a in range(3):
                q[i, a] = p[i, a] + (q[i, a] - p[i, a]) * bound / d


@njit(cache=True)
def fitted_midpoints(start, unit, length, chain, tol, share, lam):
    """The midpoint (n, 3) and tangent (n, 3) of each of the n lines (start, unit, length) on the
    fitted polyline of its run of `chain` corners (corner j joins lines j and j + 1); the line's own
    elsewhere. A run's points are its vertices and its lines' midpoints, so that a line bends at
    its midpoint as well (with the vertices alone g1_lhchips4 ran 221.1 s, with the midpoints too
    198.3 s); the fit moves them within share x the run's smallest P, and a midpoint's tangent is
    the chord of the two points beside it. The run's two end lines keep their points. A run whose
    fitted polyline turns back against its lines' directions keeps its lines."""
    n = length.shape[0]
    mid, tan = np.empty((n, 3)), unit.copy()
    for i in range(n):
        for a in range(3):
            mid[i, a] = start[i, a] + 0.5 * length[i] * unit[i, a]
    j = 0
    while j < n - 1:
        if not chain[j]:
            j += 1
            continue
        b = j
        while b < n - 1 and chain[b]:
            b += 1
        first, lines = j, b - j + 1  # corners first..b-1 join lines first..b
        j = b
        if lines < 3:
            continue
        m = 2 * lines + 1
        p = np.empty((m, 3))  # the start and the midpoint of each line, then the last one's end
        bound = np.inf
        for i in range(lines):
            k = first + i
            for a in range(3):
                p[2 * i, a] = start[k, a]
                p[2 * i + 1, a] = mid[k, a]
                p[2 * i + 2, a] = start[k, a] + length[k] * unit[k, a]
            if i < lines - 1:
                bound = min(bound, share * tol[k])
        q = np.empty((m, 3))
        _fit(p, bound, lam, 3, 3, q)
        ok = True
        for e in range(m - 1):
            d0, d1, d2 = q[e + 1, 0] - q[e, 0], q[e + 1, 1] - q[e, 1], q[e + 1, 2] - q[e, 2]
            u = unit[first + e // 2]
            if not sqrt(d0 * d0 + d1 * d1 + d2 * d2) * _TURN_MAX_COS < d0 * u[0] + d1 * u[1] + d2 * u[2]:
                ok = False
        if not ok:
            continue
        for i in range(1, lines - 1):
            k, c = first + i, 2 * i + 1
            d0, d1, d2 = q[c + 1, 0] - q[c - 1, 0], q[c + 1, 1] - q[c - 1, 1], q[c + 1, 2] - q[c - 1, 2]
            ell = sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            mid[k, 0], mid[k, 1], mid[k, 2] = q[c, 0], q[c, 1], q[c, 2]
            tan[k, 0], tan[k, 1], tan[k, 2] = d0 / ell, d1 / ell, d2 / ell
    return mid, tan
