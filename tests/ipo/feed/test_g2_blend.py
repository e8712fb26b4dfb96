"""S-curve mode's curvature-continuous corner blends between lines (ipo.feed.blends.curvature_continuous), against
independent references: the quintic sampled through scipy's BSpline, curvature from the
circle through three sampled points, distances by brute force, limits by finite
differences of the per-period positions; trapezoid mode against the circular-blend rule."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import BSpline

import ipo.feed.pieces as pieces
from ipo.feed.intake import CornerRules
from ipo.feed.nurbs_driver import blend_curves
from ipo.feed.planner import FeedPlanner
from ipo.feed.blends.curvature_continuous import arc_blend_x, g2_corner_x
from ipo.contracts import PeriodBatch
from ipo.feed.pieces import KIND_ANALYTIC, KIND_BLEND, Motion, build
from ipo.feed.sampling import ARC_TOL_MM, nurbs_table
from ipr.entities import Line, PathControl
from tests.ipo.feed.test_feed import FINE

T = FINE.period_s
A = np.array([a.max_accel_mm_s2 for a in FINE.axes])
DELTA = FINE.chord_tol_mm
SCURVE = dataclasses.replace(FINE, accel_mode="scurve")
# planner limits of S-curve mode (FeedPlanner: half of A, half of J, times ACCEL_USE) and no
# minimum speed; with the arcs ruled out by NO_ARC every line-line corner gets the quintic
G2_ANY = (492.5, 49250.0, 0.0, 49.25 / 0.75)
NO_ARC = 1e9


def corner(theta_deg: float, tol_mm: float, leg_mm: float = 10.0, feed: float = 100.0):
    th = np.radians(theta_deg)
    v = np.array([leg_mm, 0.0, 0.0])
    end = v + leg_mm * np.array([np.cos(th), np.sin(th), 0.0])
    p = PathControl(blend_tol_mm=tol_mm)
    return [Line(1, (0.0, 0.0, 0.0), tuple(v), feed, p), Line(2, tuple(v), tuple(end), feed, p)]


def build_corner(ents, **kw):
    built = build([Motion(e, 0.0, -1) for e in ents], final=True, lead_trim_mm=0.0, blend_default_mm=0.0,
                  rapid_mm_s=100.0, drivers={}, next_index=0, make_drivers=blend_curves, **kw)
    return built.pieces, built.drivers.changed  # the blends it made, by index


def dense(e, n=400001):
    """Points of the blend entity through scipy, not ipo."""
    return BSpline(np.asarray(e.knots, float), np.asarray(e.points, float), e.degree)(np.linspace(0, 1, n))


def three_point_curvature(p0, p1, p2):
    a, b, c = np.linalg.norm(p1 - p0), np.linalg.norm(p2 - p1), np.linalg.norm(p2 - p0)
    area2 = np.linalg.norm(np.cross(p1 - p0, p2 - p0))
    return 2 * area2 / (a * b * c)


def distance_to_segment(pts, a, b):
    d = b - a
    u = np.clip((pts - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(pts - (a + u[:, None] * d), axis=1)


@pytest.mark.parametrize("theta_deg", [10, 30, 90, 150])
def test_blend_is_flat_at_both_ends_and_within_p(theta_deg):
    P = 0.01
    ents = corner(theta_deg, P)
    pc, drivers = build_corner(ents, g2_limits=G2_ANY, min_blend_radius_mm=NO_ARC)
    assert list(pc.kind) == [KIND_ANALYTIC, KIND_BLEND, KIND_ANALYTIC]
    e = drivers[int(pc.nurbs[1])].entity
    assert e.degree == 5
    pts = dense(e)
    vertex = np.array(ents[0].end)
    # the vertex's distance from the curve is P: the lines are long, so P sizes the blend
    gap = np.linalg.norm(pts - vertex, axis=1).min()
    assert P * (1 - 1e-6) <= gap <= P * (1 + 1e-9)
    # continuous with the trimmed lines, tangent to them
    np.testing.assert_allclose(pts[0], pc.c[0] + pc.w[0] * pc.length[0], atol=1e-12)
    np.testing.assert_allclose(pts[-1], pc.c[2], atol=1e-12)
    d_in, d_out = np.linalg.norm(pts[0] - vertex), np.linalg.norm(pts[-1] - vertex)
    assert d_in == pytest.approx(d_out, rel=1e-12)
    np.testing.assert_allclose([pc.length[0], pc.length[2]], [10 - d_in, 10 - d_out], rtol=1e-12)
    # curvature from sampled points: 0 at the ends against its peak inside
    k = np.array([three_point_curvature(pts[i - 40], pts[i], pts[i + 40]) for i in range(40, len(pts) - 40, 40)])
    k_end = [three_point_curvature(pts[0], pts[20], pts[40]), three_point_curvature(pts[-41], pts[-21], pts[-1])]
    assert max(k_end) < 1e-3 * k.max()
    # and it takes no more than half of each line where the lines are short
    pc, drivers = build_corner(corner(theta_deg, 1.0, leg_mm=0.1), g2_limits=G2_ANY, min_blend_radius_mm=NO_ARC)
    pts = dense(drivers[int(pc.nurbs[np.nonzero(pc.kind == KIND_BLEND)[0][0]])].entity)
    np.testing.assert_allclose([np.linalg.norm(pts[0] - [0.1, 0, 0]), np.linalg.norm(pts[-1] - [0.1, 0, 0])],
                               [0.05, 0.05], rtol=1e-12)
    assert np.linalg.norm(pts - [0.1, 0, 0], axis=1).min() < 1.0


@pytest.mark.parametrize("theta_deg", [30, 90])
def test_trapezoid_mode_keeps_the_circular_blend(theta_deg):
    """Without g2_limits (trapezoid mode) the corner is the arc with R (sec(theta/2) - 1) = P."""
    P, th = 0.01, np.radians(theta_deg)
    pc, drivers = build_corner(corner(theta_deg, P))
    assert not drivers and list(pc.kind) == [KIND_ANALYTIC] * 3
    r = P / (1 / np.cos(th / 2) - 1)
    assert pc.radius[1] == pytest.approx(r, rel=1e-12)
    assert pc.omega[1] == pytest.approx(1 / r, rel=1e-12)
    assert pc.length[1] == pytest.approx(r * th, rel=1e-12)
    assert pc.length[0] == pytest.approx(10 - r * np.tan(th / 2), rel=1e-12)
    assert FeedPlanner(FINE).corners.g2_limits is None


def _periods(ents, cfg, force_arc=False):
    # force_arc: the circular blend of the old S-curve corner, even where it would stop
    planner = FeedPlanner(cfg, start_mm=ents[0].start, corners=CornerRules(0.0, None) if force_arc else None)
    return np.concatenate([b.pos_mm for b in planner.run(ents) if isinstance(b, PeriodBatch)])


def _corner_speed(pos, vertex, reach_mm=0.5):
    """The lowest speed within reach_mm of the corner (an arc's is where it meets the lines)."""
    v = np.linalg.norm(np.diff(pos, axis=0), axis=1) / T
    return v[np.linalg.norm(pos[1:] - vertex, axis=1) <= reach_mm].min()


@pytest.mark.parametrize("theta_deg,jerk", [(90, 3e5), (30, 3e5), (30, 1e5), (90, 1e5)])
def test_scurve_corner_within_limits_and_p_and_faster(theta_deg, jerk):
    """G64 P0.01 (P0.1 for 90 degrees at J = 1e5 mm/s^3, where the quintic of P0.01 would be
    slower than stopping and the planner stops instead); the corner speed against the
    circular blend crossed at its own caps."""
    P = 0.1 if (theta_deg, jerk) == (90, 1e5) else 0.01
    axes = [dataclasses.replace(a, max_jerk_mm_s3=jerk) for a in SCURVE.axes]
    cfg = dataclasses.replace(SCURVE, axes=axes)
    ents = corner(theta_deg, P)
    pos = _periods(ents, cfg)
    start = np.array(ents[0].start)
    v = np.diff(pos, axis=0, prepend=start[None]) / T
    a = np.diff(v, axis=0, prepend=np.zeros((1, 3))) / T
    j = np.diff(a, axis=0, prepend=np.zeros((1, 3))) / T
    assert np.abs(v).max() <= 100.0 + 1e-6
    assert np.all(np.abs(a) <= A + 1e-3), np.abs(a).max(0)
    assert np.all(np.abs(j) <= jerk * 1.01), np.abs(j).max(0) / jerk
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=1e-9)
    # every period point within P + delta of the programmed corner
    poly = np.vstack([start[None], pos])
    mid = 0.5 * (poly[1:] + poly[:-1])  # the chords too, at their middles
    for pts in (poly, mid):
        dist = np.minimum(distance_to_segment(pts, np.array(ents[0].start), np.array(ents[0].end)),
                          distance_to_segment(pts, np.array(ents[1].start), np.array(ents[1].end)))
        assert dist.max() <= P + DELTA
    vertex = np.array(ents[0].end)
    assert _corner_speed(pos, vertex) > 1.0
    assert _corner_speed(pos, vertex) > 1.2 * _corner_speed(_periods(ents, cfg, force_arc=True), vertex)


