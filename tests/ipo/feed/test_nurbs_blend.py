"""G64 corner blends where a NURBS meets a line or another NURBS non-tangentially.

The per-period positions (BLU 1e-9) are checked against the programmed geometry computed
here independently (scipy's BSpline in homogeneous coordinates, exact line segments), by
finite differences against the axis limits, and the corner speed against sqrt(A R) for
the blend radius R of the rule R (sec(theta/2) - 1) = P.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

from ipo.config import default_config
from ipo.feed.planner import plan_periods
from ipo.contracts import PeriodBatch
from ipo.nurbs.subcurve import sub_curve
from ipr.entities import EXACT_STOP, Arc, Line, Message, Nurbs, PathControl

BASE = default_config()
CFG = dataclasses.replace(BASE, blu_mm=1e-9)  # BLU rounding far below what is checked
V = np.array([a.max_velocity_mm_s for a in BASE.axes])
A = np.array([a.max_accel_mm_s2 for a in BASE.axes])
T = BASE.period_s
DELTA = BASE.chord_tol_mm
P = 0.01
G64P = PathControl(blend_tol_mm=P)
F = 50.0
KNOTS = np.array([0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1.0])
# a cubic leaving (10, 0) along +Y and arriving at (19, 9) along +X: three collinear control
# points at each end, so it is straight where the blends trim it
PTS = np.array([[10, 0, 0], [10, 3, 0], [10, 6, 0], [13, 9, 0], [16, 9, 0], [19, 9, 0.0]])
D30 = np.array([np.cos(np.pi / 6), -np.sin(np.pi / 6), 0.0])  # 30 degrees right of +X


def bspline_points(e: Nurbs, n: int) -> np.ndarray:
    """Dense points of a NURBS by scipy (homogeneous coordinates)."""
    w = np.asarray(e.weights, float)
    spl = BSpline(np.asarray(e.knots, float), np.column_stack([np.asarray(e.points) * w[:, None], w]), e.degree)
    h = spl(np.linspace(e.knots[0], e.knots[-1], n))
    return h[:, :3] / h[:, 3:]


def programmed(ents, n_curve=20001) -> np.ndarray:
    """The programmed path as one dense polyline (lines exact, NURBS by scipy)."""
    parts = []
    for e in ents:
        if isinstance(e, Nurbs):
            parts.append(bspline_points(e, n_curve))
        elif isinstance(e, Line):
            a, b = np.array(e.start, float), np.array(e.end, float)
            f = np.linspace(0.0, 1.0, int(np.linalg.norm(b - a) / 0.005) + 2)[:, None]
            parts.append(a + f * (b - a))
    return np.vstack(parts)


def distance_to_polyline(q: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each q from the polyline: the segments next to the nearest few vertices
    (vertices closer together than the distances that matter)."""
    _, near = cKDTree(poly).query(q, k=4)
    best = np.full(len(q), np.inf)
    for j in range(near.shape[1]):
        for s in (-1, 0):
            i = np.clip(near[:, j] + s, 0, len(poly) - 2)
            a, b = poly[i], poly[i + 1]
            ab = b - a
            f = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
            best = np.minimum(best, np.linalg.norm(q - a - f[:, None] * ab, axis=1))
    return best


def run(ents):
    items = list(plan_periods(ents, CFG, start_mm=ents[0].start))
    batches = [b for b in items if isinstance(b, PeriodBatch)]
    pos = np.concatenate([b.pos_mm for b in batches])
    feed = np.concatenate([b.feed_mm_s for b in batches])
    return items, pos, feed


def finite_differences(pos, start):
    v = np.diff(pos, axis=0, prepend=np.asarray(start, float)[None]) / T
    a = np.diff(v, axis=0, prepend=np.zeros((1, 3))) / T
    return v, a


def assert_within_limits(pos, start):
    v, a = finite_differences(pos, start)
    assert np.all(np.abs(v) <= V + 1e-6), np.abs(v).max(0)
    assert np.all(np.abs(a) <= A + 1e-3), np.abs(a).max(0)


def assert_forward_to_the_end(pos, start, end):
    """Ends exactly on the programmed end; no step turns back against the one before it."""
    assert np.max(np.abs(pos[-1] - end)) <= 1e-9
    steps = np.diff(pos, axis=0, prepend=np.asarray(start, float)[None])
    moving = steps[np.linalg.norm(steps, axis=1) > 1e-9]
    assert np.all(np.einsum("ij,ij->i", moving[1:], moving[:-1]) >= 0.0)


