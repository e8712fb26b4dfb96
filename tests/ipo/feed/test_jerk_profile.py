"""S-curve mode's jerk-limited profile (ipo.feed.jerk_profile, ipo.feed.jerk_plan, ipo.feed.scurve)
against ruckig (the time-optimal jerk-limited trajectory generator, same limits) and, through
the planner, against finite differences of the per-period positions and brute-force distances
to the programmed path: random 3-D polylines, arc chains and NURBS with every joint type."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from ruckig import ControlInterface, InputParameter, Ruckig, Trajectory

from ipo.config import default_config
from ipo.contracts import PeriodBatch
from ipo.feed.jerk_profile import (cruise_span, peak_speed, phases, reach, state, time_at, transition_distance,
                                  transition_time)
from ipo.feed.planner import ACCEL_USE, VELOCITY_USE, FeedPlanner, plan_periods
from ipr.entities import Arc, Line, Nurbs, PathControl
from tests.ipo.feed.test_nurbs_blend import distance_to_polyline

BLU = 1e-6
CFG = dataclasses.replace(default_config(), blu_mm=BLU, accel_mode="scurve")
T = CFG.period_s
V = np.array([a.max_velocity_mm_s for a in CFG.axes])
A = np.array([a.max_accel_mm_s2 for a in CFG.axes])
J = np.array([a.max_jerk_mm_s3 for a in CFG.axes])


def ruckig_1d(p, v0, v1, vmax, a, j, *, velocity=False) -> Trajectory:
    inp = InputParameter(1)
    if velocity:
        inp.control_interface = ControlInterface.Velocity
    else:
        inp.target_position = [p]
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [0.0]
    inp.target_velocity, inp.target_acceleration = [v1], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [vmax], [a], [j]
    traj = Trajectory(1)
    Ruckig(1).calculate(inp, traj)
    return traj


def test_a_speed_change_is_ruckigs_fastest():
    rng = np.random.default_rng(3)
    for _ in range(100):
        va, vb = rng.uniform(0, 100, 2)
        a, j = rng.uniform(100, 2000), rng.uniform(1e4, 2e5)
        traj = ruckig_1d(0.0, va, vb, 1e3, a, j, velocity=True)
        assert transition_time(abs(vb - va), a, j) == pytest.approx(traj.duration, rel=1e-9)
        assert transition_distance(va, vb, a, j) == pytest.approx(traj.at_time(traj.duration)[0][0], rel=1e-9)


def test_the_speed_reached_within_a_distance_is_where_ruckigs_fastest_change_covers_it():
    """reach's closed form (both cases: with and without a phase at full acceleration, from
    standstill and from speed) against the distance of ruckig's fastest speed change."""
    rng = np.random.default_rng(5)
    for n in range(200):
        v = 0.0 if n % 4 == 0 else rng.uniform(0, 100)
        a, j = rng.uniform(100, 2000), rng.uniform(1e4, 2e5)
        d = 10 ** rng.uniform(-4, 2)
        w = reach(v, d, a, j)
        # the largest such speed, up to the last bits of w (w - v may be 1e-7 of w)
        w_up = w + max(4 * np.spacing(w), 1e-9 * (w - v))
        covered = [ruckig_1d(0.0, v, x, 1e4, a, j, velocity=True) for x in (w, w_up)]
        covered = [tr.at_time(tr.duration)[0][0] for tr in covered]
        assert covered[0] <= d * (1 + 1e-9) and covered[1] >= d * (1 - 1e-9)
        assert transition_distance(v, w, a, j) <= d  # never a speed the distance cannot hold


def test_a_segment_between_anchors_is_ruckigs_fastest_and_ends_where_it_should():
    rng = np.random.default_rng(4)
    for _ in range(200):
        va, vb = rng.uniform(0, 100, 2)
        a, j = rng.uniform(100, 2000), rng.uniform(1e4, 2e5)
        vmax = max(va, vb) + rng.uniform(0, 80)
        length = transition_distance(va, vb, a, j) * rng.uniform(1, 5) + rng.uniform(0, 20)
        vp = peak_speed(va, vb, length, vmax, a, j)
        tt, ss, vv, aa, jj = phases(va, vp, vb, length, a, j)
        traj = ruckig_1d(length, va, vb, vmax, a, j)
        assert tt[7] == pytest.approx(traj.duration, rel=1e-9)
        assert ss[7] == pytest.approx(length, rel=1e-9) and vv[7] == pytest.approx(vb, abs=1e-9)
        # the inverse of s(t) the checks use, at random arc lengths
        d = rng.uniform(0, length, 20)
        assert np.allclose([state(tt, ss, vv, aa, jj, time_at(tt, ss, vv, aa, jj, x))[0] for x in d], d,
                           atol=1e-9)