def test_caps_used_to_choose_match_the_planned_speed():
    """g2_corner_x (the shape's tabulated peak curvature and its rate) against the same caps
    from the dense scipy samples of a built blend."""
    for theta_deg in (20, 90, 140):
        pc, drivers = build_corner(corner(theta_deg, 0.05), g2_limits=G2_ANY, min_blend_radius_mm=NO_ARC)
        e = drivers[int(pc.nurbs[1])].entity
        pts = dense(e, 20001)
        k = np.array([three_point_curvature(pts[i - 1], pts[i], pts[i + 1]) for i in range(1, len(pts) - 1)])
        s = np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))[:-1]
        dk = np.abs(np.diff(k)) / np.diff(s)
        a, jerk = G2_ANY[0], G2_ANY[1]
        x_ref = min(a / k.max(), (jerk / k.max() ** 2) ** (2 / 3), (jerk / dk.max()) ** (2 / 3))
        d = np.linalg.norm(np.array(e.points[0]) - [10, 0, 0])
        x = g2_corner_x(np.array([np.radians(theta_deg)]), np.array([d]), a, jerk)[0]
        assert x == pytest.approx(x_ref, rel=0.02)
    r = 2.0
    assert arc_blend_x(np.array([r]), np.array([1 / r]), 500.0, 5e4, 60.0)[0] == pytest.approx(
        min(60.0 * r, (5e4 * r * r) ** (2 / 3)))