def blend_radius(theta, tol=P):
    return tol / (1.0 / np.cos(theta / 2) - 1.0)


def program(path, curve=None):
    e = curve or Nurbs(2, 3, KNOTS, np.ones(6), PTS, F, path)
    end = np.array(e.end)
    return [Line(1, (0, 0, 0), (10, 0, 0), F, path), e, Line(3, e.end, tuple(end + 10 * D30), F, path)]


def corner_feed(pos, feed, corner, radius_mm=0.2):
    near = np.linalg.norm(pos - corner, axis=1) < radius_mm
    assert near.any()
    return feed[near].min()


def test_sub_curve_is_the_same_curve():
    """Knot insertion keeps the curve: the part between two parameters against scipy's
    evaluation of the whole curve there (rational, with a double interior knot)."""
    knots = np.array([0, 0, 0, 0, 0.3, 0.3, 0.7, 1, 1, 1, 1.0])
    rng = np.random.default_rng(7)
    e = Nurbs(1, 3, knots, rng.uniform(0.5, 2.0, 7), rng.normal(size=(7, 3)), F)
    w = e.weights
    whole = BSpline(knots, np.column_stack([e.points * w[:, None], w]), 3)
    for u0, u1 in ((0.1, 0.9), (0.0, 0.3), (0.3, 1.0), (0.25, 0.35)):
        part = sub_curve(e, u0, u1)
        assert part.knots[0] == u0 and part.knots[-1] == u1
        u = np.linspace(u0, u1, 101)
        h = whole(u)
        np.testing.assert_allclose(bspline_points(part, 101), h[:, :3] / h[:, 3:], atol=1e-12)


def test_nurbs_corners_are_blended_within_p():
    """G01 -> G06.2 -> G01 with a 90 degree corner into the curve and a 30 degree corner out
    of it, under G64 P0.01: within P + delta of the programmed path, within the axis
    limits, and through each corner at no less than 0.8 sqrt(A R), R the blend radius of
    the rule (the unblended corner cap was A T / (2 |dt|) = 0.35 mm/s at 90 degrees)."""
    ents = program(G64P)
    _, pos, feed = run(ents)
    start, end = np.array(ents[0].start), np.array(ents[-1].end)
    dev = distance_to_polyline(pos, programmed(ents))
    assert dev.max() <= P + DELTA, dev.max()
    assert_within_limits(pos, start)
    assert_forward_to_the_end(pos, start, end)
    for corner, theta in ((PTS[0], np.pi / 2), (PTS[-1], np.pi / 6)):
        near = np.linalg.norm(pos - corner, axis=1) < 0.5
        # the blend uses its tolerance: the path leaves the corner by about P cos(theta/2)
        assert 0.8 * P * np.cos(theta / 2) <= dev[near].max() <= P + DELTA
        v_blend = np.sqrt(A.min() * blend_radius(theta))
        assert corner_feed(pos, feed, corner) >= 0.8 * v_blend, (theta, corner_feed(pos, feed, corner), v_blend)
    assert corner_feed(pos, feed, PTS[0]) > 10 * 0.5 * A.min() * T / np.sqrt(2)


def test_same_program_under_g61_stops_at_the_corners():
    ents = program(EXACT_STOP)
    _, pos, feed = run(ents)
    for corner in (PTS[0], PTS[-1]):
        d = np.linalg.norm(pos - corner, axis=1)
        k = int(np.argmin(d))
        assert d[k] <= 1e-9 and min(feed[k], feed[k + 1]) < 1.0
    assert_within_limits(pos, ents[0].start)
    assert_forward_to_the_end(pos, ents[0].start, ents[-1].end)


def test_g64_p0_does_not_blend():
    ents = program(PathControl(blend_tol_mm=0.0))
    _, pos, feed = run(ents)
    assert corner_feed(pos, feed, PTS[0]) < 1.0  # the corner cap: about 0.35 mm/s


def test_event_between_moves_gives_the_same_stream():
    """A message after the curve makes the planner build the curve in one window and its
    end corner in the next (the curve held back, trimmed at its start by the earlier
    window): the stream is the one without the message, within float rounding."""
    ents = program(G64P)
    _, ref, _ = run(ents)
    items, pos, _ = run([ents[0], Message(1, "a"), ents[1], Message(2, "b"), ents[2]])
    assert sum(isinstance(i, Message) for i in items) == 2
    assert pos.shape == ref.shape
    assert np.abs(pos - ref).max() <= 1e-9


