"""Weights and knots of conic spans joined into one rational quadratic B-spline.

A quadratic B-spline with simple knots is C1; its span k is the rational quadratic
Bezier (J_k, P_k, J_k+1) whose end points J lie on the legs P_k P_k+1 of the control
polygon. For the spans of ipo.fit.conic_plan (control points C_k = P_k, shape weights
rho_k: the middle weight when the end weights are 1) the B-spline's weights w_k and
knot intervals h_k follow from the junctions, lambda being where J lies on its leg
(J = (1 - lambda) P_k + lambda P_k+1):

    h_k+1 / h_k = (1 - lambda) w_k+1 / (lambda w_k)     (J where the knots put it)
    1 / E = lambda / w_k+1 + (1 - lambda) / w_k          (E: J's weight in both spans)
    rho_k = w_k / sqrt(E_k E_k+1)                         (span k's shape)

With x_k = w_k / E_k: x_k+1 = lambda rho_k^2 / (rho_k^2 - (1 - lambda) x_k), which
needs rho_k^2 > (1 - lambda) x_k, and E_k+1 = E_k x_k^2 / rho_k^2. x_1 of a run is
free (any x_1 <= rho_1^2 keeps the next junction's condition); it is chosen to bring
E back to the group's first weight. A parabola (rho = 1) after x = 1 leaves x = 1 and E
as they are; conics do not, and consecutive ones drift the weights and the knot
intervals geometrically. Where the condition fails, or the drift would pass
LOG_WEIGHT_SPREAD over the group or LOG_INTERVAL_SPREAD within a run, the junction
takes a knot of multiplicity 2 instead (it becomes a control point: one block more;
the run, its x and its intervals start again; the weights' scale cannot, the point is
shared).

The controller's feed stage gives the curve the same speed |C'(u)| on both sides of every
C0 knot (ipo.feed.split.even_speed) by scaling all the knots after it, so the scales of
the runs compound along a group: a g1_lhchips4 group written with knots up to 1380 was
followed with knots up to 5.6e14 and intervals of 2e-8, which double precision cannot
table. The state therefore also follows the intervals as the feed stage evens them (log
g: at a C0 knot the speed before it, 2 (w_k / E) |J - C_k| / h_k, The NURBS Book eq. 4.9
at a clamped end, is the speed after it, 2 (w_k+1 / E) |C_k+1 - J| / h_k+1), and their
spread over the group is bounded by LOG_EVEN_SPREAD.

The state of a path at a junction (STATE values): x, log E, log w of the span into it,
log h of that span (relative to its run's first), the group's smallest and largest
log weight, the run's smallest and largest log interval, log g of that span and the
group's smallest and largest log g.
"""
from __future__ import annotations

import numpy as np
from numba import njit

STATE = 11
X, LOG_E, LOG_W, LOG_H, W_LO, W_HI, H_LO, H_HI, LOG_G, G_LO, G_HI = range(STATE)
# Each spread bound below costs blocks (a double knot where a run would pass it): g1_lhchips4 at 10 um
# wrote 4192 blocks with 1e6 / 1e4 / 1e8, 4129 with these (the controller's check refusing none); a group
# the check refuses, or off as written, is planned again in halves (ipo.fit.convert)
LOG_WEIGHT_SPREAD = np.log(1e9)  # largest / smallest weight of a group
LOG_INTERVAL_SPREAD = np.log(1e6)  # longest / shortest knot interval of a run
# longest / shortest knot interval of a group as the feed stage evens it: 1e14 let one reach 1.6e-13
# of its last knot (refused), 1e10 passed
LOG_EVEN_SPREAD = np.log(1e10)
LAMBDA_MIN = 1e-3  # a junction closer to a control point (fraction of the leg) takes a double knot
# E_k+1 / E_k of one span, either way: the span's speed in its parameter changes by this factor
# (times its arms' ratio) from one end to the other; the controller's arc-length table
# (ipo.feed.sampling) refuses a curve that moves too unevenly in u. A run's first span can
# always keep it: |2 log rho| <= 2 log 20 (ipo.fit.conic's RHO_MAX) is below it
LOG_SPAN_E_STEP = np.log(1e3)


@njit(cache=True)
def _start_run(c_prev, j, rho_prev, prev, c, rho, out):
    """A run's first span from junction j, after a span of control point c_prev, weight rho_prev and
    state prev (rho_prev = 0: the group opens at j): x_1 brings E back towards the group's first (by
    at most LOG_SPAN_E_STEP); g_1 keeps the speed on both sides of j. Whether the spreads allow it."""
    step = min(max(-prev[LOG_E], -LOG_SPAN_E_STEP), LOG_SPAN_E_STEP)
    x = min(rho * rho, rho * np.exp(0.5 * step))
    out[X] = x
    out[LOG_W] = prev[LOG_E] + np.log(x)
    out[LOG_E] = prev[LOG_E] + 2.0 * np.log(x) - 2.0 * np.log(rho)
    out[LOG_H] = 0.0
    out[W_LO] = min(prev[W_LO], out[LOG_W], out[LOG_E])
    out[W_HI] = max(prev[W_HI], out[LOG_W], out[LOG_E])
    out[H_LO] = 0.0
    out[H_HI] = 0.0
    if rho_prev > 0.0:
        before = rho_prev * rho_prev / prev[X] * np.sqrt((j - c_prev) @ (j - c_prev))
        out[LOG_G] = prev[LOG_G] + np.log(x * np.sqrt((c - j) @ (c - j)) / before)
    else:
        out[LOG_G] = 0.0
    out[G_LO] = min(prev[G_LO], out[LOG_G])
    out[G_HI] = max(prev[G_HI], out[LOG_G])
    return out[W_HI] - out[W_LO] <= LOG_WEIGHT_SPREAD and out[G_HI] - out[G_LO] <= LOG_EVEN_SPREAD


