"""The travel check's NURBS extreme is exact (branch and bound over the convex hull), not sampled.

References: scipy's BSpline on the homogeneous coordinates (x w and w), sampled densely and
polished by a bounded scalar search around the best sample; the issue's reproducer, whose
peak lies between the 256 samples per span the old check took.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline
from scipy.optimize import minimize_scalar

from ipr import parse_text
from ipr.entities import Nurbs
from machine.extents import EXTREME_TOL_MM, curve_extreme
from tests.machine.travel_check import travel_violations

REPRODUCER = """G0 X-900 Y30 Z5
G6.2 P3 K0 X-900 Y30 Z5 R1 F6000
K0 X2885.233929961 Y130 R1
K0 X-870.542926615 Y230 R1
K1
K1
K1
M2
"""


def reference_max(curve: Nurbs, axis: int) -> float:
    p, t = int(curve.degree), np.asarray(curve.knots, float)
    w = np.asarray(curve.weights, float)
    num, den = BSpline(t, curve.points[:, axis] * w, p), BSpline(t, w, p)
    u = np.union1d(np.linspace(t[0], t[-1], 20_001), t)  # the knots: degree 1 peaks there
    x = num(u) / den(u)
    i = int(np.argmax(x))
    a, b = u[max(i - 1, 0)], u[min(i + 1, len(u) - 1)]
    res = minimize_scalar(lambda v: -num(v) / den(v), bounds=(a, b), method="bounded",
                          options={"xatol": 1e-14})
    return max(float(x[i]), float(-res.fun))


def test_issue_reproducer_is_refused_before_motion():
    program = parse_text(REPRODUCER)
    curve = next(e for e in program.entities if isinstance(e, Nurbs))
    assert reference_max(curve, 0) == pytest.approx(1000.0100, abs=5e-5)
    got = travel_violations([e for e in program.entities if hasattr(e, "start")],
                            np.full(3, -1000.0), np.full(3, 1000.0))
    assert got == [(2, "X reaches 1000.0100 mm, above the travel limit 1000.0000 mm")]


def test_a_curve_touching_the_limit_from_inside_passes():
    curve = next(e for e in parse_text(REPRODUCER).entities if isinstance(e, Nurbs))
    peak = reference_max(curve, 0)
    lo = np.full(3, -1000.0)
    assert travel_violations([curve], lo, np.array([peak + 1e-7, 1000, 1000]))  == []
    assert travel_violations([curve], lo, np.array([peak - 1e-6, 1000, 1000]))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(degree=st.integers(1, 4), n_extra=st.integers(0, 4), data=st.data())
def test_extreme_matches_a_dense_reference(degree, n_extra, data):
    n = degree + 1 + n_extra
    pts = np.array(data.draw(st.lists(st.tuples(*[st.floats(-50, 50)] * 3), min_size=n, max_size=n)))
    log_w = data.draw(st.lists(st.floats(-3, 3), min_size=n, max_size=n))
    inner = sorted(data.draw(st.lists(st.floats(0.05, 0.95), min_size=n - degree - 1, max_size=n - degree - 1,
                                      unique=True)))
    knots = np.array([0.0] * (degree + 1) + inner + [1.0] * (degree + 1))
    curve = Nurbs(1, degree, knots, 10.0 ** np.array(log_w), pts, 10.0)
    want = reference_max(curve, 0)
    limit = float(pts[:, 0].min()) - 1.0  # below every point: the whole curve must be bounded exactly
    got = curve_extreme(curve, 0, 1.0, limit)
    assert got >= want - 1e-7  # never below a point on the curve (the check never misses a peak)
    assert got <= want + max(EXTREME_TOL_MM, 1e-7)


def test_extreme_weights_decide_quickly():
    pts = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0.0]])
    curve = Nurbs(1, 3, np.array([0, 0, 0, 0, 1, 1, 1, 1.0]), np.array([1, 1e-15, 1e15, 1]), pts, 10.0)
    assert curve_extreme(curve, 0, 1.0, 5.0) == pytest.approx(10.0, abs=1e-6)
    assert math.isfinite(curve_extreme(curve, 1, 1.0, 5.0))
