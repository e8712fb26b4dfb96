"""Compiled closest-point search for the rational fit (ipo.fit.rational, ipo.fit.tolerance).

001's parameter correction (eq. 10–11) and the tolerance check both look for, per point,
the parameter of the nearest curve point in a bracket. The curve is given as one
polynomial per knot span in homogeneous form (SpanPolynomials.homogeneous), so each
evaluation is a Horner pass and a division: thousands of points times ~30 golden-section
steps are cheap in a loop and costly as numpy calls.
"""
from __future__ import annotations

import numpy as np
from numba import njit

GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


@njit(cache=True)
def _dist2(poly, starts, p, u):
    """|p - C(u)|^2 with C the rational curve of the homogeneous span polynomials poly (S, power, dim+1)."""
    k = np.searchsorted(starts, u, side="right") - 1
    k = min(max(k, 0), starts.shape[0] - 1)
    x = u - starts[k]
    deg = poly.shape[1] - 1
    dim = poly.shape[2] - 1
    den = poly[k, deg, dim]
    for power in range(deg - 1, -1, -1):
        den = den * x + poly[k, power, dim]
    out = 0.0
    for a in range(dim):
        num = poly[k, deg, a]
        for power in range(deg - 1, -1, -1):
            num = num * x + poly[k, power, a]
        diff = p[a] - num / den
        out += diff * diff
    return out


@njit(cache=True)
def foot_params(poly, starts, pts, lo, hi, iterations):
    """Per point pts[j], the golden-section minimiser of |pts[j] - C(u)|^2 on [lo[j], hi[j]]."""  # 001 eq. 11
    out = np.empty(pts.shape[0])
    for j in range(pts.shape[0]):
        p = pts[j]
        a, b = lo[j], hi[j]
        c = b - GOLDEN * (b - a)
        d = a + GOLDEN * (b - a)
        fc = _dist2(poly, starts, p, c)
        fd = _dist2(poly, starts, p, d)
        for _ in range(iterations):
            if fc < fd:
                b, d, fd = d, c, fc
                c = b - GOLDEN * (b - a)
                fc = _dist2(poly, starts, p, c)
            else:
                a, c, fc = c, d, fd
                d = a + GOLDEN * (b - a)
                fd = _dist2(poly, starts, p, d)
        out[j] = 0.5 * (a + b)
    return out
