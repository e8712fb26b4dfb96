"""Constant-chord stepping along lines and arcs (the exact geometry, no parameter guessing).

Both steppers follow the contract in ipo/contracts.py: each period's point lies at chord
distance d_j from the previous one (the first at steps_mm[0] - lead_mm from the entity
start) and exactly on the line, circle or helix; u is the arc length in mm from the
entity start. A period whose target reaches or passes the end ends on the entity's end
point, and carry_mm = d_j - |end - previous point| is the unused part of its step.

Arcs: the radius may change linearly with the angle from the start radius to the end
radius (the interpreter accepts end points up to 0.002 mm off the circle, as RS274NGC
does), so the end point is reached exactly; for a consistent arc this is the circle or
helix itself. The chord to the next point is solved on the curve (safeguarded Newton),
taking the first point along the path at distance d; if no point of the remaining sweep
is that far away (a step wider than the arc), the period reaches the end.
"""
from __future__ import annotations

from math import atan2, cos, hypot, inf, isfinite, pi, sin, sqrt

import numpy as np
from numba import njit

from ipr.entities import PLANE_AXES, Arc, Line, Rapid
from ipo.contracts import Steps
from ipo.errors import ARC_RADIUS, NON_FINITE, IpoError

# A first step shorter than lead_mm by less than this is float noise of the caller's
# lead = step - carry, not an error.
_LEAD_NOISE_MM = 1e-9


def _check_steps(steps_mm, lead_mm: float, first: bool) -> tuple[np.ndarray, float]:
    """Validated float64 steps and the offset to subtract from the first one."""
    steps = np.ascontiguousarray(steps_mm, dtype=np.float64)
    if steps.ndim != 1:
        raise ValueError(f"steps_mm must be one-dimensional, got shape {steps.shape}")
    if not _all_finite_nonneg(steps):
        raise ValueError("steps_mm must be finite and >= 0")
    off = lead_mm if first else 0.0
    if steps.size and off > 0.0 and steps[0] < off - _LEAD_NOISE_MM:
        raise ValueError(f"first step {steps[0]} mm is shorter than lead_mm {off} mm")
    return steps, off


@njit(cache=True)
def _all_finite_nonneg(a):
    for x in a:
        if not (x >= 0.0 and x < inf):
            return False
    return True


def _check_lead(lead_mm: float) -> float:
    lead = float(lead_mm)
    if not (isfinite(lead) and lead >= 0.0):
        raise ValueError(f"lead_mm must be finite and >= 0, got {lead_mm}")
    return lead


@njit(cache=True)
def _line_run(g, length, s0, steps, off, pos, u):
    """Fill pos/u for each period; returns (periods, done, carry_mm, s).
    g holds start (0:3), unit direction (3:6) and end (6:9)."""
    s = s0
    for j in range(steps.shape[0]):
        d = max(steps[j] - off, 0.0) if j == 0 else steps[j]
        rem = length - s
        if d >= rem:
            pos[j, :] = g[6:9]
            u[j] = length
            return j + 1, True, d - rem, length
        s += d
        for i in range(3):
            pos[j, i] = g[i] + g[3 + i] * s
        u[j] = s
    return steps.shape[0], False, 0.0, s


def output_arrays(n: int, out: tuple | None) -> tuple:
    """Where advance() writes n periods: `out` = (pos (>= n, 3), u (>= n), evals (>= n)), C-contiguous
    float64, float64 and int64 arrays the caller preallocated (the periods are written in place
    and the returned Steps are views of them), or new arrays."""
    if out is None:
        return np.empty((n, 3)), np.empty(n), np.empty(n, dtype=np.int64)
    pos, u, evals = out
    for a, dtype, ndim in ((pos, np.float64, 2), (u, np.float64, 1), (evals, np.int64, 1)):
        if not (a.dtype == dtype and a.ndim == ndim and a.shape[0] >= n and a.flags.c_contiguous):
            raise ValueError(f"out arrays must be C-contiguous {dtype.__name__} with >= {n} rows")
    if pos.shape[1] != 3:
        raise ValueError(f"out's pos must have 3 columns, got {pos.shape[1]}")
    return pos, u, evals


