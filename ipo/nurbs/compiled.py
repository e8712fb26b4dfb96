"""Compiled scalar NURBS evaluation for the per-period loops (one u at a time).

Two forms of the same curve (000 eq. 1-4):
- Cox-de Boor on the knot vector (find_span, basis, point): the textbook
  path (NURBS Book A2.1, A2.2, A4.1), used to build and to check the fast form.
- The span polynomials: on each non-empty knot span the homogeneous curve
  A(u) = sum N_i h_i B_i, w(u) = sum N_i h_i is a polynomial of degree p, stored in
  power form in the local variable t = (u - a) / (b - a) in [0, 1]. A point then
  costs one span lookup (reusing the last span) and p Horner steps per coordinate:
  this is the specialised basis evaluation the interpolators run on.
The span-polynomial functions allocate nothing; the Cox-de Boor ones allocate small scratch
arrays and serve checks, not the per-period loops.

`compile_curve` returns the curve as one record, `SpanCurve` (a NamedTuple, which numba
compiles as a struct): the interpolators' kernels take that (ipo.interp); the evaluation
functions here take the arrays they read.
"""
from __future__ import annotations

from math import factorial, sqrt
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.nurbs.kernel import basis_derivs


@njit(cache=True)
def find_span(knots, degree, u, hint):
    """Index i with U[i] <= u < U[i+1] on a non-empty span, starting the walk at `hint`;
    u_max maps to the last non-empty span."""
    n = knots.shape[0] - degree - 2
    s = min(max(hint, degree), n)
    while s < n and u >= knots[s + 1]:
        s += 1
    while s > degree and u < knots[s]:
        s -= 1
    return s


@njit(cache=True)
def basis(knots, degree, span, u, out, left, right):
    """Non-zero basis functions N_{span-p..span,p}(u) into out (p+1); left/right are scratch (p+1)."""  # 000 eq. 2-3
    out[0] = 1.0
    for j in range(1, degree + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = 0.0
        for r in range(j):
            temp = out[r] / (right[r + 1] + left[j - r])
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@njit(cache=True)
def point(degree, knots, pw, u, span, out):
    """C(u) into out (3) from homogeneous control points pw (n, 4) = (h*B, h)."""  # 000 eq. 4
    nb = np.empty(degree + 1)
    left = np.empty(degree + 1)
    right = np.empty(degree + 1)
    basis(knots, degree, span, u, nb, left, right)
    a0 = a1 = a2 = w = 0.0
    for r in range(degree + 1):
        i = span - degree + r
        a0 += nb[r] * pw[i, 0]
        a1 += nb[r] * pw[i, 1]
        a2 += nb[r] * pw[i, 2]
        w += nb[r] * pw[i, 3]
    out[0] = a0 / w
    out[1] = a1 / w
    out[2] = a2 / w


@njit(cache=True)
def _rational2(aw, out):
    """Rational C, C', C'' from the homogeneous A, A', A'' and w, w', w'' (rows of aw)."""
    w0, w1, w2 = aw[0, 3], aw[1, 3], aw[2, 3]
    for c in range(3):
        c0 = aw[0, c] / w0
        c1 = (aw[1, c] - w1 * c0) / w0
        out[0, c] = c0
        out[1, c] = c1
        out[2, c] = (aw[2, c] - 2.0 * w1 * c1 - w2 * c0) / w0


class SpanCurve(NamedTuple):
    """A clamped NURBS as the per-period kernels read it (compile_curve)."""

    breaks: np.ndarray  # (S+1) the ends of the non-empty knot spans
    inv_h: np.ndarray  # (S) 1 / span width
    coef: np.ndarray  # (S, p+1, 4): [i, k] the k-th power-form coefficient in t of (h*B, h) on span i
    end: np.ndarray  # (3) the last control point, where the curve ends
    u_min: float
    u_max: float
    polygon_mm: float  # length of the control polygon (000 eq. 10)


def compile_curve(degree: int, knots: np.ndarray, weights: np.ndarray, points: np.ndarray) -> SpanCurve:
    """The span polynomials of a clamped NURBS, with its end and parameter range."""
    knots = np.asarray(knots, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    p = int(degree)
    breaks = np.unique(knots[p:len(knots) - p])
    a, b = breaks[:-1], breaks[1:]
    pw = np.hstack([points * weights[:, None], weights[:, None]])
    ders = basis_derivs(knots, p, a, p)  # at the left end of each span, from the right
    span = np.searchsorted(knots, a, side="right") - 1
    idx = span[:, None] - p + np.arange(p + 1)[None, :]
    hom = np.einsum("kmi,mic->mkc", ders, pw[idx])
    h = b - a
    scale = np.array([h**k / factorial(k) for k in range(p + 1)]).T  # (S, p+1)
    coef = np.ascontiguousarray(hom * scale[:, :, None])
    return SpanCurve(breaks, 1.0 / h, coef, np.ascontiguousarray(points[-1]), float(knots[0]), float(knots[-1]),
                     float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()))


@njit(cache=True)
def poly_span(breaks, u, hint):
    """Span i of the polynomial form with breaks[i] <= u < breaks[i+1]; u_max -> last span."""
    last = breaks.shape[0] - 2
    s = min(max(hint, 0), last)
    while s < last and u >= breaks[s + 1]:
        s += 1
    while s > 0 and u < breaks[s]:
        s -= 1
    return s


@njit(cache=True)
def poly_point(breaks, inv_h, coef, span, u):
    """C(u) as a tuple (x, y, z) on a span found by poly_span."""
    t = (u - breaks[span]) * inv_h[span]
    c = coef[span]
    p = c.shape[0] - 1
    x, y, z, w = c[p, 0], c[p, 1], c[p, 2], c[p, 3]
    for k in range(p - 1, -1, -1):
        x = x * t + c[k, 0]
        y = y * t + c[k, 1]
        z = z * t + c[k, 2]
        w = w * t + c[k, 3]
    iw = 1.0 / w
    return x * iw, y * iw, z * iw


@njit(cache=True)
def _horner2(c, q, t):
    """Column q of a power-form polynomial and its first two t-derivatives at t."""
    p = c.shape[0] - 1
    v0 = c[p, q]
    v1 = 0.0
    v2 = 0.0
    for k in range(p - 1, -1, -1):
        v2 = v2 * t + 2.0 * v1
        v1 = v1 * t + v0
        v0 = v0 * t + c[k, q]
    return v0, v1, v2


@njit(cache=True)
def poly_derivs2(breaks, inv_h, coef, span, u, out):
    """C(u), C'(u), C''(u) (derivatives in u) into out (3, 3)."""
    t = (u - breaks[span]) * inv_h[span]
    c = coef[span]
    ih = inv_h[span]
    w0, w1, w2 = _horner2(c, 3, t)
    w1 *= ih
    w2 *= ih * ih
    for q in range(3):
        a0, a1, a2 = _horner2(c, q, t)
        c0 = a0 / w0
        c1 = (a1 * ih - w1 * c0) / w0
        out[0, q] = c0
        out[1, q] = c1
        out[2, q] = (a2 * ih * ih - 2.0 * w1 * c1 - w2 * c0) / w0


@njit(cache=True)
def dist3(x0, y0, z0, x1, y1, z1):
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    return sqrt(dx * dx + dy * dy + dz * dz)
