"""The recursive constant-chord parameter update of 000 §2.2, and an adaptive variant.

Paper mode (fixed count): the first guess is eq. 8 (steady state) or eq. 12 (start-up),
each refinement is eq. 9 / eq. 14, and the point at the n1-th (m1-th) increment is the
output: n1 curve evaluations per period, the output point included.

Tolerance mode (§2.2.1 for the start-up; `chord_tol_pct` for every period): trial points
are evaluated until the chord is within the tolerance of d, and the accepted trial *is*
the output point.

Adaptive mode (`secant`): the update is not eq. 9 but a root of the quadratic signed-chord
model sigma(du) = a du + b du^2 through the origin and the two latest known points (the
previous step seen backwards counts as one: sigma(-du_{j-1}) = -s_{j-1}), kept inside the
bracket of trials found so far. Where it leaves the bracket, or two trials in a row fall on
the same side of d (a kink in the curve), the Illinois variant of regula falsi on the
bracket takes over; eq. 9 serves until an overshoot closes the bracket. Should the cap
stop it on a trial beyond d(1 + tol), the longest trial short of d is output instead, so
an adaptive chord never exceeds d(1 + tol). With `bisect_past_cap` (the feed stage, whose
driver would have to catch up a short chord within the next periods) the cap does not stop
the solve: past it the bracket is halved (doubling until an overshoot closes it) until the
chord is within the tolerance or the bracket is one float wide, so a period falls short of
its chord by no more than float resolution.

A zero chord (a stretch where the curve stands still) doubles the increment instead of
dividing by zero, so the parameter always moves forward.
"""
from __future__ import annotations

from math import inf, sqrt
from typing import NamedTuple

from numba import njit

from ipo.nurbs.compiled import dist3, poly_point, poly_span

STARTUP_CAP = 64  # evaluations a tolerance start-up may spend before it takes its last trial


class ChordRule(NamedTuple):
    """When recursive_step accepts a trial, and how it makes the next one."""

    n_fixed: int  # paper mode (tol < 0): the increment whose point is the output (n1 or m1)
    tol: float  # tolerance modes: relative chord tolerance (< 0: paper mode)
    cap: int  # tolerance modes: evaluations before the last trial is taken
    secant: bool  # the adaptive update (see the module docstring) instead of eq. 9
    bisect_past_cap: bool  # adaptive update: past the cap, bisect to the tolerance (module docstring)


@njit(cache=True)
def eq9(d, du, s):
    """Delta u_{jk} = d * Delta u_{j(k-1)} / s_{j(k-1)}; doubled where the chord is zero."""  # 000 eq. 9, 14
    if s > 0.0:
        return d * du / s
    return 2.0 * du


@njit(cache=True)
def predict_ratio(g1, s1, g2, s2, d):
    """Delta u per mm for the next step, linearly extrapolated in arc length from the last
    two ratios (eq. 8 alone is the constant extrapolation), kept within a factor 2 of eq. 8."""
    r1 = g1 / s1
    if s2 <= 0.0:
        return r1
    r2 = g2 / s2
    r = r1 + (r1 - r2) * (s1 + d) / (s1 + s2)
    return min(max(r, 0.5 * r1), 2.0 * r1)


@njit(cache=True)
def _quadratic_root(d, xa, ya, xb, yb):
    """Positive du with a du + b du^2 = d for the quadratic through (0,0), (xa,ya), (xb,yb);
    -1 where the model has no usable root."""
    if xa == xb or xa == 0.0 or xb == 0.0:
        return -1.0
    qa = ya / xa
    qb = yb / xb
    b = (qb - qa) / (xb - xa)
    a = qa - b * xa
    disc = a * a + 4.0 * b * d
    if a <= 0.0 or disc < 0.0:
        return -1.0
    return 2.0 * d / (a + sqrt(disc))


@njit(cache=True)
def recursive_step(curve, rule, span, u, p, d, g, prev):
    """One period from P(u) = p on the curve (ipo.nurbs.compiled.SpanCurve) towards chord d,
    starting from the guess g, under the ChordRule `rule`.

    prev: the previous step (Delta u_{j-1}, s_{j-1}) for the secant model, s = 0 if none.
    A trial at or beyond u_max is the end point; when that end lies within d (plus the
    tolerance) the period ends the curve.
    Returns (du, x, y, z, chord, evals, at_end, span)."""
    n_fixed, tol, cap, secant, bisect_past_cap = rule
    bisect_past_cap = bisect_past_cap and secant and tol >= 0.0
    breaks, inv_h, coef, end = curve.breaks, curve.inv_h, curve.coef, curve.end
    ru = curve.u_max - u
    px, py, pz = p
    gb, sb = prev
    evals = 0
    k = 1
    lo, flo = 0.0, -d  # bracket of du with chord - d below and above zero
    hi, fhi = inf, inf
    xl, yl, zl, sl = px, py, pz, 0.0  # the point at lo: short of d
    streak = 0  # trials in a row on the same side of d
    short = False  # the previous trial fell short of d
    xa, ya = -gb, -sb
    while True:
        clamped = g >= ru
        if clamped:
            g = ru
            x, y, z = end[0], end[1], end[2]
        else:
            span = poly_span(breaks, u + g, span)
            x, y, z = poly_point(breaks, inv_h, coef, span, u + g)
        evals += 1
        s = dist3(px, py, pz, x, y, z)
        if clamped and s <= d * (1.0 + max(tol, 0.0)):
            return g, x, y, z, s, evals, True, span
        if tol < 0.0:
            accept = k >= n_fixed and not clamped
        else:
            accept = not clamped and (abs(s - d) <= tol * d or (evals >= cap and not bisect_past_cap))
        if accept:
            if tol >= 0.0 and s > d * (1.0 + tol) and lo > 0.0:  # capped: never overshoot d
                return lo, xl, yl, zl, sl, evals, False, span
            return g, x, y, z, s, evals, False, span
        if not secant:
            gn = eq9(d, g, s)
        else:
            streak = streak + 1 if streak > 0 and (s < d) == short else 1
            short = s < d
            if short:
                lo, flo = g, s - d
                xl, yl, zl, sl = x, y, z, s
            else:
                hi, fhi = g, s - d
            if streak >= 2:  # Illinois: the end that keeps staying counts half
                if short:
                    fhi *= 0.5
                else:
                    flo *= 0.5
            gn = -1.0
            if s > 0.0 and ya != 0.0 and streak < 2:
                gn = _quadratic_root(d, xa, ya, g, s)
            if not (lo < gn < hi):
                if hi < inf:
                    gn = lo - flo * (hi - lo) / (fhi - flo)
                else:  # no overshoot yet: eq. 9, or doubling where the chord hardly grows
                    gn = eq9(d, g, s) if streak < 3 else max(eq9(d, g, s), 2.0 * g)
            if not (lo < gn < hi) or evals >= cap:
                gn = 0.5 * (lo + hi) if hi < inf else 2.0 * g
                if evals >= cap and not (lo < gn < hi):  # the bracket is one float wide
                    if lo > 0.0:
                        return lo, xl, yl, zl, sl, evals, False, span
                    return g, x, y, z, s, evals, False, span
            if s > 0.0:
                xa, ya = g, s
        g = gn
        k += 1
