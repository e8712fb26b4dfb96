"""The linear programme of one look-ahead interval: how fast the machine may enter it.

Between samples k and k+1 the profile has one path acceleration s'' = (x_k+1 - x_k) / (2 ds)
(x = v^2), and every axis must hold |t_i s'' + kv_i x| <= A_i at both ends. Those are rows
p x_k + q x_k+1 <= r of a 2-variable programme (`interval_rows`); the backward pass asks for
the largest x_k with some x_k+1 in [0, b_top] (`max_start_from`), the forward pass for the
range of x_k+1 from a given x_k (`end_range`).

That largest x_k is defined by vertex enumeration: the largest x_k over the vertices of every
pair of (unit-normal) rows that meet all rows within a tolerance (max_start in
tests/ipo/feed/lp_reference.py enumerates them all). The backward pass solves
5-6 million of these programmes on a 169k-block program, so `max_start_from` first tries
the pair that was optimal in the interval before (neighbouring intervals are alike) and,
when that vertex is certified optimal, enumerates only the rows that pass near it: the
same vertices, the same arithmetic, so the same result to the bit, at a tenth of the cost.
Usually only the optimal pair's own two rows pass near it and no two rows are nearly parallel:
then there is nothing to enumerate, which a screen of the axis rows' directions tells at a
fraction of the enumeration's cost (stellabee1's backward pass 100 -> 86 ns per interval).

The kernels here are compiled without numba's runtime (`_nrt=False`, the option numba's own
`register_jitable` documents for code that allocates nothing): none of them allocates, returns
or keeps an array, and the caller holds every array it passes for the whole call. With the
runtime, each call to a kernel that calls another one updated the reference count of every
array argument (an atomic increment and decrement that numba's pruning pass leaves in place
there): 14 atomic operations per interval, 30 % of stellabee1's backward pass. A kernel that
did allocate would fail to compile, not run unsafely.
"""
from __future__ import annotations

import numpy as np
from numba import njit

_BIG = 1e300
_DET_MIN = 1e-14  # rows more parallel than this have no vertex
_ULP = 1e-15  # relative rounding of one vertex or residual, with headroom
_LAMBDA_MIN = 1e-9  # multipliers below this leave the certificate to the full enumeration
# A vertex of rows at least this far from parallel lies on both within _STABLE_RES * scale
# (Cramer's rule: residual <= 4 u scale / |det|); nearer-parallel pairs are always enumerated.
_DET_STABLE = 1e-6
_STABLE_RES = 1e-9


@njit(cache=True, _nrt=False)
def interval_rows(t, kv, k, d, a_max, scale, rows):
    """The axis limits at both ends of interval k as rows (p, q, r) of p x_k + q x_k+1 <= r,
    with s'' = (x_k+1 - x_k) / d constant in between (d = 2 ds): |t_i s'' + kv_i x| <= scale A_i
    at either end, for every axis moving there (one linear system in both ends' x, so that
    one s'' meets both ends). Returns the number of rows; rows 2j and 2j+1 are one row and
    its negation."""
    m = 0
    for j in range(2):
        kk = k + j
        for i in range(3):
            ti = t[kk, i]
            if abs(ti) <= 1e-12:
                continue
            td = ti / d  # -ti / d is -td to the bit: rounding to nearest is symmetric
            p = -td + (kv[kk, i] if j == 0 else 0.0)
            q = td + (kv[kk, i] if j == 1 else 0.0)
            lim = scale * a_max[i]
            rows[m, 0], rows[m, 1], rows[m, 2] = p, q, lim
            rows[m + 1, 0], rows[m + 1, 1], rows[m + 1, 2] = -p, -q, lim
            m += 2
    return m


@njit(cache=True, _nrt=False)
def _unit_rows(rows, m, a_top, b_top, r):
    """rows and the box 0 <= x_k <= a_top, 0 <= x_k+1 <= b_top as unit-normal rows in r;
    returns their number (the box rows, too, come in pairs of opposite normals)."""
    n = m + 4
    for i in range(0, m, 2):  # unit normals: one feasibility tolerance for every row
        h = np.sqrt(rows[i, 0] ** 2 + rows[i, 1] ** 2)
        r[i, 0], r[i, 1], r[i, 2] = rows[i, 0] / h, rows[i, 1] / h, rows[i, 2] / h
        # row i + 1 is row i negated (its limit is the same): the same h, the same quotients
        r[i + 1, 0], r[i + 1, 1], r[i + 1, 2] = -r[i, 0], -r[i, 1], r[i, 2]
    r[m, 0], r[m, 1], r[m, 2] = 1.0, 0.0, a_top
    r[m + 1, 0], r[m + 1, 1], r[m + 1, 2] = -1.0, 0.0, 0.0
    r[m + 2, 0], r[m + 2, 1], r[m + 2, 2] = 0.0, 1.0, b_top
    r[m + 3, 0], r[m + 3, 1], r[m + 3, 2] = 0.0, -1.0, 0.0
    return n