@njit(cache=True)
def junction_lambda(c_prev, j, c):
    leg = c - c_prev
    len2 = leg @ leg
    return ((j - c_prev) @ leg) / len2 if len2 > 0.0 else -1.0


@njit(cache=True)
def may_continue(c_prev, j, rho_prev, prev, c, out):
    """The state after a span of control point c that continues the run at junction j (reached by a span
    of control point c_prev, weight rho_prev, state prev) into out, all but what the span's own weight
    sets (LOG_E, and W_LO, W_HI through it); whether the spans' junction and the spreads so far allow
    that. False: a span through c costs a double knot at j (or cannot follow), whatever its weight."""
    lam = junction_lambda(c_prev, j, c)
    if not LAMBDA_MIN <= lam <= 1.0 - LAMBDA_MIN:
        return False
    den = rho_prev * rho_prev - (1.0 - lam) * prev[X]
    if den <= 0.0:
        return False
    x = lam * rho_prev * rho_prev / den
    out[X] = x
    out[LOG_W] = prev[LOG_E] + np.log(x)
    out[LOG_H] = prev[LOG_H] + np.log((1.0 - lam) / lam) + out[LOG_W] - prev[LOG_W]
    out[W_LO] = min(prev[W_LO], out[LOG_W])
    out[W_HI] = max(prev[W_HI], out[LOG_W])
    out[H_LO] = min(prev[H_LO], out[LOG_H])
    out[H_HI] = max(prev[H_HI], out[LOG_H])
    out[LOG_G] = prev[LOG_G] + out[LOG_H] - prev[LOG_H]
    out[G_LO] = min(prev[G_LO], out[LOG_G])
    out[G_HI] = max(prev[G_HI], out[LOG_G])
    return (out[W_HI] - out[W_LO] <= LOG_WEIGHT_SPREAD and out[H_HI] - out[H_LO] <= LOG_INTERVAL_SPREAD
            and out[G_HI] - out[G_LO] <= LOG_EVEN_SPREAD)


@njit(cache=True)
def follow(run_start, c_prev, j, rho_prev, prev, c, rho, out):
    """The state after a span (control point c, weight rho) that follows junction j (reached by a span
    of control point c_prev, weight rho_prev, state prev; run_start: j is a corner, or the group
    opens there with rho_prev = 0) into out, and its blocks: 1 (it continues the run, or starts
    one at j), 2 (a double knot at j), 0 (the weights cannot carry it)."""
    if not run_start and may_continue(c_prev, j, rho_prev, prev, c, out):
        out[LOG_E] = prev[LOG_E] + 2.0 * np.log(out[X]) - 2.0 * np.log(rho)
        out[W_LO] = min(out[W_LO], out[LOG_E])
        out[W_HI] = max(out[W_HI], out[LOG_E])
        if out[W_HI] - out[W_LO] <= LOG_WEIGHT_SPREAD and abs(out[LOG_E] - prev[LOG_E]) <= LOG_SPAN_E_STEP:
            return 1
    if not _start_run(c_prev, j, rho_prev, prev, c, rho, out):
        return 0
    return 1 if run_start else 2


def spline(items: list, degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Control points, weights (largest 1) and clamped knots of a group from its items, in order:
    ('start', point), ('span', C, rho, end point, double, x) and ('corner', point). Each run's
    parameter length is its chord length."""
    points = [np.asarray(items[0][1], dtype=float)]
    weights = [1.0]
    intervals: list[float] = []
    doubles: list[int] = []  # interval indices that start a run after another
    run_h: list[float] = []
    e, w_prev, c_prev, j = 1.0, 1.0, None, points[0]

    def close_run():
        chord = np.linalg.norm(np.diff(np.array(run_pts), axis=0), axis=1).sum()
        h = np.array(run_h)
        intervals.extend(h * chord / h.sum())

    run_pts = [points[0]]
    for item in items[1:]:
        if item[0] == "corner":
            c_prev = None
            continue
        _, c, rho, end, double, x = item
        if c_prev is None or double:
            if run_h:  # the junction (a corner, or a double knot) becomes a control point
                close_run()
                doubles.append(len(intervals))
                run_h, run_pts = [], [j]
                points.append(j)
                weights.append(e)
            h = 1.0
        else:
            lam = junction_lambda(c_prev, j, c)
            h = run_h[-1] * (1.0 - lam) * (x * e) / (lam * w_prev)
        w_prev = x * e
        points.append(np.asarray(c, dtype=float))
        weights.append(w_prev)
        e = w_prev * x / rho**2
        run_h.append(h)
        c_prev, j = np.asarray(c, dtype=float), np.asarray(end, dtype=float)
        run_pts.append(j)
    close_run()
    points.append(j)
    weights.append(e)
    t = np.concatenate([[0.0], np.cumsum(intervals)])
    inner: list[float] = []
    for k in range(1, len(intervals)):
        inner += [t[k]] * (2 if k in doubles else 1)
    knots = np.concatenate([[0.0] * (degree + 1), inner, [t[-1]] * (degree + 1)])
    w = np.array(weights)
    return np.array(points), w / w.max(), knots
