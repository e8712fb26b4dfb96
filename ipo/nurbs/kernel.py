"""The one NURBS geometry kernel, vectorised over many parameters at once.

Curves are given as plain arrays (degree p, knots U, weights h, control points B)
so that the interpolators, the feed stage and the fitting code share this module
without knowing about G-code. Algorithms follow The NURBS Book (A2.1–A2.3, A4.2);
000 eq. 1–4 define the curve. A2.3 (basis_derivs, under every derivative) runs compiled, u by u in
the array form's order of operations: the feed stage's tables evaluate a curve at a few hundred u
a round, where the array form spent its time in a hundred small numpy calls.
"""
from __future__ import annotations

from math import comb

import numpy as np
from numba import njit


def find_span(knots: np.ndarray, degree: int, u: np.ndarray) -> np.ndarray:
    """Index i with U[i] <= u < U[i+1] and a non-empty span; u_max maps to the last span."""
    n = len(knots) - degree - 2
    span = np.searchsorted(knots, u, side="right") - 1
    return np.clip(span, degree, n)


def basis(knots: np.ndarray, degree: int, u: np.ndarray, span: np.ndarray | None = None) -> np.ndarray:
    """Non-zero basis functions N_{span-p..span, p}(u), shape (len(u), p+1)."""  # 000 eq. 2-3
    u = np.atleast_1d(np.asarray(u, dtype=float))
    if span is None:
        span = find_span(knots, degree, u)
    n_u = len(u)
    out = np.zeros((n_u, degree + 1))
    out[:, 0] = 1.0
    left = np.zeros((degree + 1, n_u))
    right = np.zeros((degree + 1, n_u))
    for j in range(1, degree + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = np.zeros(n_u)
        for r in range(j):
            temp = out[:, r] / (right[r + 1] + left[j - r])
            out[:, r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[:, j] = saved
    return out


def basis_derivs(knots: np.ndarray, degree: int, u: np.ndarray, n_derivs: int,
                 span: np.ndarray | None = None) -> np.ndarray:
    """Basis functions and their derivatives, shape (n_derivs+1, len(u), p+1) (NURBS Book A2.3)."""
    u = np.atleast_1d(np.asarray(u, dtype=float))
    if span is None:
        span = find_span(knots, degree, u)
    return _basis_derivs(np.asarray(knots, dtype=float), int(degree), u, int(n_derivs), span)


@njit(cache=True, error_model="numpy")
def _basis_derivs(knots, p, u, n_derivs, span):
    """A2.3 at every u (its knot span given), the NURBS Book's array form evaluated u by u: the
    same arithmetic in the same order as that form over arrays of u (its 0 + x sums kept,
    which turn -0 into 0), so the same bits (tests/ipo/nurbs/test_basis_derivs.py)."""
    m = u.shape[0]
    ders = np.zeros((n_derivs + 1, m, p + 1))
    ndu = np.empty((p + 1, p + 1))
    left = np.zeros(p + 1)
    right = np.zeros(p + 1)
    a = np.empty((2, p + 1))
    for e in range(m):
        x, sp = u[e], span[e]
        ndu[:] = 0.0
        ndu[0, 0] = 1.0
        for j in range(1, p + 1):
            left[j] = x - knots[sp + 1 - j]
            right[j] = knots[sp + j] - x
            saved = 0.0
            for r in range(j):
                ndu[j, r] = right[r + 1] + left[j - r]
                temp = ndu[r, j - 1] / ndu[j, r]
                ndu[r, j] = saved + right[r + 1] * temp
                saved = left[j - r] * temp
            ndu[j, j] = saved
        for r in range(p + 1):
            ders[0, e, r] = ndu[r, p]
        a[:] = 0.0
        for r in range(p + 1):
            s1, s2 = 0, 1
            a[0, 0] = 1.0
            for k in range(1, n_derivs + 1):
                d = 0.0
                rk, pk = r - k, p - k
                if r >= k:
                    a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                    d = a[s2, 0] * ndu[rk, pk]
                j1 = 1 if rk >= -1 else -rk
                j2 = k - 1 if r - 1 <= pk else p - r
                for j in range(j1, j2 + 1):
                    a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                    d = d + a[s2, j] * ndu[rk + j, pk]
                if r <= pk:
                    a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                    d = d + a[s2, k] * ndu[r, pk]
                ders[k, e, r] = d
                s1, s2 = s2, s1
    factor = float(p)
    for k in range(1, n_derivs + 1):
        for e in range(m):
            for r in range(p + 1):
                ders[k, e, r] *= factor
        factor *= p - k
    return ders


def curve_derivs(degree: int, knots: np.ndarray, weights: np.ndarray, points: np.ndarray,
                 u: np.ndarray, n_derivs: int = 0) -> np.ndarray:
    """C(u) and its derivatives d^k C/du^k, shape (n_derivs+1, len(u), dim) (NURBS Book A4.2)."""
    u = np.atleast_1d(np.asarray(u, dtype=float))
    span = find_span(knots, degree, u)
    ders = basis_derivs(knots, degree, u, n_derivs, span)
    idx = span[:, None] - degree + np.arange(degree + 1)[None, :]
    w = weights[idx]
    wp = points[idx] * w[..., None]
    a_ders = np.einsum("kmi,mid->kmd", ders, wp)
    w_ders = np.einsum("kmi,mi->km", ders, w)
    out = np.empty_like(a_ders)
    for k in range(n_derivs + 1):
        v = a_ders[k].copy()
        for i in range(1, k + 1):
            v -= comb(k, i) * w_ders[i][:, None] * out[k - i]
        out[k] = v / w_ders[0][:, None]
    return out


def curve_points(degree: int, knots: np.ndarray, weights: np.ndarray, points: np.ndarray,
                 u: np.ndarray) -> np.ndarray:
    """C(u), shape (len(u), dim)."""  # 000 eq. 1
    return curve_derivs(degree, knots, weights, points, u, 0)[0]


def curvature(degree: int, knots: np.ndarray, weights: np.ndarray, points: np.ndarray,
              u: np.ndarray) -> np.ndarray:
    """Curvature |C' x C''| / |C'|^3 in 1/mm; 0 where the derivative vanishes."""
    d = curve_derivs(degree, knots, weights, points, u, 2)
    d1, d2 = d[1], d[2]
    if d1.shape[1] == 2:
        cross = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    else:
        cross = np.linalg.norm(np.cross(d1, d2), axis=1)
    speed = np.linalg.norm(d1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(speed > 0, cross / speed**3, 0.0)
    return k


def arc_length(degree: int, knots: np.ndarray, weights: np.ndarray, points: np.ndarray,
               u0: float | None = None, u1: float | None = None, rel_tol: float = 1e-10) -> float:
    """Arc length by 8-point Gauss–Legendre quadrature of |C'(u)| on every non-empty knot span,
    each span split into more pieces until two successive refinements agree within rel_tol."""
    lo = knots[degree] if u0 is None else u0
    hi = knots[-degree - 1] if u1 is None else u1
    breaks = np.unique(np.clip(knots, lo, hi))
    xg, wg = np.polynomial.legendre.leggauss(8)
    previous = np.inf
    for level in range(12):
        pieces = 2**level
        t = np.linspace(0.0, 1.0, pieces + 1)
        edges = (breaks[:-1, None] + (breaks[1:] - breaks[:-1])[:, None] * t[None, :])
        a, b = edges[:, :-1].ravel(), edges[:, 1:].ravel()
        uu = (0.5 * (b - a)[:, None] * (xg[None, :] + 1) + a[:, None]).ravel()
        ww = (0.5 * (b - a)[:, None] * wg[None, :]).ravel()
        speed = np.linalg.norm(curve_derivs(degree, knots, weights, points, uu, 1)[1], axis=1)
        length = float(np.sum(ww * speed))
        if abs(length - previous) <= rel_tol * max(length, 1e-300):
            break
        previous = length
    return length