def test_quintic_table_and_points_by_arc_length_against_scipy():
    """The compiled quintic path (ipo.feed.blends.compiled via nurbs_table / points_at): arc length and
    points at given arc lengths against scipy's BSpline integrated on a dense grid."""
    pc, drivers = build_corner(corner(70, 0.05), g2_limits=G2_ANY, min_blend_radius_mm=NO_ARC)
    e = drivers[int(pc.nurbs[1])].entity
    tab = nurbs_table(e)
    spline = BSpline(np.asarray(e.knots, float), np.asarray(e.points, float), 5)
    u = np.linspace(0, 1, 400001)
    speed = np.linalg.norm(spline(u, 1), axis=1)
    s_ref = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(u))])
    assert tab.length == pytest.approx(s_ref[-1], abs=ARC_TOL_MM)  # the tables' stated accuracy
    s = np.linspace(0, tab.length, 37)
    want = spline(np.interp(s, s_ref, u))
    np.testing.assert_allclose(tab.points_at(e, s), want, atol=ARC_TOL_MM)


def test_polyline_along_a_curve_keeps_its_chained_arcs(monkeypatch):
    """A 1-degree polygon of 0.17 mm moves (circle360's kind) under G64 P0.01 in S-curve mode,
    corner by corner (the run's chain, ipo.feed.blends.g2_chains, switched off):
    the arcs fill half of each move and meet each other at the same curvature, so they stay
    arcs of the polygon's radius (a quintic chain returns to curvature 0 at every join); only
    the first and last corner, which meet a straight, and their neighbours (which then meet a
    quintic's flat end: g2_corners decides twice) may take the quintic. An isolated 10-degree
    corner between 10 mm lines takes it."""
    monkeypatch.setattr(pieces, "chain_runs", lambda small, slow: np.zeros(len(small), bool))
    planner = FeedPlanner(SCURVE)
    limits = planner.corners._asdict()
    ang = np.radians(np.arange(0, 91))
    pts = np.c_[10 * np.cos(ang), 10 * np.sin(ang), np.zeros(len(ang))]
    p = PathControl(blend_tol_mm=0.01)
    ents = [Line(i + 1, tuple(pts[i]), tuple(pts[i + 1]), 50.0, p) for i in range(len(pts) - 1)]
    pc, _ = build_corner(ents, **limits)
    inner = np.nonzero(pc.length > 0)[0]
    blends = inner[(pc.kind[inner] == KIND_BLEND) | (pc.omega[inner] != 0)]
    assert len(blends) == 89
    assert np.sum(pc.kind[blends] == KIND_BLEND) <= 4
    arcs = blends[2:-2]
    assert np.all(pc.kind[arcs] == KIND_ANALYTIC)
    np.testing.assert_allclose(pc.radius[arcs], 10 * np.cos(np.radians(0.5)), rtol=1e-4)
    pc, _ = build_corner(corner(10, 0.01), **limits)
    assert list(pc.kind) == [KIND_ANALYTIC, KIND_BLEND, KIND_ANALYTIC]