@njit(cache=True, _nrt=False)
def _feasible(r, n, a, b, tol):
    for q in range(n):
        if r[q, 0] * a + r[q, 1] * b > r[q, 2] + tol:
            return False
    return True


@njit(cache=True, _nrt=False)
def _vertex_above(r, n, tol, i, j, best, pair):
    """best, or the vertex of rows i < j if it is feasible and its x_k is larger (its pair
    into `pair`): the enumeration's arithmetic, shared by both of its forms."""
    det = r[i, 0] * r[j, 1] - r[i, 1] * r[j, 0]
    if abs(det) < _DET_MIN:
        return best
    a = (r[i, 2] * r[j, 1] - r[i, 1] * r[j, 2]) / det
    if a <= best:
        return best
    b = (r[i, 0] * r[j, 2] - r[i, 2] * r[j, 0]) / det
    if not _feasible(r, n, a, b, tol):
        return best
    pair[0], pair[1] = i, j
    return a


@njit(cache=True, _nrt=False)
def _best_vertex(r, n, tol, best, pair):
    """The largest x_k over the feasible vertices of all pairs of rows (above `best` only)."""
    for i in range(n):
        for j in range(i + 1, n):
            best = _vertex_above(r, n, tol, i, j, best, pair)
    return best


@njit(cache=True, _nrt=False)
def _near_vertex(r, n, tol, near, best, pair):
    """_best_vertex over the pairs of rows that are both `near`, or nearly parallel (rows
    2k and 2k+1 are opposite: each pair of directions stands for four pairs of rows)."""
    for e in range(0, n, 2):
        for f in range(e + 2, n, 2):
            det = r[e, 0] * r[f, 1] - r[e, 1] * r[f, 0]
            if abs(det) < _DET_MIN:
                continue
            stable = abs(det) >= _DET_STABLE
            for i in (e, e + 1):
                for j in (f, f + 1):
                    if not stable or (near[i] and near[j]):
                        best = _vertex_above(r, n, tol, i, j, best, pair)
    return best


@njit(cache=True, _nrt=False)
def _any_unstable(r, m):
    """Whether _near_vertex may meet two rows of different directions that are nearly parallel
    (it enumerates those whatever their distance): two of the m rows of the axis limits, or one
    of them and a box row, whose normal (1, 0) or (0, 1) makes the determinant the row's other
    component, exactly. A NaN counts as nearly parallel, as it does there."""
    for e in range(0, m, 2):
        if not (abs(r[e, 0]) >= _DET_STABLE and abs(r[e, 1]) >= _DET_STABLE):
            return True
        for f in range(e + 2, m, 2):
            d = abs(r[e, 0] * r[f, 1] - r[e, 1] * r[f, 0])
            if not (d < _DET_MIN or d >= _DET_STABLE):
                return True
    return False


@njit(cache=True, _nrt=False)
def _certified(r, n, tol, a_top, b_top, i, j, near, pair):
    """The enumeration's value from the vertex of rows i < j if it can be certified there (steps
    1-3 of max_start_from), else -2; the optimum's pair into `pair`."""
    # 1. the hinted vertex
    det = r[i, 0] * r[j, 1] - r[i, 1] * r[j, 0]
    if abs(det) < _DET_MIN:
        return -2.0
    a0 = (r[i, 2] * r[j, 1] - r[i, 1] * r[j, 2]) / det
    b0 = (r[i, 0] * r[j, 2] - r[i, 2] * r[j, 0]) / det
    if not _feasible(r, n, a0, b0, tol):
        return -2.0
    pair[0], pair[1] = i, j
    if a0 >= a_top:
        return a_top  # the cap binds: no vertex can give more
    # 2. the certificate
    l1 = r[j, 1] / det
    l2 = -r[i, 1] / det
    if not (l1 > _LAMBDA_MIN and l2 > _LAMBDA_MIN):
        return -2.0
    scale = 1.0 + abs(a0) + abs(b0) + a_top + b_top
    for q in range(n):
        scale = max(scale, abs(r[q, 2]))
    res = abs(r[i, 0] * a0 + r[i, 1] * b0 - r[i, 2]) + abs(r[j, 0] * a0 + r[j, 1] * b0 - r[j, 2])
    tau = tol + 4.0 * res + 8.0 * _ULP * scale
    reach = 2.0 * tau * (max(1.0, l2 / l1) + max(1.0, l1 / l2)) / abs(det)
    # 3. the rows near v0, and their pairs
    n_near = 0
    for q in range(n):
        near[q] = abs(r[q, 0] * a0 + r[q, 1] * b0 - r[q, 2]) <= 2.0 * reach + _STABLE_RES * scale
        n_near += near[q]
    if n_near == 2 and near[i] and near[j] and not _any_unstable(r, n - 4):
        # the usual case: _near_vertex would try (i, j) alone, the same arithmetic as v0's
        return min(a0, a_top)
    return min(_near_vertex(r, n, tol, near, a0, pair), a_top)


