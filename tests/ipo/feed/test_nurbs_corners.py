"""Corners inside one NURBS: interior knots of multiplicity p (C0) where the tangent turns.

The per-period positions (BLU 1e-9) are checked against the programmed geometry computed
here independently (exact segments for the degree-1 polyline, scipy's BSpline for the
cubic), by finite differences against the axis limits, and the corner speed against
sqrt(A R) for the blend radius of the rule R (sec(theta/2) - 1) = P. The last tests check
the NURBS driver's tracking of the planned arc length on smooth random curves (seeds that
went over the acceleration limit before).
"""
from __future__ import annotations

import numpy as np
import pytest

from ipo.feed.planner import plan_periods
from ipo.feed.split import corner_knots, corner_parts
from ipo.contracts import PeriodBatch
from ipr import parse_text
from ipr.entities import EXACT_STOP, Line, Message, Nurbs, PathControl
from tests.ipo.feed.test_nurbs_blend import (CFG, DELTA, A, F, P, T, assert_forward_to_the_end, assert_within_limits,
                                    blend_radius, bspline_points, corner_feed, distance_to_polyline, run_scurve)

G64P = PathControl(blend_tol_mm=P)
G64P0 = PathControl(blend_tol_mm=0.0)
MODES = {"G61": EXACT_STOP, "G64 P0": G64P0, "G64 P0.01": G64P}

# degree 1 (G06.2 P2): a polyline with two 90 degree corners
POLY_PTS = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [20, 10, 0.0]])
POLY_KNOTS = np.array([0, 0, 1, 2, 3, 3.0])
# a cubic with a triple interior knot: arrives at (10, 0) along +X, leaves at 45 degrees
D45 = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0])
CUBIC_PTS = np.array([[0, 0, 0], [3, 2, 0], [7, 0, 0], [10, 0, 0], [10, 0, 0] + 3 * D45, [10, 0, 0] + 6 * D45,
                      [18, 9, 0.0]])
CUBIC_KNOTS = np.array([0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2.0])
CURVES = {
    "polyline": (1, POLY_KNOTS, POLY_PTS, [(POLY_PTS[1], np.pi / 2), (POLY_PTS[2], np.pi / 2)]),
    "cubic": (3, CUBIC_KNOTS, CUBIC_PTS, [(CUBIC_PTS[3], np.pi / 4)]),
}


def curve(name: str, path: PathControl) -> Nurbs:
    p, knots, pts, _ = CURVES[name]
    return Nurbs(1, p, knots, np.ones(len(pts)), pts, F, path)


def run(ents):
    items = list(plan_periods(ents, CFG, start_mm=ents[0].start))
    batches = [b for b in items if isinstance(b, PeriodBatch)]
    return (np.concatenate([b.pos_mm for b in batches]), np.concatenate([b.feed_mm_s for b in batches]),
            np.concatenate([b.line for b in batches]))


def exact_path(name: str) -> np.ndarray:
    """The programmed curve as a dense polyline: the polyline's own vertices (its segments
    are exact), the cubic by scipy."""
    if name == "polyline":
        return POLY_PTS
    return bspline_points(curve(name, G64P), 40001)


def test_corner_knots_against_hand_computed_turns():
    assert corner_knots(curve("polyline", G64P)).tolist() == [1.0, 2.0]
    assert corner_knots(curve("cubic", G64P)).tolist() == [1.0]
    parts = corner_parts(curve("cubic", G64P))
    for q, knots in zip(parts, ([0, 0, 0, 0, 1, 1, 1, 1], [1, 1, 1, 1, 2, 2, 2, 2]), strict=True):
        np.testing.assert_allclose(q.knots, knots, rtol=0, atol=1e-12)  # |C'| = 9 on both sides
    np.testing.assert_array_equal(parts[0].points, CUBIC_PTS[:4])
    np.testing.assert_array_equal(parts[1].points, CUBIC_PTS[3:])