class _ChunkStepper:
    """The stepper contract (ipo/contracts.py) around a compiled kernel `_run` that fills a
    whole chunk of periods and advances the subclass's own position state."""

    def advance(self, steps_mm: np.ndarray, out: tuple | None = None) -> Steps:
        if self.done:
            raise RuntimeError(f"advance() called on a finished {type(self).__name__}")
        steps, off = _check_steps(steps_mm, self._lead, self._first)
        n = steps.shape[0]
        pos, u, evals = output_arrays(n, out)
        k, done, carry = self._run(steps, off, pos, u)
        evals[:k] = 0
        if n:
            self._first = False
        self.done = bool(done)
        return Steps(pos[:k], u[:k], evals[:k], self.done, float(carry))


class LineStepper(_ChunkStepper):
    """Rapid (G0) or Line (G1): points every d_j along the straight segment."""

    startup_evals = 0

    def __init__(self, entity: Rapid | Line, lead_mm: float = 0.0):
        if not isinstance(entity, (Rapid, Line)):
            raise TypeError(f"LineStepper needs a Rapid or Line, got {type(entity).__name__}")
        # plain floats, not arrays: programs of short moves build one stepper per block
        start = tuple(map(float, entity.start))
        end = tuple(map(float, entity.end))
        if not all(map(isfinite, start + end)):
            raise IpoError(NON_FINITE, "non-finite start or end point", entity.line)
        delta = (end[0] - start[0], end[1] - start[1], end[2] - start[2])
        self.length_mm = hypot(*delta)
        inv = 1.0 / self.length_mm if self.length_mm > 0.0 else 0.0
        self._g = np.array(start + (delta[0] * inv, delta[1] * inv, delta[2] * inv) + end)
        self._lead = _check_lead(lead_mm)
        self._s = 0.0
        self._first = True
        self.done = False

    def _run(self, steps, off, pos, u):
        k, done, carry, self._s = _line_run(self._g, self.length_mm, self._s, steps, off, pos, u)
        return k, done, carry


# Arc geometry vector g: centre a, centre b, normal at start, start angle, sense (+-1),
# start radius, radius change per rad, normal travel per rad, total |sweep|.
_CA, _CB, _N0, _ALPHA0, _SENSE, _R0, _RHO, _K, _THETA = range(9)


@njit(cache=True)
def _arc_xyz(g, th):
    r = g[_R0] + g[_RHO] * th
    ang = g[_ALPHA0] + g[_SENSE] * th
    return g[_CA] + r * cos(ang), g[_CB] + r * sin(ang), g[_N0] + g[_K] * th


@njit(cache=True)
def _arc_len(g, th):
    """Arc length from the start to angle th: Simpson's rule, exact for a circle or helix
    (constant speed) and within ~1e-15 relative for the slight spiral of a radius mismatch."""
    c = g[_RHO] ** 2 + g[_K] ** 2
    r0 = g[_R0]
    if g[_RHO] == 0.0:
        return th * sqrt(r0 * r0 + c)
    rm = g[_R0] + g[_RHO] * 0.5 * th
    r1 = g[_R0] + g[_RHO] * th
    return th / 6.0 * (sqrt(r0 * r0 + c) + 4.0 * sqrt(rm * rm + c) + sqrt(r1 * r1 + c))


@njit(cache=True)
def _chord_excess(g, th_a, pa, pb, pn, phi, d2):
    """h = |P(th_a + phi) - P(th_a)|^2 - d^2 and dh/dphi."""
    th = th_a + phi
    r = g[_R0] + g[_RHO] * th
    ang = g[_ALPHA0] + g[_SENSE] * th
    ca, sa = cos(ang), sin(ang)
    dx = g[_CA] + r * ca - pa
    dy = g[_CB] + r * sa - pb
    dz = g[_N0] + g[_K] * th - pn
    ta = g[_RHO] * ca - r * g[_SENSE] * sa
    tb = g[_RHO] * sa + r * g[_SENSE] * ca
    return dx * dx + dy * dy + dz * dz - d2, 2.0 * (dx * ta + dy * tb + dz * g[_K])