@njit(cache=True, _nrt=False)
def _b_range(r, n, a):
    """The rows that bound x_k+1 tightest from above and from below at x_k = a, and the gap
    between those bounds (negative: no x_k+1 fits)."""
    up, hi, lo_row, lo = -1, _BIG, -1, -_BIG
    for q in range(n):
        if r[q, 1] > 0.0:
            bound = (r[q, 2] - r[q, 0] * a) / r[q, 1]
            if bound < hi:
                up, hi = q, bound
        elif r[q, 1] < 0.0:
            bound = (r[q, 2] - r[q, 0] * a) / r[q, 1]
            if bound > lo:
                lo_row, lo = q, bound
    return up, lo_row, hi - lo


@njit(cache=True, _nrt=False)
def _vertex_guess(r, n, m):
    """A first guess at the optimum's pair of rows (i < j; -1, -1: none), for the certificate
    (_certified) to accept or refuse.

    For each x_k = a the rows leave x_k+1 an interval between the lowest upper bound and the
    highest lower bound; their gap is concave in a, and the optimum is the largest a where
    it is >= 0 (and the rows on x_k alone allow it). Start at x_k = a_top (row m); while the
    gap there is negative, move a to where the two binding rows' bounds meet (one Newton
    step on a piecewise linear function: it never overshoots the root of a concave one)."""
    a = r[m, 2]
    for q in range(n):  # rows on x_k alone (x_k <= a_top among them)
        if r[q, 1] == 0.0 and r[q, 0] > 0.0:
            a = min(a, r[q, 2] / r[q, 0])
    up, lo, gap = _b_range(r, n, a)
    if up < 0:
        return -1, -1
    if gap >= 0.0:  # the top itself fits
        return (min(up, m), max(up, m)) if a == r[m, 2] else (-1, -1)
    for _ in range(n):
        slope = -r[up, 0] / r[up, 1] + r[lo, 0] / r[lo, 1]  # d gap / d a
        if not slope < 0.0:
            return -1, -1
        a_next = a - gap / slope
        if not a_next < a:
            break
        a = a_next
        up_next, lo_next, gap = _b_range(r, n, a)
        if (up_next == up and lo_next == lo) or gap >= 0.0:
            break
        up, lo = up_next, lo_next
    return min(up, lo), max(up, lo)


@njit(cache=True, _nrt=False)
def max_start_from(rows, m, a_top, b_top, r, pairs, near):
    """The enumeration's value, bit for bit, trying first the pairs of rows in `pairs` (4,): the optimum of
    the last interval and the one before it that differed (neighbouring intervals are
    alike; updated to this interval's), then a guess (_vertex_guess). r (m + 4, 3) and near (m + 4,) are scratch.

    1. A hinted pair's vertex v0 = (a0, b0), if it is feasible.
    2. The certificate: the objective (1, 0) = l1 n_i + l2 n_j with both l > 0. Then every
       feasible vertex with a > a0 lies within the tolerance of both rows' half-planes and
       beyond a0: a triangle of diameter D around v0, and both its rows pass within D of v0.
    3. Enumerate the pairs of rows that pass within D of v0 (usually the hinted pair alone)
       and the nearly parallel pairs (whose computed vertex may lie off both rows), with
       the full feasibility check: the same vertices the enumeration keeps that can beat
       a0, computed the same way.
    Anything else (no hint, an infeasible or uncertified vertex) enumerates every pair."""
    n = _unit_rows(rows, m, a_top, b_top, r)
    tol = 1e-9 * max(1.0, b_top)
    last_i, last_j = pairs[0], pairs[1]
    x = -2.0
    for h in range(3):
        if h < 2:
            i, j = pairs[2 * h], pairs[2 * h + 1]
        else:
            i, j = _vertex_guess(r, n, m)
        if 0 <= i < j < n:
            x = _certified(r, n, tol, a_top, b_top, i, j, near, pairs)
            if x > -2.0:
                break
    if x == -2.0:
        x = min(_best_vertex(r, n, tol, -1.0, pairs), a_top)
    if pairs[0] != last_i or pairs[1] != last_j:
        pairs[2], pairs[3] = last_i, last_j
    return x


@njit(cache=True, _nrt=False)
def end_range(rows, m, a):
    """Range [lo, hi] of x_k+1 that the rows allow from x_k = a (lo > hi: none)."""
    lo = 0.0
    hi = _BIG
    for i in range(m):
        q = rows[i, 1]
        rest = rows[i, 2] - rows[i, 0] * a
        if q > 0.0:
            hi = min(hi, rest / q)
        elif q < 0.0:
            lo = max(lo, rest / q)
        elif rest < 0.0:
            lo = _BIG
    return lo, hi