@pytest.mark.parametrize("name", CURVES)
@pytest.mark.parametrize("mode", ["G61", "G64 P0"])
def test_unblended_interior_corner_is_crossed_exactly_and_slowly(name, mode):
    """G61 stops on the corner: a period ends on it (within BLU) and the mean feed of the
    periods on either side is at most A T / 2 (braking to zero within a period). G64 P0
    crosses it within one period at the corner cap A T / (2 |dt|) (0.35 mm/s at 90
    degrees, 0.65 mm/s at 45), cutting it by at most the chord tolerance."""
    e = curve(name, MODES[mode])
    pos, feed, line = run([e])
    for corner, _ in CURVES[name][3]:
        d = np.linalg.norm(pos - corner, axis=1)
        k = int(np.argmin(d))
        assert d[k] <= (1e-9 if mode == "G61" else DELTA), d[k]
        if mode == "G61":
            assert max(feed[k], feed[k + 1]) <= 0.5 * A.min() * T, (feed[k], feed[k + 1])
        else:
            assert min(feed[k], feed[k + 1]) < 1.0
    assert_within_limits(pos, e.start)
    assert_forward_to_the_end(pos, e.start, e.end)
    assert np.all(line == 1)


@pytest.mark.parametrize("name", CURVES)
def test_interior_corner_is_blended_within_p(name):
    """G64 P0.01: within P + delta of the exact curve, the tolerance used at each corner,
    within the axis limits, and through the corner at >= 0.8 sqrt(A R)."""
    e = curve(name, G64P)
    pos, feed, line = run([e])
    dev = distance_to_polyline(pos, exact_path(name))
    assert dev.max() <= P + DELTA, dev.max()
    for corner, theta in CURVES[name][3]:
        near = np.linalg.norm(pos - corner, axis=1) < 0.5
        assert 0.8 * P * np.cos(theta / 2) <= dev[near].max() <= P + DELTA
        v_blend = np.sqrt(A.min() * blend_radius(theta))
        assert corner_feed(pos, feed, corner) >= 0.8 * v_blend, (corner_feed(pos, feed, corner), v_blend)
    assert_within_limits(pos, e.start)
    assert_forward_to_the_end(pos, e.start, e.end)
    assert np.all(line == 1)


def test_polyline_program_through_the_interpreter():
    """G06.2 P2 text followed by a message and a G1: the corners are blended, the periods
    carry the curve's line until it ends, and the message comes out once, in the period
    that reaches the curve's end (the last part of the split curve)."""
    text = "\n".join(["G21 G90 G17 G64 P0.01 F3000", "G06.2 P2 K0 X0 Y0 Z0",
                      "K0 X10 Y0", "K1 X10 Y10", "K2 X20 Y10", "K3", "K3", "(MSG, done)", "G1 X30", "M2"])
    ents = parse_text(text).entities
    nurbs = [e for e in ents if isinstance(e, Nurbs)]
    assert len(nurbs) == 1 and nurbs[0].line == 2
    items = list(plan_periods(ents, CFG))
    batches = [b for b in items if isinstance(b, PeriodBatch)]
    pos = np.concatenate([b.pos_mm for b in batches])
    line = np.concatenate([b.line for b in batches])
    dev = distance_to_polyline(pos, np.vstack([POLY_PTS, [[30, 10, 0]]]))
    assert dev.max() <= P + DELTA
    assert set(np.unique(line).tolist()) == {2, 9}
    on_curve = line == 2
    assert np.linalg.norm(pos[on_curve][-1] - POLY_PTS[-1]) <= F * T  # the last period on the curve
    assert sum(isinstance(i, Message) for i in items) == 1
    k = [i for i, item in enumerate(items) if isinstance(item, Message)][0]
    emitted = sum(len(b) for b in items[:k] if isinstance(b, PeriodBatch))
    assert np.linalg.norm(pos[emitted - 1] - POLY_PTS[-1]) <= F * T  # where the curve ends
    assert_within_limits(pos, (0, 0, 0))
    assert np.max(np.abs(pos[-1] - [30, 10, 0])) <= 1e-9


