"""Walks one NURBS entity with its stepper (ipo.interp.steppers) along a planned arc-length schedule.

The stepper takes chord lengths; the feed stage plans arc length. Each period's target
chord is the arc step shortened by the circle estimate d (1 - kappa^2 d^2 / 24), and
after every call the stepper's arc position is read back from its curve parameter (the
table's Hermite s(u)), so the stepper's own chord tolerances never accumulate into a
speed error at the end of the curve.

A chord error that changes from one period to the next is an acceleration error of
(its change) / T^2: 0.01 um per period is 10 mm/s^2 at T = 1 ms. So the stepper solves each
chord to CHORD_TOL_PCT (a fixed iteration count falls 0.6 % short in sharp turns, the
shortfall changing by 0.02 um a period), and the driver's corrections never step: the gain
moves linearly to its new value over a chunk, and the lag is taken up by a sin^2 bump that
starts and ends at zero (spreading it evenly changes the speed at every resync, up to
19 % over the acceleration limit on random curves). A Taylor update's du is the first guess
of that solve (ipo.interp.steppers); constant du cannot follow a feed and is refused by the planner.
"""
from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.feed.pieces import BLEND_SPANS
from ipo.feed.sampling import NurbsTable, blend_tables, nurbs_table
from ipo.nurbs.subcurve import sub_curve
from ipr.entities import Nurbs

# The stepper's chords carry a small bias (about 1e-6 of a step, more at start-up);
# re-reading its arc position this often keeps the lag far below what a drive could feel.
RESYNC_PERIODS = 32
# 1e-5 of a chord: at 0.1 mm a period (100 mm/s, 1 ms) 1 nm, whose change over a period
# stays within the planner's headroom below the acceleration limit (feed.ACCEL_USE)
CHORD_TOL_PCT = 1e-3
# Curve evaluations a period's chord solve spends before it only halves its bracket. A solve
# that stopped at a cap short of the chord would leave a lag whose catch-up breaks the axis
# limits: at the stepper's default cap (8) a curve whose speed in u changes by orders of
# magnitude within a period (weights of 1e-5 next to 1e-2, as `vcnc fit` writes for
# CAMotics' bear.nc) lost 13 um of a 28 um step in one period, and the catch-up took X to
# 1140 mm/s^2 against 1000. So the driver's solve never stops short (bisect_past_cap); past
# this count it halves the bracket, which the regula falsi before it (15 evaluations at most
# over the whole fitted bear.nc) does not need.
MAX_CHORD_EVALS = 64
_END_SNAP_MM = 1e-9


class NurbsDriver:
    def __init__(self, entity, table: NurbsTable, method: str):
        self.entity = entity
        self.table = table
        self.method = method
        self.stepper = None
        self.s_reached = 0.0  # arc length the stepper has reached
        self.s_planned = 0.0  # arc length the schedule asked for so far
        self.gain = 1.0  # realised arc per asked chord, learnt chunk by chunk
        self.gain_used = 1.0  # the gain the last period was asked with
        self.chunk = 1  # periods per stepper call: doubles up to RESYNC_PERIODS while the gain settles
        self.end = np.array(entity.points[-1], dtype=float)

    def trimmed(self, u0: float, u1: float) -> "NurbsDriver":
        """A fresh driver for the part of the curve between parameters u0 and u1 (G64 corner
        blends took the rest), with its own table."""
        part = sub_curve(self.entity, u0, u1)
        u = self.table.u
        fine = np.concatenate([[part.knots[0]], u[(u > part.knots[0]) & (u < part.knots[-1])], [part.knots[-1]]])
        return NurbsDriver(part, nurbs_table(part, self.table.end_gap_mm, fine), self.method)

    def points(self, sigma: np.ndarray, sigma_before: float) -> np.ndarray:
        """Points at arc lengths sigma (from the curve's start); sigma_before is where the
        previous period ended (negative: inside the previous piece)."""
        n = len(sigma)
        out = np.repeat(self.end[None, :], n, axis=0)
        target = np.minimum(sigma, self.table.length)
        lead = 0.0
        if self.stepper is None:
            from ipo.interp.steppers import make_stepper   # ~4 ms to load, for programs with a NURBS only

            lead = max(-sigma_before, 0.0)
            self.stepper = make_stepper(self.entity, method=self.method, lead_mm=lead, chord_tol_pct=CHORD_TOL_PCT,
                                        max_evals=MAX_CHORD_EVALS, bisect_past_cap=True)
        a = 0
        while a < n and not self.stepper.done:
            # towards the curve's end a chunk covers at most half of what is left, so that the
            # lag it leaves is not corrected in the few periods of a stop
            half = int(np.searchsorted(target, 0.5 * (self.s_planned + self.table.length), side="right"))
            b = min(a + self.chunk, n, max(half, a + 1))
            out[a:b] = self._advance(target[a:b], lead if a == 0 else 0.0)
            self.chunk = min(2 * self.chunk, RESYNC_PERIODS)
            a = b
        return out

    def _advance(self, target: np.ndarray, lead: float) -> np.ndarray:
        length = self.table.length
        # the lag left by the last chunk is taken up over this one (a bump from and to zero), and
        # the gain moves to the last chunk's realised/asked ratio: the step correction never jumps
        ramp, bump, bump_sum = _chunk_shape(len(target))
        steps, chord = _chunk_steps(target, self.s_planned, self.table.s, self.table.kappa, self.gain_used, self.gain,
                                    self.s_planned - self.s_reached, ramp, bump, bump_sum, lead,
                                    length - _END_SNAP_MM, 2.0 * length + 1.0)
        st = self.stepper.advance(steps)
        self.gain_used = self.gain
        k = len(st.u)
        out = np.empty((len(target), 3))
        out[:k] = st.pos_mm
        out[k:] = self.end
        if st.done:
            self.s_reached = length
        elif k == len(target):
            moved = self.table.s_of_u(float(st.u[-1])) - self.s_reached
            asked = float(steps.sum()) - lead
            planned, chords = float(target[-1]) - self.s_planned, float(chord.sum())
            if moved > 0 and chords > 0:
                self.gain = min(max(planned * asked / (chords * moved), 0.99), 1.01)
            self.s_reached += moved
        self.s_planned = float(target[-1])
        return out


