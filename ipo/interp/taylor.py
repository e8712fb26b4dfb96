"""Taylor parameter update, the classical baseline (002 eq. 7, algorithms.md §4).

With s(u) the arc length, du/ds = 1/|P'| and d2u/ds2 = -(P'.P'')/|P'|^4, so
    u_{i+1} = u_i + ds/|P'| - ds^2 (P'.P'') / (2 |P'|^4)        (002 eq. 7, dot-product form)
The first-order update drops the last term. Each period evaluates the point and its two
derivatives once, at the output parameter; those derivatives drive the next update.
"""
from __future__ import annotations

from math import isfinite, sqrt

from numba import njit

from ipo.nurbs.compiled import dist3, poly_derivs2, poly_span

# Where |ds (P'.P'') / (2|P'|^3)| is not small the series is meaningless; the second-order
# factor is kept within these bounds so the step stays forward and finite.
_FACTOR_MIN = 0.5
_FACTOR_MAX = 2.0


@njit(cache=True)
def taylor_delta_u(ds, d1x, d1y, d1z, d2x, d2y, d2z, order):
    """Parameter increment for arc length ds from P' and P'' (002 eq. 7); -1 where P' = 0."""
    speed2 = d1x * d1x + d1y * d1y + d1z * d1z
    if not speed2 > 0.0:
        return -1.0
    speed = sqrt(speed2)
    du = ds / speed
    if order == 2:
        f = 1.0 - ds * (d1x * d2x + d1y * d2y + d1z * d2z) / (2.0 * speed2 * speed)  # 002 eq. 7
        du *= min(max(f, _FACTOR_MIN), _FACTOR_MAX)
    if not (isfinite(du) and du > 0.0):
        return -1.0
    return du


@njit(cache=True)
def taylor_step(curve, span, u, p, d, der, order, fallback_du):
    """One period of chord d from P(u) = p on the curve (ipo.nurbs.compiled.SpanCurve):
    update u by eq. 7 from the derivatives in der (3, 3) at u, then evaluate the new point
    and its derivatives into der. fallback_du is used where P' vanishes.
    Returns (du, x, y, z, chord, evals, at_end, span)."""
    breaks, inv_h, coef, end = curve.breaks, curve.inv_h, curve.coef, curve.end
    ru = curve.u_max - u
    px, py, pz = p
    g = taylor_delta_u(d, der[1, 0], der[1, 1], der[1, 2], der[2, 0], der[2, 1], der[2, 2], order)
    if g <= 0.0:
        g = fallback_du
    if g >= ru:
        s = dist3(px, py, pz, end[0], end[1], end[2])
        return ru, end[0], end[1], end[2], s, 1, True, span
    span = poly_span(breaks, u + g, span)
    poly_derivs2(breaks, inv_h, coef, span, u + g, der)
    x, y, z = der[0, 0], der[0, 1], der[0, 2]
    return g, x, y, z, dist3(px, py, pz, x, y, z), 1, False, span