@pytest.mark.parametrize("path", [EXACT_STOP, G64P0])
def test_c0_knot_with_agreeing_tangents_is_crossed_at_full_feed(path):
    """A triple knot of a cubic whose control points are collinear through it (straight in,
    a bend out of it, the tangent continuous) and a degree-1 knot between collinear
    segments: no corner, so no stop even under G61."""
    cubic = Nurbs(1, 3, CUBIC_KNOTS, np.ones(7), np.array([[0, 0, 0], [4, 0, 0], [8, 0, 0], [12, 0, 0], [16, 0, 0],
                                                           [20, 0.5, 0], [24, 1.5, 0.0]]), F, path)
    poly = Nurbs(1, 1, np.array([0, 0, 1, 2, 2.0]), np.ones(3), np.array([[0, 0, 0], [5, 0, 0], [12, 0, 0.0]]), F,
                 path)
    for e, knot_point in ((cubic, np.array([12, 0, 0.0])), (poly, np.array([5, 0, 0.0]))):
        assert len(corner_parts(e)) == 1
        pos, feed, _ = run([e])
        near = np.linalg.norm(pos - knot_point, axis=1) < 1.0
        assert np.all(np.abs(feed[near] - F) < 1e-6), feed[near].min()
        assert_within_limits(pos, e.start)
        assert_forward_to_the_end(pos, e.start, e.end)


def test_repeated_polyline_point_is_a_corner_like_any_other():
    """A point repeated at a polyline corner (a zero-length segment) plans the same stream as
    the polyline without it."""
    pts = np.insert(POLY_PTS, 2, POLY_PTS[1], axis=0)
    e = Nurbs(1, 1, np.array([0, 0, 1, 2, 3, 4, 4.0]), np.ones(5), pts, F, G64P)
    pos, _, _ = run([e])
    ref, _, _ = run([curve("polyline", G64P)])
    assert pos.shape == ref.shape and np.abs(pos - ref).max() <= 1e-9


def random_cubic(seed: int) -> Nurbs:
    """A smooth rational cubic through a random walk of 5..11 control points (random interior
    knots and weights) at a random feed, under G64 P0.01."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 12))
    pts = np.cumsum(rng.normal(scale=8.0, size=(n, 3)), axis=0)
    pts[0] = 0.0
    weights = rng.uniform(0.5, 2.0, n)
    knots = np.concatenate([[0.0] * 4, np.sort(rng.uniform(0.0, 1.0, n - 4)), [1.0] * 4])
    return Nurbs(1, 3, knots, weights, pts, float(rng.uniform(20.0, 100.0)), G64P)


# seeds whose curves went 4-11 % over the acceleration limit with the stepper's fixed two
# evaluations and the driver's stepwise lag correction, and 2 % with either fix alone
@pytest.mark.parametrize("seed", [1, 8, 19, 40, 53, 98, 136])
def test_stepper_tracking_stays_within_the_axis_limits(seed):
    e = random_cubic(seed)
    pos, _, _ = run([e])
    assert_within_limits(pos, e.start)
    assert_forward_to_the_end(pos, e.start, e.end)


def random_c0_curve(seed: int, path: PathControl) -> Nurbs:
    """A random rational curve of degree 1..3 made of 2..4 Bezier pieces joined at knots of
    multiplicity p: a corner at every joint (a random turn), a random feed."""
    rng = np.random.default_rng(seed)
    p = int(rng.choice([1, 2, 3]))
    pieces = int(rng.integers(2, 5))
    n = p * pieces + 1
    pts = np.cumsum(rng.normal(scale=5.0, size=(n, 3)), axis=0)
    pts[0] = 0.0
    inner = np.repeat(np.sort(rng.uniform(0.0, 1.0, pieces - 1)), p)
    knots = np.concatenate([[0.0] * (p + 1), inner, [1.0] * (p + 1)])
    return Nurbs(1, p, knots, rng.uniform(0.5, 2.0, n), pts, float(rng.uniform(20.0, 100.0)), path)


# seed 71 has a turn of radius 2 um crossed at 1.5 mm/s: 0.4 um of arc-length readback error
# there (a coarse table's s(u)) went 9.5 % over the acceleration limit
@pytest.mark.parametrize("seed", [0, 1, 2, 5, 14, 71])  # degrees 3, 2, 3, 3, 1, 3
@pytest.mark.parametrize("mode", MODES)
def test_random_curves_with_corners_inside_stay_within_the_limits(seed, mode):
    """Every joint is a corner (some sharper than 90 degrees): the unsplit curve went up to
    150 times over the acceleration limit there. Split, every mode keeps the axis limits
    and ends on the end point, and the path (the polyline through the period points)
    passes each corner within the mode's tolerance."""
    e = random_c0_curve(seed, MODES[mode])
    pos, _, _ = run([e])
    assert_within_limits(pos, e.start)
    assert np.max(np.abs(pos[-1] - e.end)) <= 1e-9
    tol = {"G61": 1e-9, "G64 P0": DELTA, "G64 P0.01": P + DELTA}[mode]
    firsts = np.unique(e.knots[e.degree + 1:-e.degree - 1], return_index=True)[1] + e.degree + 1
    assert len(firsts) >= 1
    corners = e.points[firsts - 1]  # a knot of multiplicity p: the curve passes the point before it
    assert np.all(distance_to_polyline(corners, np.vstack([e.start, pos])) <= tol)