@pytest.mark.parametrize("seed", range(8))
def test_random_polylines_in_scurve_mode(seed):
    """Random 3-D polylines (moves 0.05-5 mm, turns up to 143 degrees, P 0.005-0.3) in S-curve
    mode: v, a, j by finite differences within the limits, every period point within
    P + delta of the programmed polyline, the end reached."""
    rng = np.random.default_rng(seed)
    n = rng.integers(4, 10)
    length = np.exp(rng.uniform(np.log(0.05), np.log(5), n))
    head = np.cumsum(rng.uniform(-2.5, 2.5, n))
    steps = np.c_[length * np.cos(head), length * np.sin(head), rng.uniform(-0.3, 0.3, n) * length]
    pts = np.vstack([[0.0, 0.0, 0.0], np.cumsum(steps, axis=0)])
    P = float(rng.choice([0.005, 0.01, 0.05, 0.1, 0.3]))
    p = PathControl(blend_tol_mm=P)
    ents = [Line(i + 1, tuple(pts[i]), tuple(pts[i + 1]), float(rng.uniform(20, 100)), p) for i in range(n)]
    pos = _periods(ents, SCURVE)
    v = np.diff(pos, axis=0, prepend=pts[:1]) / T
    a = np.diff(v, axis=0, prepend=np.zeros((1, 3))) / T
    j = np.diff(a, axis=0, prepend=np.zeros((1, 3))) / T
    jerk = np.array([ax.max_jerk_mm_s3 for ax in SCURVE.axes])
    assert np.all(np.abs(v) <= 100.0 + 1e-6) and np.all(np.abs(a) <= A + 1e-3)
    assert np.all(np.abs(j) <= jerk * 1.01), np.abs(j).max(0) / jerk
    np.testing.assert_allclose(pos[-1], pts[-1], atol=1e-9)
    dist = np.min([distance_to_segment(pos, pts[i], pts[i + 1]) for i in range(n)], axis=0)
    assert dist.max() <= P + DELTA
