"""S-curve mode across look-ahead windows (ipo.feed.scurve): a window that ends inside a tight
curve commits a speed near v^2 kappa = A, and the next window, with more path read, must go on
from it. Checked by finite differences of the drive's positions against the machine's limits and
by where the run ends; the fallback to the last plan's rest (scurve.tail_gap) against the
double-S profile's own numbers on a straight."""
from __future__ import annotations

import numpy as np
import pytest

from ipo.errors import IpoError
from ipo.feed import jerk_plan, scurve
from ipo.feed.intake import _BUILD_CHUNK
from ipo.feed.jerk_profile import transition_distance
from ipr.entities import Line, PathControl
from tests.ipo.feed.test_jerk_profile import assert_within_limits, run

FEED = 100.0  # mm/s
STEP_MM = 0.05  # the lead-in's moves


def straight_into_a_polygon(n_lead: int, radius_mm: float, chord_mm: float, tol_mm: float) -> list:
    """n_lead short moves up to an exact stop (so that the window's end falls where n_lead puts
    it: a build takes _BUILD_CHUNK motions), then 60 mm of X at F6000 into a half circle of
    radius_mm as chords of chord_mm (S-curve mode blends them into one G2 chain), and 60 mm back.
    At radius 8 the curve allows v^2 kappa = A at 89 mm/s."""
    blend, stop = PathControl(blend_tol_mm=tol_mm), PathControl(exact_stop=True)
    y0 = -STEP_MM * n_lead
    pts = [(-60.0, y0 + i * STEP_MM, 0.0) for i in range(n_lead + 1)]
    n = int(radius_mm * np.pi / chord_mm)
    phi = np.pi * np.arange(n + 1) / n
    pts += [(radius_mm * np.sin(p), radius_mm * (1.0 - np.cos(p)), 0.0) for p in phi]
    pts.append((-60.0, 2.0 * radius_mm, 0.0))
    return [Line(i + 1, a, b, FEED, stop if i == n_lead - 1 else blend) for i, (a, b) in enumerate(zip(pts[:-1], pts[1:]))]


@pytest.mark.parametrize("n_lead,chord_mm,tol_mm", [(2020, 0.7, 0.02), (2028, 1.0, 0.05)])
def test_a_window_that_ends_in_a_tight_curve_is_followed_within_the_limits(n_lead, chord_mm, tol_mm):
    """The first window ends in the half circle (its build takes the lead-in and the first
    chords) and commits about 90 mm/s where the curvature cap falls to 88.6 mm/s within 4.5 mm.
    The next window's plan found no braking from there (IpoError "no jerk-limited profile"
    before the last plan's rest was kept); now every period keeps v/a/j and the run ends on the
    program's end."""
    assert _BUILD_CHUNK < n_lead + 30 < 2 * _BUILD_CHUNK  # the window's end falls in the curve
    ents = straight_into_a_polygon(n_lead, 8.0, chord_mm, tol_mm)
    pos = run(ents)
    assert_within_limits(pos)
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=1e-6)


def straight_tail(cap_mm_s: float, ag: float):
    """A 10 mm straight along X sampled every 0.05 mm, and a last plan's rest on it: one gap from
    50 mm/s to a stop at its end with path acceleration ag and jerk 98500 mm/s^3."""
    s = np.linspace(0.0, 10.0, 201)
    t = np.tile([1.0, 0.0, 0.0], (len(s), 1))
    geo = jerk_plan.Geometry(s, t, np.zeros_like(t))
    tail = scurve.Segments(np.array([0, 200]), np.array([50.0, 0.0]), np.array([50.0]), np.array([ag]),
                           np.array([98500.0]))
    lim = jerk_plan.AxisLimits(np.full(3, 985.0), np.full(3, 98500.0), 1e-3)
    return tail, geo, np.full(len(s), cap_mm_s**2), lim


def test_the_last_plans_rest_is_taken_only_within_todays_caps_and_the_axis_limits():
    # the stop takes 25 mm/s x (50/985 + 985/98500) s = 1.52 mm of the 10
    assert transition_distance(50.0, 0.0, 985.0, 98500.0) == pytest.approx(25.0 * (50.0 / 985.0 + 0.01))
    tail, geo, cap, lim = straight_tail(100.0, 985.0)
    assert scurve.tail_gap(tail, geo, cap, lim, 7) is tail
    with pytest.raises(IpoError, match="line 7: no jerk-limited profile"):  # an override cut the feed to 40
        scurve.tail_gap(*straight_tail(40.0, 985.0)[:3], lim, 7)
    with pytest.raises(IpoError, match="no jerk-limited profile"):  # braking at 1.2 A on one axis
        scurve.tail_gap(*straight_tail(100.0, 1.2 * 985.0)[:3], lim, 7)
    with pytest.raises(IpoError, match="no jerk-limited profile"):  # nothing kept
        scurve.tail_gap(None, geo, cap, lim, 7)