def test_the_cruise_span_holds_what_solving_for_the_time_gives_to_the_bit():
    """Inside cruise_span the checks take (vv[3] + 0, 0, 0) without time_at: at random arc lengths,
    at the span's ends and next to the cruise's end, that is state(time_at(d)) bit for bit."""
    rng = np.random.default_rng(11)
    inside = 0
    for _ in range(300):
        va, vb = rng.uniform(0, 100, 2) * rng.choice([0.0, 1.0], 2)
        a, j = rng.uniform(100, 2000), rng.uniform(1e4, 2e5)
        length = transition_distance(va, vb, a, j) * rng.uniform(1, 5) + rng.uniform(0, 200)
        vp = peak_speed(va, vb, length, max(va, vb) + rng.uniform(0, 80), a, j)
        tt, ss, vv, aa, jj = phases(va, vp, vb, length, a, j)
        c0, c1 = cruise_span(tt, ss, vv, aa, jj)
        near_end = ss[4] - np.array([0.0, 1e-15, 1e-12, 1e-9, 1e-6]) * max(1.0, ss[4])
        for d in np.concatenate([rng.uniform(0, length, 50), [c0, np.nextafter(c1, 0)], near_end]):
            if c0 <= d < c1:
                inside += 1
                want = state(tt, ss, vv, aa, jj, time_at(tt, ss, vv, aa, jj, d))[1:]
                assert (vv[3] + 0.0, 0.0, 0.0) == want
    assert inside > 5000


def run(ents, cfg=CFG):
    start = ents[0].start
    pos = [b.pos_mm for b in plan_periods(ents, cfg, start_mm=start) if isinstance(b, PeriodBatch)]
    return np.vstack([np.asarray(start, float)[None], *pos])


def assert_within_limits(pos):
    """Finite differences of the positions against the machine's limits, with the slack the
    BLU rounding needs: each position is within b/2 of the planned one, so the k-th
    difference of positions is off by at most 2^k b/2 (v: b/T, a: 2b/T^2, j: 4b/T^3)."""
    v = np.diff(pos, axis=0) / T
    a = np.diff(v, axis=0, prepend=np.zeros((1, 3))) / T
    j = np.diff(a, axis=0, prepend=np.zeros((1, 3))) / T
    assert np.all(np.abs(v) <= V + BLU / T), np.abs(v).max(0)
    assert np.all(np.abs(a) <= A + 2 * BLU / T**2), np.abs(a).max(0)
    assert np.all(np.abs(j) <= J + 4 * BLU / T**3), np.abs(j).max(0)


def test_a_single_straight_move_takes_ruckigs_time():
    """A 200 mm diagonal at F6000 from rest to rest: the planner's path limits are the axis
    limits over the direction cosines (and its own ACCEL_USE / VELOCITY_USE margins); ruckig
    with those limits on the path parameter gives the time-optimal duration. The periods
    end on the stop exactly, so the cycle lies within one period above it; 0.1 % allowed."""
    d = np.array([150.0, 100.0, 80.0])
    line = Line(1, (0.0, 0.0, 0.0), tuple(d), 100.0)
    pos = run([line])
    assert_within_limits(pos)
    u = np.abs(d) / np.linalg.norm(d)
    vmax = min(100.0, float(np.min(V * VELOCITY_USE / u)))
    traj = ruckig_1d(float(np.linalg.norm(d)), 0.0, 0.0, vmax, float(np.min(A * ACCEL_USE / u)),
                     float(np.min(J * ACCEL_USE / u)))
    cycle = (len(pos) - 1) * T
    assert traj.duration <= cycle <= traj.duration + T
    assert cycle == pytest.approx(traj.duration, rel=1e-3)
    np.testing.assert_allclose(pos[-1], d, atol=BLU)


def random_polyline(rng, n=25, tol=0.05):
    pts = np.cumsum(rng.normal(size=(n + 1, 3)) * [3.0, 3.0, 1.0], axis=0)
    p = PathControl(blend_tol_mm=tol)
    return [Line(i + 1, tuple(a), tuple(b), float(rng.uniform(20, 100)), p)
            for i, (a, b) in enumerate(zip(pts[:-1], pts[1:]))]