@njit(cache=True)
def _arc_sweep_for_chord(g, th_a, pa, pb, pn, d, rem):
    """Angle to the first point at chord d beyond angle th_a, or -1 if the end comes first."""
    d2 = d * d
    lo = 0.0
    hi = min(pi, rem)
    if _chord_excess(g, th_a, pa, pb, pn, hi, d2)[0] <= 0.0:
        if rem <= pi:
            return -1.0
        # The step is wider than the arc: look for it beyond half a turn (helix only).
        lo = pi
        found = False
        while lo < rem:
            nxt = min(lo + pi / 16.0, rem)
            if _chord_excess(g, th_a, pa, pb, pn, nxt, d2)[0] > 0.0:
                hi = nxt
                found = True
                break
            lo = nxt
        if not found:
            return -1.0
    # Chord <= arc length, so d / speed lies at or below the root: a good Newton start.
    r = g[_R0] + g[_RHO] * th_a
    phi = d / sqrt(r * r + g[_RHO] ** 2 + g[_K] ** 2)
    if not (lo < phi < hi):
        phi = 0.5 * (lo + hi)
    for _ in range(100):
        h, dh = _chord_excess(g, th_a, pa, pb, pn, phi, d2)
        if h == 0.0:
            return phi
        if h > 0.0:
            hi = phi
        else:
            lo = phi
        nxt = phi - h / dh if dh > 0.0 else inf
        if not (lo < nxt < hi):
            nxt = 0.5 * (lo + hi)
        # Quadratic convergence: a step this small leaves an error far below it; the
        # absolute term is the rounding floor of the angle argument alpha0 + theta.
        if abs(nxt - phi) <= 1e-13 * phi + 4e-16 * (1.0 + th_a) or hi - lo <= 4e-16 * hi:
            return nxt
        phi = nxt
    return phi


@njit(cache=True)
def _arc_run(g, ia, ib, inn, end, th0, steps, off, pos, u):
    """Fill pos/u for each period; returns (periods, done, carry_mm, theta)."""
    th = th0
    pa, pb, pn = _arc_xyz(g, th)
    # On a circle or helix the chord depends on the swept angle alone, and rises
    # monotonically up to half a turn: a repeated step reuses the last angle.
    d_last, phi_last = -1.0, -1.0
    for j in range(steps.shape[0]):
        d = max(steps[j] - off, 0.0) if j == 0 else steps[j]
        if d > 0.0:
            rem = g[_THETA] - th
            if d == d_last and g[_RHO] == 0.0 and phi_last <= pi and phi_last < rem:
                phi = phi_last
            else:
                phi = _arc_sweep_for_chord(g, th, pa, pb, pn, d, rem)
                d_last, phi_last = d, phi
            if phi < 0.0:
                pos[j, :] = end
                u[j] = _arc_len(g, g[_THETA])
                c_end = sqrt((end[ia] - pa) ** 2 + (end[ib] - pb) ** 2 + (end[inn] - pn) ** 2)
                return j + 1, True, max(d - c_end, 0.0), g[_THETA]
            th += phi
            pa, pb, pn = _arc_xyz(g, th)
        pos[j, ia] = pa
        pos[j, ib] = pb
        pos[j, inn] = pn
        u[j] = _arc_len(g, th)
    return steps.shape[0], False, 0.0, th


class ArcStepper(_ChunkStepper):
    """Arc (G2/G3), helix and full turns: points at chord d_j on the exact curve."""

    startup_evals = 0

    def __init__(self, entity: Arc, lead_mm: float = 0.0):
        if not isinstance(entity, Arc):
            raise TypeError(f"ArcStepper needs an Arc, got {type(entity).__name__}")
        a, b, n = PLANE_AXES[entity.plane]
        start = tuple(map(float, entity.start))
        end = tuple(map(float, entity.end))
        centre = tuple(map(float, entity.center))
        if not all(map(isfinite, start + end + centre)):
            raise IpoError(NON_FINITE, "non-finite arc start, end or centre", entity.line)
        self._end = np.array(end)
        r0 = entity.radius_mm
        r1 = hypot(end[a] - centre[a], end[b] - centre[b])
        if not r0 > 0.0:
            raise IpoError(ARC_RADIUS, "arc radius is zero (start point on the centre)", entity.line)
        sweep = entity.sweep_rad
        theta = abs(sweep)
        self._g = np.array([
            centre[a], centre[b], start[n],
            atan2(start[b] - centre[b], start[a] - centre[a]), 1.0 if sweep > 0 else -1.0,
            r0, (r1 - r0) / theta, (end[n] - start[n]) / theta, theta,
        ])
        self._axes = (a, b, n)
        self.radius_mm = r0
        self.length_mm = float(_arc_len(self._g, theta))
        self._lead = _check_lead(lead_mm)
        self._theta = 0.0
        self._first = True
        self.done = False

    def _run(self, steps, off, pos, u):
        a, b, nn = self._axes
        k, done, carry, self._theta = _arc_run(self._g, a, b, nn, self._end, self._theta,
                                               steps, off, pos, u)
        return k, done, carry