def test_rational_nurbs_into_nurbs_corner():
    """A rational curve into another at 60 degrees: blended within P, within the limits,
    ending exactly on the last point."""
    w = np.array([1, 1, 2, 1, 1, 1.0])
    first = Nurbs(2, 3, KNOTS, w, PTS, F, G64P)
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    turn = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])  # +Y turned 30 degrees to the right: 60 degrees from +X
    second = Nurbs(3, 3, KNOTS, np.ones(6), PTS[-1] + 0.5 * (PTS - PTS[0]) @ turn.T, F, G64P)
    ents = [Line(1, (0, 0, 0), (10, 0, 0), F, G64P), first, second]
    t_out = np.array([1.0, 0, 0])
    t_in = turn @ np.array([0, 1.0, 0])
    theta = np.arccos(np.dot(t_out, t_in))
    assert abs(theta - np.pi / 3) < 1e-12
    _, pos, feed = run(ents)
    dev = distance_to_polyline(pos, programmed(ents))
    assert dev.max() <= P + DELTA
    assert_within_limits(pos, ents[0].start)
    assert_forward_to_the_end(pos, ents[0].start, second.end)
    assert corner_feed(pos, feed, PTS[-1]) >= 0.8 * np.sqrt(A.min() * blend_radius(theta))


def test_tangent_nurbs_to_line_is_crossed_at_full_feed():
    """The curve arrives along +X and the line goes on along +X: no blend, no slow-down."""
    ents = [Nurbs(1, 3, KNOTS, np.ones(6), PTS, 40.0, G64P), Line(2, tuple(PTS[-1]), (29, 9, 0), 40.0, G64P)]
    _, pos, feed = run(ents)
    near = np.linalg.norm(pos - PTS[-1], axis=1) < 1.0
    assert np.all(np.abs(feed[near] - 40.0) < 1e-6)
    assert_within_limits(pos, ents[0].start)
    assert_forward_to_the_end(pos, ents[0].start, ents[-1].end)


@pytest.mark.parametrize("path", [G64P, EXACT_STOP])
def test_reversal_still_stops(path):
    """A reversal is not blended: the machine comes (almost, under G64: the corner cap
    A T / (2 |dt|) = 0.25 mm/s) to a stop on the reversal point."""
    ents = [Nurbs(1, 3, KNOTS, np.ones(6), PTS, F, path), Line(2, tuple(PTS[-1]), (12, 9, 0), F, path)]
    _, pos, feed = run(ents)
    d = np.linalg.norm(pos - PTS[-1], axis=1)
    k = int(np.argmin(d))
    assert d[k] <= DELTA and max(feed[k], feed[k + 1]) < 1.0
    assert_within_limits(pos, ents[0].start)


def test_blend_takes_at_most_half_of_a_short_curve():
    """Under a tolerance far larger than the curve, each blend takes at most half of it: the
    path still passes (within delta) through the curve's point at half its arc length."""
    big = PathControl(blend_tol_mm=5.0)
    pts = PTS * 0.1 + [10 - 1.0, 0, 0]
    e = Nurbs(2, 3, KNOTS, np.ones(6), pts, F, big)
    ents = [Line(1, (0, 0, 0), tuple(pts[0]), F, big), e, Line(3, tuple(pts[-1]), tuple(pts[-1] + 10 * D30), F, big)]
    _, pos, _ = run(ents)
    dense = bspline_points(e, 20001)
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    mid = dense[np.searchsorted(s, 0.5 * s[-1])]
    assert distance_to_polyline(mid[None], pos)[0] <= DELTA
    assert_within_limits(pos, ents[0].start)
    assert_forward_to_the_end(pos, ents[0].start, ents[-1].end)