def random_arc_chain(rng, n=12, tol=0.05):
    """XY arcs of random radius and sweep, each starting where the last ended in a random
    direction (non-tangent joints: arc-arc corners), with lines between some of them."""
    p = PathControl(blend_tol_mm=tol)
    ents, pos, z = [], np.zeros(3), 0.0
    for i in range(n):
        r = rng.uniform(2, 10)
        phi0, sweep = rng.uniform(0, 2 * np.pi), rng.uniform(0.5, 2.5) * rng.choice([-1, 1])
        centre = pos - r * np.array([np.cos(phi0), np.sin(phi0), 0.0])
        end = centre + r * np.array([np.cos(phi0 + sweep), np.sin(phi0 + sweep), 0.0])
        end[2] = z = z + rng.uniform(-1, 1)
        ents.append(Arc(len(ents) + 1, tuple(pos), tuple(end), tuple(centre[:2]) + (pos[2],), "XY", sweep > 0,
                        float(rng.uniform(20, 80)), path=p))
        pos = end
        if rng.random() < 0.4:
            nxt = pos + rng.normal(size=3) * [4, 4, 1]
            ents.append(Line(len(ents) + 1, tuple(pos), tuple(nxt), float(rng.uniform(20, 80)), p))
            pos = nxt
    return ents


def random_nurbs_path(rng, tol=0.05):
    """Cubic NURBS (random weights) joined to lines and to each other at angles: NURBS-line,
    line-NURBS and NURBS-NURBS corners."""
    p = PathControl(blend_tol_mm=tol)
    ents, pos = [], np.zeros(3)
    for i in range(4):
        ctrl = np.vstack([pos, pos + np.cumsum(rng.normal(size=(5, 3)) * [4, 4, 1], axis=0)])
        knots = np.r_[[0.0] * 4, np.sort(rng.uniform(0.2, 0.8, 2)), [1.0] * 4]
        ents.append(Nurbs(len(ents) + 1, 3, knots, rng.uniform(0.5, 2.0, 6), ctrl, float(rng.uniform(20, 80)), p))
        pos = ctrl[-1]
        nxt = pos + rng.normal(size=3) * [4, 4, 1]
        ents.append(Line(len(ents) + 1, tuple(pos), tuple(nxt), float(rng.uniform(20, 80)), p))
        pos = nxt
    return ents


def programmed_points(ents, step=0.01):
    out = []
    for e in ents:
        if isinstance(e, Line):
            a, b = np.array(e.start), np.array(e.end)
            out.append(a + np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / step)))[:, None] * (b - a))
        elif isinstance(e, Arc):
            c, a0 = np.array(e.center), np.array(e.start)
            r = e.radius_mm
            phi0 = np.arctan2(a0[1] - c[1], a0[0] - c[0])
            q = np.linspace(0, 1, max(3, int(abs(e.sweep_rad) * r / step)))
            pts = np.c_[c[0] + r * np.cos(phi0 + e.sweep_rad * q), c[1] + r * np.sin(phi0 + e.sweep_rad * q),
                        a0[2] + (e.end[2] - a0[2]) * q]
            out.append(pts)
        else:
            from scipy.interpolate import BSpline
            hom = np.c_[e.points * e.weights[:, None], e.weights]
            c = BSpline(e.knots, hom, e.degree)(np.linspace(0, 1, 20001))
            out.append(c[:, :3] / c[:, 3:])
    return np.vstack(out)


@pytest.mark.parametrize("kind,seed", [("polyline", s) for s in range(3)] + [("arcs", s) for s in range(3)]
                         + [("nurbs", s) for s in range(2)])
def test_random_paths_within_the_limits_and_p(kind, seed):
    rng = np.random.default_rng(100 + seed)
    ents = {"polyline": random_polyline, "arcs": random_arc_chain, "nurbs": random_nurbs_path}[kind](rng)
    pos = run(ents)
    assert_within_limits(pos)
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=BLU)
    # every programmed point lies within P + delta of the per-period polyline
    dev = distance_to_polyline(programmed_points(ents), pos)
    assert dev.max() <= 0.05 + CFG.chord_tol_mm + 1e-9, dev.max()


@pytest.mark.parametrize("factor", [0.3, 1.5])
def test_a_feed_override_change_in_s_curve_mode_keeps_the_limits(factor):
    """The override changes while the machine runs (between batches): S-curve mode replans
    from the next anchor; the periods stay within v/a/j and the path ends where programmed,
    at the new feed in between (a drop brakes within the jerk limit, a raise speeds up)."""
    p = PathControl(blend_tol_mm=0.05)
    ents = [Line(1, (0.0, 0.0, 0.0), (100.0, 0.0, 0.0), 60.0, p), Line(2, (100.0, 0.0, 0.0), (100.0, 100.0, 0.0), 60.0, p)]
    planner = FeedPlanner(CFG, batch_periods=64)
    pos, n = [np.zeros((1, 3))], 0
    for b in planner.run(ents):
        if isinstance(b, PeriodBatch):
            pos.append(b.pos_mm)
            n += len(b)
            if n == 512:
                planner.set_feed_override(factor)
    pos = np.vstack(pos)
    assert_within_limits(pos)
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=BLU)
    on_y = np.abs(np.diff(pos[:, 1])) / T
    assert on_y.max() == pytest.approx(min(60.0 * factor, V[1] * VELOCITY_USE), rel=1e-3)