@pytest.mark.parametrize("name", CURVES)
@pytest.mark.parametrize("mode", MODES)
def test_scurve_mode_keeps_jerk_at_interior_corners(name, mode):
    """S-curve mode: within A and 1.01 J by finite differences, ending on the end point."""
    run_scurve([curve(name, MODES[mode])])


def _scipy_speed(e):
    """|C'(u)| of the rational curve e by scipy's BSpline in homogeneous coordinates."""
    from scipy.interpolate import BSpline

    w = np.asarray(e.weights, float)
    spl = BSpline(np.asarray(e.knots, float), np.column_stack([e.points * w[:, None], w]), e.degree)
    dspl = spl.derivative()

    def speed(u):
        h, dh = spl(u), dspl(u)
        return np.linalg.norm((dh[:3] * h[3] - h[:3] * dh[3]) / h[3] ** 2)

    return speed


def test_arc_length_readback_against_quadrature():
    """The table's s(u), through which the driver reads the stepper's position back, against
    scipy's adaptive quadrature of |C'(u)| (evaluated by scipy's BSpline), on a rational
    cubic whose parametric speed varies a lot: within 1e-6 mm everywhere."""
    from scipy.integrate import quad

    from ipo.feed.sampling import nurbs_table

    e = corner_parts(random_c0_curve(71, G64P))[0]
    speed = _scipy_speed(e)
    tab = nurbs_table(e)
    u = np.linspace(e.knots[0], e.knots[-1], 41)
    exact = np.cumsum([0.0] + [quad(speed, a, b, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
                               for a, b in zip(u[:-1], u[1:])])
    assert np.abs(np.array([tab.s_of_u(x) for x in u]) - exact).max() <= 1e-6


def test_u_at_arc_lengths_against_quadrature():
    """NurbsTable.u_at (the corner blends and joints trim a NURBS by arc length through it):
    at 23 arc lengths, the quadrature of |C'| (scipy's BSpline, scipy's quad) from the curve's
    start to the u found is the arc length asked for, within 1e-6 mm."""
    from scipy.integrate import quad

    from ipo.feed.sampling import nurbs_table

    e = corner_parts(random_c0_curve(72, G64P))[0]
    speed = _scipy_speed(e)
    tab = nurbs_table(e)
    s = np.linspace(0.0, tab.length, 23)
    u = tab.u_at(e, s)
    knots = np.unique(e.knots)
    got = [sum(quad(speed, a, min(b, x), epsabs=1e-13, epsrel=1e-13, limit=200)[0]
               for a, b in zip(knots[:-1], knots[1:]) if a < x) for x in u]
    assert np.all(np.diff(u) > 0) and np.abs(np.array(got) - s).max() <= 1e-6


@pytest.mark.parametrize("path", [EXACT_STOP, G64P0, G64P])
def test_polyline_nurbs_runs_as_the_same_g1_program(path):
    """A degree-1 NURBS through 60 points with a turn at each (random knots and weights) is
    the polyline the same G1 blocks program: the same per-period positions."""
    rng = np.random.default_rng(3)
    ang = np.linspace(0.0, 1.5 * np.pi, 60)
    pts = np.c_[20 * np.cos(ang), 20 * np.sin(ang) + rng.normal(scale=0.2, size=60), 0.1 * ang]
    knots = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 2.0, 59)), [0.0]])
    knots[-1] = knots[-2]
    e = Nurbs(1, 1, np.concatenate([[0.0], knots]), rng.uniform(0.5, 2.0, 60), pts, F, path)
    lines = [Line(1, tuple(a), tuple(b), F, path) for a, b in zip(pts[:-1], pts[1:])]
    pos, _, line = run([e])
    ref, _, _ = run(lines)
    # within one BLU: the parts' end points come back from homogeneous coordinates (x w / w)
    assert pos.shape == ref.shape and np.abs(pos - ref).max() <= 1.001e-9
    assert np.all(line == 1)