@njit(cache=True)
def _chunk_steps(target, s_planned, tab_s, tab_kappa, gain_used, gain, lag, ramp, bump, bump_sum, lead, snap_from,
                 snap_step):
    """A chunk's steps for the stepper and its chords (_advance): each period's arc step d as the
    chord of an arc of length d at the table's curvature halfway along it, d (1 - (kappa d)^2 / 24),
    times the gain moving from gain_used to gain over the chunk, plus the lag's share of the bump;
    the first step also takes the lead, and a period that reaches snap_from (the curve's end) at
    least snap_step, so that it ends on the curve's end even if the stepper lags (the planner's
    arc lengths may fall short of the table's length by float rounding)."""
    n = target.shape[0]
    d = np.empty(n)
    prev = s_planned
    for i in range(n):
        step = target[i] - prev
        d[i] = step if (step >= 0.0 or step != step) else 0.0  # np.maximum's: NaN stays, -0.0 stays
        prev = target[i]
    kappa = np.interp(target - 0.5 * d, tab_s, tab_kappa)
    chord = np.empty(n)
    steps = np.empty(n)
    for i in range(n):
        kd = kappa[i] * d[i]
        chord[i] = d[i] * (1.0 - kd * kd / 24.0)
        g = gain_used + (gain - gain_used) * ramp[i] / n
        step = chord[i] * g + lag * bump[i] / bump_sum
        steps[i] = step if (step >= 0.0 or step != step) else 0.0
    steps[0] += lead
    if target[n - 1] >= snap_from:
        for i in range(n):
            if target[i] >= snap_from:
                steps[i] = steps[i] if (steps[i] >= snap_step or steps[i] != steps[i]) else snap_step
    return steps, chord


class BlendCurve(NamedTuple):
    """A corner blend (a cubic or the G2 quintic Bezier of ipo.feed.pieces) where the window keeps
    the NURBS drivers: emission walks every blend by its table in one compiled call
    (ipo.feed.blends.compiled.bezier_points_runs), not by a stepper, so a blend needs no driver
    and no entity, and a build makes thousands of them (circle360: a NurbsDriver and a Nurbs each
    cost more than the NamedTuple)."""

    line: int
    feed_mm_s: float
    points: np.ndarray  # control points, (4, 3) or (6, 3)
    table: NurbsTable

    @property
    def entity(self) -> Nurbs:
        """The blend as the NURBS entity it is."""
        return Nurbs(self.line, len(self.points) - 1, *BLEND_SPANS[len(self.points)], self.points, self.feed_mm_s)


def blend_curves(blends: list[tuple[int, float, np.ndarray]]) -> list[BlendCurve]:
    """The blends (line, feed, control points) as BlendCurves, their tables made in one compiled
    call per degree (ipo.feed.sampling.blend_tables)."""
    lines, feeds, ctrls = zip(*blends)
    return list(map(BlendCurve, lines, feeds, ctrls, blend_tables(ctrls, lines)))


@lru_cache(maxsize=None)
def _chunk_shape(n: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The gain's ramp 1..n and the lag's sin^2 bump (with its sum) over a chunk of n periods:
    a chunk holds at most RESYNC_PERIODS periods, so a handful of shapes serve every curve."""
    ramp, bump = np.arange(1, n + 1), np.sin(np.pi * (np.arange(n) + 0.5) / n) ** 2
    ramp.flags.writeable = bump.flags.writeable = False  # shared by every chunk of n periods
    return ramp, bump, bump.sum()
