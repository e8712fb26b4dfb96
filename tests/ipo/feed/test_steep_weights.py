"""A rational quadratic whose speed in u changes by orders of magnitude within a period.

The reproducer is the part (u 130 to 137.2912, knots shifted to 0) of the G06.2 group at
line 917 of what `vcnc fit --tol-mm 0.01` writes for CAMotics' bear.nc, cut by Boehm knot
insertion: weights from 8.7e-6 to 2.5e-2 and a double knot, at 100 mm/s. With the stepper's
default of 8 curve evaluations per period the chord solve stopped short there (13 um of a
28 um step lost in one period) and the driver's catch-up took X to 1140 mm/s^2 (17 periods
over the limit by the drive's 10-period stencil, 14000 mm/s^2 by one-period differences).
"""
from __future__ import annotations

import numpy as np
import pytest

import ipr
from ipo.contracts import PeriodBatch
from ipo.feed import nurbs_driver
from ipo.feed.planner import plan_periods
from ipo.interp.steppers import make_stepper
from ipr.entities import Nurbs
from tests.ipo.feed.test_nurbs_blend import CFG, A, T, V, assert_forward_to_the_end, finite_differences

PROGRAM = """G21 G17 G90 G94 G64
G0 X42.657290 Y9.501000 Z-11.526968
G06.2 P3 K0.000000 R0.000020173604 F6000
K0.000000 X42.115927 Y9.501000 Z-11.449483 R0.000017369700
K0.000000 X40.869000 Y9.501000 Z-11.304000 R0.000012496170
K0.862224 X40.160000 Y9.501000 Z-11.304000 R0.001133938000
K1.167658 X38.016000 Y9.501000 Z-11.304000 R0.025074070000
K1.167658 X36.600000 Y9.501000 Z-11.422000 R0.025074070000
K5.732540 X34.984421 Y9.501000 Z-11.664337 R0.000023316904
K7.288750 X34.231929 Y9.501000 Z-11.842991 R0.000008672956
K7.291200
K7.291200
K7.291200
M2
"""
# a position is rounded to BLU by at most half a BLU: a second difference by 2 BLU / T^2
A_SLACK = 2 * CFG.blu_mm / T**2
V_SLACK = CFG.blu_mm / T


def _group():
    (e,) = [x for x in ipr.parse_text(PROGRAM, "bear_917.nc").entities if isinstance(x, Nurbs)]
    return e


def test_steep_weight_group_stays_within_the_axis_limits():
    e = _group()
    assert e.weights.max() / e.weights.min() > 2000  # the steepness this is about
    items = plan_periods([e], CFG, start_mm=e.start)
    pos = np.concatenate([b.pos_mm for b in items if isinstance(b, PeriodBatch)])
    v, a = finite_differences(pos, e.start)
    assert np.all(np.abs(v) <= V + V_SLACK), np.abs(v).max(0)
    assert np.all(np.abs(a) <= A + A_SLACK), np.abs(a).max(0)
    assert_forward_to_the_end(pos, e.start, e.end)


@pytest.mark.parametrize("max_evals", [2, 8])
def test_the_chord_solve_past_its_cap_still_meets_every_chord(max_evals):
    """Past max_evals the feed stage's solve halves its bracket instead of keeping a short
    trial: every period's chord (measured from the output points) is the asked one within
    the tolerance, however few evaluations the cap allows before it bisects."""
    e = _group()
    step_mm, tol = 0.028, 1e-5
    steps = np.full(200, step_mm)
    capped = make_stepper(e, chord_tol_pct=100 * tol, max_evals=max_evals).advance(steps)
    exact = make_stepper(e, chord_tol_pct=100 * tol, max_evals=max_evals, bisect_past_cap=True).advance(steps)
    for st in (capped, exact):
        assert not st.done  # 200 steps of 28 um stay inside the 7.3 mm group
    chords = np.linalg.norm(np.diff(np.vstack([e.start, exact.pos_mm]), axis=0), axis=1)
    assert np.all(np.abs(chords - step_mm) <= tol * step_mm * (1 + 1e-9)), np.abs(chords - step_mm).max()
    short = step_mm - np.linalg.norm(np.diff(np.vstack([e.start, capped.pos_mm]), axis=0), axis=1)
    assert short.max() > 10 * tol * step_mm  # where the cap alone stops the solve short
    assert exact.evals.max() > max_evals


def test_a_driver_with_a_small_cap_still_stays_within_the_axis_limits(monkeypatch):
    """The driver's periods never fall short at the cap, so no lag is left to catch up: with
    only 8 evaluations before bisection (the cap that broke the limits) the limits hold."""
    monkeypatch.setattr(nurbs_driver, "MAX_CHORD_EVALS", 8)
    e = _group()
    pos = np.concatenate([b.pos_mm for b in plan_periods([e], CFG, start_mm=e.start) if isinstance(b, PeriodBatch)])
    v, a = finite_differences(pos, e.start)
    assert np.all(np.abs(v) <= V + V_SLACK), np.abs(v).max(0)
    assert np.all(np.abs(a) <= A + A_SLACK), np.abs(a).max(0)
    assert_forward_to_the_end(pos, e.start, e.end)
