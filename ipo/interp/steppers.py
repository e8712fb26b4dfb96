"""Per-entity steppers: `make_stepper` picks the interpolator for a motion entity.

Lines and arcs are stepped exactly (ipo.interp.line_arc); a NURBS is stepped by one of the
parameter updates (recursive 000 §2.2, Taylor 002 eq. 7, constant du 000 Fig. 7). The
NURBS stepper follows ipo/contracts.py: one compiled call fills the arrays of a whole chunk
of periods. Every curve evaluation is counted in `Steps.evals`, the output point and the
start-up included (a Taylor evaluation includes the two derivatives); `startup_evals` is
the part spent by the start-up (the first moving period, or the first ones should they be
too short to measure du/ds from). With `chord_tol_pct`, every period's chord is solved to
that tolerance: by the recursive update's tolerance mode, or from a Taylor update's du as
the first guess (the feed stage needs it: a chord error that changes from period to period
is an acceleration error; it also asks `bisect_past_cap`, so that max_evals never leaves a
period short). Constant du has no chord to hold.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.interp.constant_du import constant_du_step
from ipo.interp.line_arc import ArcStepper, LineStepper, output_arrays
from ipo.nurbs.compiled import SpanCurve, compile_curve, dist3, poly_derivs2, poly_point, poly_span
from ipo.contracts import Steps
from ipo.errors import NURBS_DATA, IpoError
from ipo.interp.recursive import STARTUP_CAP, ChordRule, eq9, predict_ratio, recursive_step
from ipo.interp.taylor import taylor_step
from ipr.entities import Arc, Line, Nurbs, Rapid

METHODS = {"recursive": 0, "taylor1": 1, "taylor2": 2, "constant-du": 3}
_RECURSIVE, _TAYLOR1, _TAYLOR2, _CONSTANT_DU = range(4)

# float state: u, P(u), last two steps (du, chord), pending lead, P' and P'' at u (Taylor)
_U, _PX, _PY, _PZ, _G1, _S1, _G2, _S2, _LEAD = range(9)
_NST = 9
# int state: span hint, started (du/ds known), evaluations spent on the start-up
_SPAN, _STARTED, _STARTUP_EVALS = range(3)

_LEAD_NOISE_MM = 1e-9  # a first step shorter than the lead by less than this is float noise
# Chords below this are too close to float resolution to learn du/ds from (steps near a stop)
_RATIO_MIN_MM = 1e-9


class WalkOptions(NamedTuple):
    """The parameter update and its settings (make_stepper's options, in kernel units)."""

    method: int  # one of METHODS' values
    n1: int  # recursive: increments per period (000 eq. 8-9)
    m1: int  # recursive: increments of the start-up (000 eq. 12-14)
    start_tol: float  # relative chord tolerance of the start-up (§2.2.1); < 0: none
    chord_tol: float  # relative chord tolerance of every period; < 0: none
    max_evals: int  # evaluations per period under chord_tol
    bisect_past_cap: bool  # under chord_tol: past max_evals, bisect on to the tolerance (recursive.py)
    du: float  # constant du: the increment


@njit(cache=True)
def _walk_tuples(curve, opts, st, ist, der, steps, pos, uo, evo):
    """_walk for the Python side, its records as plain tuples: numba types a plain tuple
    argument in C, a NamedTuple in Python on every call (7 against 15 us a call measured
    under load; the feed stage calls a stepper 12,883 times for finish_nurbs.nc)."""
    return _walk(SpanCurve(*curve), WalkOptions(*opts), st, ist, der, steps, pos, uo, evo)


@njit(cache=True)
def _paper_run(curve, n1, st, ist, steps, j, pos, uo, evo):
    """The steady state of the recursive paper mode (000 eq. 8-9: n1 evaluations a period) from
    period j on, with the state in registers: twice the periods per second of a general
    period. It leaves to _walk, at the period it returns, whatever is not that steady state
    (a step <= 0, a trial at or past the end, a chord too short to learn from); every period
    it takes is the one _walk would have taken, bit for bit."""
    breaks, inv_h, coef, u_max = curve.breaks, curve.inv_h, curve.coef, curve.u_max
    u, px, py, pz = st[_U], st[_PX], st[_PY], st[_PZ]
    g1, s1, g2, s2 = st[_G1], st[_S1], st[_G2], st[_S2]
    span = ist[_SPAN]
    x = y = z = s = 0.0
    while j < steps.shape[0]:
        d = steps[j]
        if d <= 0.0:
            break
        g = eq9(d, g1, s1)  # 000 eq. 8
        for k in range(n1):
            if k > 0:
                g = eq9(d, g, s)  # 000 eq. 9
            if g >= u_max - u:
                break
            span = poly_span(breaks, u + g, span)
            x, y, z = poly_point(breaks, inv_h, coef, span, u + g)
            s = dist3(px, py, pz, x, y, z)
        if g >= u_max - u or u + g >= u_max or not s > _RATIO_MIN_MM:
            break
        pos[j, 0], pos[j, 1], pos[j, 2] = x, y, z
        u += g
        uo[j] = u
        evo[j] = n1
        px, py, pz = x, y, z
        g2, s2, g1, s1 = g1, s1, g, s
        j += 1
    st[_U], st[_PX], st[_PY], st[_PZ] = u, px, py, pz
    st[_G1], st[_S1], st[_G2], st[_S2] = g1, s1, g2, s2
    ist[_SPAN] = span
    return j


@njit(cache=True)
def _walk(curve, opts, st, ist, der, steps, pos, uo, evo):
    """Step the curve (SpanCurve) through `steps` with the update of opts (WalkOptions),
    from the state st, ist, der, into pos, uo, evo; returns (periods, done, carry_mm)."""
    method, chord_tol, u_min, u_max = opts.method, opts.chord_tol, curve.u_min, curve.u_max
    breaks, inv_h, coef, end = curve.breaks, curve.inv_h, curve.coef, curve.end
    paper = method == _RECURSIVE and chord_tol < 0.0 and curve.polygon_mm > 0.0
    j = 0
    while j < steps.shape[0]:
        if paper and ist[_STARTED] == 1 and st[_LEAD] <= 0.0:
            j = _paper_run(curve, opts.n1, st, ist, steps, j, pos, uo, evo)
            if j == steps.shape[0]:
                break
        d = steps[j]
        if st[_LEAD] > 0.0:
            d = max(d - st[_LEAD], 0.0)
            st[_LEAD] = 0.0
        u = st[_U]
        px, py, pz = st[_PX], st[_PY], st[_PZ]
        if d <= 0.0:
            pos[j, 0], pos[j, 1], pos[j, 2] = px, py, pz
            uo[j] = u
            evo[j] = 0
            j += 1
            continue
        if curve.polygon_mm <= 0.0:  # every control point equal: the curve is a point
            pos[j, 0], pos[j, 1], pos[j, 2] = end[0], end[1], end[2]
            uo[j] = u_max
            evo[j] = 0
            return j + 1, True, d
        started = ist[_STARTED] == 1
        span = ist[_SPAN]
        here = (px, py, pz)
        prev = (st[_G1], st[_S1])
        tolerant = ChordRule(opts.n1, chord_tol, opts.max_evals, True, opts.bisect_past_cap)
        extra = 0
        if method == _RECURSIVE:
            if not started:
                g = d * (u_max - u_min) / curve.polygon_mm  # 000 eq. 12
                tol = opts.start_tol if opts.start_tol >= 0.0 else chord_tol
                startup = ChordRule(opts.m1, tol, STARTUP_CAP, chord_tol >= 0.0, opts.bisect_past_cap)
                res = recursive_step(curve, startup, span, u, here, d, g, (0.0, 0.0))
            elif chord_tol >= 0.0:
                g = d * predict_ratio(st[_G1], st[_S1], st[_G2], st[_S2], d)
                res = recursive_step(curve, tolerant, span, u, here, d, g, prev)
            else:
                g = eq9(d, st[_G1], st[_S1])  # 000 eq. 8
                res = recursive_step(curve, ChordRule(opts.n1, -1.0, 0, False, False), span, u, here, d, g, (0.0, 0.0))
        elif method == _CONSTANT_DU:
            res = constant_du_step(curve, span, u, here, opts.du)
        else:
            if not started:
                poly_derivs2(breaks, inv_h, coef, span, u, der)
                extra = 1
            fallback = eq9(d, st[_G1], st[_S1]) if st[_S1] > 0.0 else d * (u_max - u_min) / curve.polygon_mm
            res = taylor_step(curve, span, u, here, d, der, 1 if method == _TAYLOR1 else 2, fallback)
            if chord_tol >= 0.0:
                # a chord tolerance asks every period's chord within it (the feed stage: a chord that
                # is off by a changing amount is an acceleration error); eq. 7's du is the first guess
                extra += res[5]
                res = recursive_step(curve, tolerant, span, u, here, d, res[0], prev)
                if not res[6]:
                    poly_derivs2(breaks, inv_h, coef, res[7], u + res[0], der)
        g, x, y, z, s, evals, at_end, span = res
        at_end = at_end or u + g >= u_max  # u + du rounded onto u_max
        evals += extra
        ist[_SPAN] = span
        if not started:
            ist[_STARTUP_EVALS] += evals
            # a first step too short to measure leaves the start-up to the next one
            ist[_STARTED] = 1 if (method != _RECURSIVE or s > _RATIO_MIN_MM or at_end) else 0
        evo[j] = evals
        if at_end:
            pos[j, 0], pos[j, 1], pos[j, 2] = end[0], end[1], end[2]
            uo[j] = u_max
            st[_U] = u_max
            return j + 1, True, max(d - s, 0.0)
        pos[j, 0], pos[j, 1], pos[j, 2] = x, y, z
        uo[j] = u + g
        st[_U] = u + g
        st[_PX], st[_PY], st[_PZ] = x, y, z
        if s > _RATIO_MIN_MM:
            st[_G2], st[_S2] = st[_G1], st[_S1]
            st[_G1], st[_S1] = g, s
        elif d > _RATIO_MIN_MM:  # no motion: the curve stands still here; twice the increment next time
            st[_G1], st[_S1] = 2.0 * g, d
            st[_S2] = 0.0
        j += 1
    return steps.shape[0], False, 0.0


def _check_curve(e: Nurbs) -> None:
    p = int(e.degree)
    knots = np.asarray(e.knots, dtype=float)
    pts = np.asarray(e.points, dtype=float)
    w = np.asarray(e.weights, dtype=float)
    why = None
    if p < 1:
        why = f"degree must be >= 1, got {p}"
    elif pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < p + 1:
        why = f"need at least {p + 1} control points of 3 coordinates"
    elif w.shape != (len(pts),) or not (np.isfinite(w).all() and (w > 0).all()):
        why = "weights must be finite and > 0, one per control point"
    elif not np.isfinite(pts).all():
        why = "control points must be finite"
    elif len(knots) != len(pts) + p + 1 or not np.isfinite(knots).all() or (np.diff(knots) < 0).any():
        why = f"need {len(pts) + p + 1} finite non-decreasing knots, got {len(knots)}"
    elif not ((knots[:p + 1] == knots[0]).all() and (knots[-p - 1:] == knots[-1]).all()):
        why = f"knot vector must be clamped (first and last knot repeated {p + 1} times)"
    elif not knots[-1] > knots[0]:
        why = "knot vector has zero range"
    else:
        _, mult = np.unique(knots[p + 1:-p - 1], return_counts=True)
        if mult.size and mult.max() > p:
            why = f"an interior knot repeats {mult.max()} times; more than the degree {p} breaks the curve apart"
    if why is not None:
        raise IpoError(NURBS_DATA, f"NURBS {why}", e.line)


class NurbsStepper:
    """Walks one NURBS entity with the chosen parameter update (see make_stepper)."""

    def __init__(self, entity: Nurbs, *, method: str = "recursive", lead_mm: float = 0.0, n1: int = 2,
                 m1: int = 3, start_tol_pct: float | None = None, chord_tol_pct: float | None = None,
                 max_evals: int = 8, du: float = 0.02, bisect_past_cap: bool = False):
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
        for name, value in (("n1", n1), ("m1", m1), ("max_evals", max_evals)):
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value}")
        for name, value in (("start_tol_pct", start_tol_pct), ("chord_tol_pct", chord_tol_pct)):
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be > 0, got {value}")
        if not (np.isfinite(du) and du > 0):
            raise ValueError(f"du must be > 0, got {du}")
        if not (np.isfinite(lead_mm) and lead_mm >= 0):
            raise ValueError(f"lead_mm must be finite and >= 0, got {lead_mm}")
        _check_curve(entity)
        curve = compile_curve(int(entity.degree), entity.knots, np.asarray(entity.weights, float), entity.points)
        opts = WalkOptions(METHODS[method], int(n1), int(m1), -1.0 if start_tol_pct is None else start_tol_pct / 100.0,
                           -1.0 if chord_tol_pct is None else chord_tol_pct / 100.0, int(max_evals), bool(bisect_past_cap), float(du))
        self._records = (tuple(curve), tuple(opts))  # as _walk_tuples takes them
        self._st = np.zeros(_NST)
        self._st[_U] = curve.u_min
        self._st[_PX:_PZ + 1] = entity.points[0]
        self._st[_LEAD] = float(lead_mm)
        self._lead_check = float(lead_mm)
        self._ist = np.zeros(3, dtype=np.int64)
        self._der = np.zeros((3, 3))
        self.done = False

    @property
    def startup_evals(self) -> int:
        """Curve evaluations spent by the start-up (000 eq. 10-14 or §2.2.1), output point included."""
        return int(self._ist[_STARTUP_EVALS])

    def advance(self, steps_mm: np.ndarray, out: tuple | None = None) -> Steps:
        """The next periods (ipo/contracts.py), written into `out` if given (line_arc.output_arrays)."""
        if self.done:
            raise RuntimeError("advance() called on a finished NurbsStepper")
        steps = np.ascontiguousarray(steps_mm, dtype=np.float64)
        if steps.ndim != 1:
            raise ValueError(f"steps_mm must be one-dimensional, got shape {steps.shape}")
        if steps.size and not (np.isfinite(steps).all() and steps.min() >= 0.0):
            raise ValueError("steps_mm must be finite and >= 0")
        if steps.size and self._lead_check > 0.0:
            if steps[0] < self._lead_check - _LEAD_NOISE_MM:
                raise ValueError(f"first step {steps[0]} mm is shorter than lead_mm {self._lead_check} mm")
            self._lead_check = 0.0
        pos, u, evals = output_arrays(steps.shape[0], out)
        curve, opts = self._records
        k, done, carry = _walk_tuples(curve, opts, self._st, self._ist, self._der, steps, pos, u, evals)
        self.done = bool(done)
        return Steps(pos[:k], u[:k], evals[:k], self.done, float(carry))


def make_stepper(entity, *, method: str = "recursive", lead_mm: float = 0.0, n1: int = 2, m1: int = 3,
                 start_tol_pct: float | None = None, chord_tol_pct: float | None = None,
                 max_evals: int = 8, du: float = 0.02, bisect_past_cap: bool = False):
    """The stepper for one motion entity; `method` and its options apply to NURBS only."""
    if isinstance(entity, Nurbs):
        return NurbsStepper(entity, method=method, lead_mm=lead_mm, n1=n1, m1=m1, start_tol_pct=start_tol_pct,
                            chord_tol_pct=chord_tol_pct, max_evals=max_evals, du=du, bisect_past_cap=bisect_past_cap)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if isinstance(entity, (Rapid, Line)):
        return LineStepper(entity, lead_mm)
    if isinstance(entity, Arc):
        return ArcStepper(entity, lead_mm)
    raise TypeError(f"no stepper for {type(entity).__name__}: only Rapid, Line, Arc and Nurbs move")
