"""The naive baseline of 000 Fig. 7: the same parameter increment every period.

Chord lengths then follow the parametric speed |P'(u)| (000 Fig. 2-3); a period with a
zero step stands still, any other advances u by du whatever its length.
"""
from __future__ import annotations

from numba import njit

from ipo.nurbs.compiled import dist3, poly_point, poly_span


@njit(cache=True)
def constant_du_step(curve, span, u, p, du):
    """One period from P(u) = p on the curve (ipo.nurbs.compiled.SpanCurve): u + du, or the
    end point when that passes u_max. Returns (du, x, y, z, chord, evals, at_end, span)."""
    breaks, inv_h, coef, end = curve.breaks, curve.inv_h, curve.coef, curve.end
    ru = curve.u_max - u
    px, py, pz = p
    if du >= ru:
        s = dist3(px, py, pz, end[0], end[1], end[2])
        return ru, end[0], end[1], end[2], s, 1, True, span
    span = poly_span(breaks, u + du, span)
    x, y, z = poly_point(breaks, inv_h, coef, span, u + du)
    return du, x, y, z, dist3(px, py, pz, x, y, z), 1, False, span