def test_arc_into_nurbs_corner():
    """A G3 quarter circle (R5 about (10, 5)) arriving at (15, 5) along +Y into the curve,
    which leaves along +Y turned 45 degrees to the right: blended within P of the circle
    and the curve, through the corner at no less than 0.8 sqrt(A R)."""
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    turn = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    curve = Nurbs(2, 3, KNOTS, np.ones(6), np.array([15, 5, 0]) + (PTS - PTS[0]) @ turn.T, F, G64P)
    arc = Arc(1, (10, 0, 0), (15, 5, 0), (10, 5, 0), "XY", True, F, path=G64P)
    ents = [arc, curve]
    _, pos, feed = run(ents)
    ang = np.linspace(-np.pi / 2, 0, 20001)
    circle = np.c_[10 + 5 * np.cos(ang), 5 + 5 * np.sin(ang), np.zeros_like(ang)]
    dev = distance_to_polyline(pos, np.vstack([circle, bspline_points(curve, 20001)]))
    assert dev.max() <= P + DELTA
    near = np.linalg.norm(pos - [15, 5, 0], axis=1) < 0.5
    assert dev[near].max() >= 0.5 * P * np.cos(np.pi / 8)  # blended, not crossed at the corner
    assert corner_feed(pos, feed, np.array([15, 5, 0])) >= 0.8 * np.sqrt(A.min() * blend_radius(np.pi / 4))
    assert_within_limits(pos, arc.start)
    assert_forward_to_the_end(pos, arc.start, curve.end)


def run_scurve(ents):
    cfg = dataclasses.replace(CFG, accel_mode="scurve")
    items = list(plan_periods(ents, cfg, start_mm=ents[0].start))
    pos = np.concatenate([b.pos_mm for b in items if isinstance(b, PeriodBatch)])
    feed = np.concatenate([b.feed_mm_s for b in items if isinstance(b, PeriodBatch)])
    _, a = finite_differences(pos, ents[0].start)
    jerk = np.diff(a, axis=0, prepend=np.zeros((1, 3))) / T
    j_max = np.array([ax.max_jerk_mm_s3 for ax in cfg.axes])
    assert np.all(np.abs(a) <= A + 1e-3)
    assert np.all(np.abs(jerk) <= j_max * 1.01), np.abs(jerk).max(0)
    assert np.max(np.abs(pos[-1] - ents[-1].end)) <= 1e-9
    return pos, feed


def standstills(pos, feed, where, radius_mm):
    """Runs of periods below 0.01 mm/s within radius_mm of `where`."""
    still = (np.linalg.norm(pos - where, axis=1) < radius_mm) & (feed < 0.01)
    return int(still[0]) + int(np.sum(still[1:] & ~still[:-1]))


def test_scurve_mode_stops_once_at_a_corner_too_tight_to_blend():
    """S-curve mode: the blends of P = 0.003 at 90 and 30 degrees (R = 0.0072 and 0.085 mm) lie
    below limits.min_blend_radius_mm (about 0.49 mm for these limits: the filter's lowest
    smooth speed sqrt(x_low) = A/2 * 20 ms / 2 = 4.9 mm/s against v^2 <= J/2 T R at the
    blend's ends), and the curvature-continuous joints within P are so short that their
    curvature rate caps them below a stop's gain (ipo.feed.blends.g2_joints), so each corner is
    one stop on the corner point, not two at the blend's ends."""
    pos, feed = run_scurve(program(PathControl(blend_tol_mm=0.003)))
    for corner in (PTS[0], PTS[-1]):
        assert np.linalg.norm(pos - corner, axis=1).min() <= 1e-9
        assert standstills(pos, feed, corner, 0.5) == 1


def test_scurve_mode_crosses_a_low_cap_inside_a_piece():
    """S-curve mode: a quarter circle of R 0.03 mm (an exact rational quadratic NURBS) between
    two tangent lines caps the speed at about sqrt(A/2 R) = 3.8 mm/s, below what the filter
    crosses smoothly: the machine stops where the curvature steps (the two junctions) and
    crosses the curve itself at its cap instead of stopping at each of its samples."""
    r = 0.03
    arc = Nurbs(2, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([1, np.sqrt(0.5), 1]),
                np.array([[10, 0, 0], [10 + r, 0, 0], [10 + r, r, 0.0]]), F, G64P)
    ents = [Line(1, (0, 0, 0), (10, 0, 0), F, G64P), arc, Line(3, (10 + r, r, 0), (10 + r, 10, 0), F, G64P)]
    pos, feed = run_scurve(ents)
    assert standstills(pos, feed, np.array([10 + r / 2, r / 2, 0]), 0.1) <= 2
    on_arc = np.abs(np.linalg.norm(pos[:, :2] - [10, r], axis=1) - r) < 1e-6
    assert on_arc.sum() >= 3 and feed[on_arc].max() > 1.0
