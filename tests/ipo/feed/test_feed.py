"""Feed stage end to end: per-period positions checked by finite differences and against
analytic geometry (trapezoid times, circle radii, scipy's BSpline for NURBS)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import BSpline

from ipo.config import Finishing, default_config
from ipo.feed.planner import ACCEL_USE, FeedPlanner, plan_periods
from ipr import iter_entities, parse_text
from ipo.contracts import LIMIT_ACCEL, LIMIT_AXIS, LIMIT_CURVATURE, LIMIT_PROGRAMMED, LIMIT_ROUGHNESS, PeriodBatch
from ipr.entities import (EXACT_STOP, MOTION_TYPES, Arc, Dwell, Line, Message, Nurbs, PathControl, ProgramEnd, Rapid,
                          Spindle, Stop)

BASE = default_config()
FINE = dataclasses.replace(BASE, blu_mm=1e-9)  # BLU rounding far below the limits' resolution
V = np.array([a.max_velocity_mm_s for a in BASE.axes])
A = np.array([a.max_accel_mm_s2 for a in BASE.axes])
T = BASE.period_s
G64 = PathControl(blend_tol_mm=0.01)


def run(entities, cfg=FINE, **kw):
    start = kw.pop("start_mm", None)
    if start is None:
        start = next(e for e in entities if hasattr(e, "start")).start
    items = list(plan_periods(entities, cfg, start_mm=start, **kw))
    batches = [b for b in items if isinstance(b, PeriodBatch)]
    cat = {f: np.concatenate([getattr(b, f) for b in batches]) for f in ("pos_mm", "inc_blu", "feed_mm_s",
                                                                        "limit", "line")}
    return items, cat, np.asarray(start, float)


def finite_differences(pos, start):
    v = np.diff(pos, axis=0, prepend=start[None]) / T
    a = np.diff(v, axis=0, prepend=np.zeros((1, 3))) / T
    return v, a


def assert_within_limits(pos, start, tol_v=1e-6, tol_a=1e-3):
    v, a = finite_differences(pos, start)
    assert np.all(np.abs(v) <= V + tol_v), np.abs(v).max(0)
    assert np.all(np.abs(a) <= A + tol_a), np.abs(a).max(0)


def polygon_circle(n=360, r=10.0, feed=50.0, path=G64):
    ang = np.linspace(0, 2 * np.pi, n + 1)
    p = np.c_[r * np.cos(ang), r * np.sin(ang), np.zeros(n + 1)]
    return [Line(i + 1, tuple(p[i]), tuple(p[i + 1]), feed, path) for i in range(n)]


def quarter_nurbs(feed=50.0):
    return Nurbs(1, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([1, np.sqrt(0.5), 1]),
                 np.array([[10, 0, 0], [10, 10, 0], [0, 10, 0.0]]), feed)


def test_straight_line_is_a_trapezoid():
    L, F = 30.0, 50.0
    _, out, start = run([Line(1, (0, 0, 0), (L, 0, 0), F)])
    a = A[0] * ACCEL_USE
    t_trap = L / F + F / a  # accelerate and brake at a, cruise at F
    assert len(out["pos_mm"]) * T == pytest.approx(t_trap, abs=2 * T)
    np.testing.assert_allclose(out["pos_mm"][-1], [L, 0, 0], atol=1e-9)
    assert out["feed_mm_s"].max() == pytest.approx(F, rel=1e-9)
    assert_within_limits(out["pos_mm"], start)


def test_increments_sum_to_the_end_in_blu():
    items, out, _ = run([Line(1, (0, 0, 0), (1.2345678, -2.5, 0.3), 20.0)], cfg=BASE)
    np.testing.assert_array_equal(out["inc_blu"].sum(0), np.rint(np.array([1.2345678, -2.5, 0.3]) / 1e-3))
    np.testing.assert_allclose(out["pos_mm"][-1], [1.235, -2.5, 0.3], atol=1e-12)


@pytest.mark.parametrize("name", ["polygon", "g2", "nurbs", "helix", "corners_g64", "corners_g61", "rapid_3d"])
def test_no_axis_exceeds_its_limits(name):
    ents = {
        "polygon": lambda: polygon_circle(),
        "g2": lambda: [Arc(1, (10, 0, 0), (10, 0, 0), (0, 0, 0), "XY", False, 90.0)],
        "nurbs": lambda: [quarter_nurbs(150.0)],
        "helix": lambda: [Arc(1, (5, 0, 0), (5, 0, 3), (0, 0, 0), "XY", True, 80.0, turns=2)],
        "corners_g64": lambda: [Line(1, (0, 0, 0), (10, 0, 0), 80.0, G64), Line(2, (10, 0, 0), (10, 10, 2), 80.0, G64),
                                Line(3, (10, 10, 2), (0, 3, 2), 80.0, G64)],
        "corners_g61": lambda: [Line(1, (0, 0, 0), (10, 0, 0), 80.0, EXACT_STOP),
                                Line(2, (10, 0, 0), (10, 10, 0), 80.0, EXACT_STOP)],
        "rapid_3d": lambda: [Rapid(1, (0, 0, 0), (40, 30, -20)), Rapid(2, (40, 30, -20), (0, 0, 0))],
    }[name]()
    _, out, start = run(ents)
    assert_within_limits(out["pos_mm"], start)
    np.testing.assert_allclose(out["pos_mm"][-1], ents[-1].end, atol=1e-9)


def test_circle_radius_and_chord_error():
    """Every period point lies on the G2 circle; the chord sagitta stays within delta."""
    _, out, start = run([Arc(1, (10, 0, 0), (10, 0, 0), (0, 0, 0), "XY", False, 100.0)])
    r = np.linalg.norm(out["pos_mm"][:, :2], axis=1)
    np.testing.assert_allclose(r, 10.0, atol=1e-9)
    chord = np.linalg.norm(np.diff(out["pos_mm"], axis=0), axis=1)
    sagitta = 10.0 - np.sqrt(100.0 - (chord / 2) ** 2)
    assert sagitta.max() <= BASE.chord_tol_mm * (1 + 1e-9)


def _nurbs_dense(e, n=200001):
    hom = np.c_[e.points * e.weights[:, None], e.weights]
    u = np.linspace(e.knots[e.degree], e.knots[-e.degree - 1], n)
    h = BSpline(e.knots, hom, e.degree)(u)
    return h[:, :3] / h[:, 3:]


def test_realised_chord_error_on_a_tight_nurbs():
    """A curve with a sharp curvature peak: the largest distance of the curve from the
    per-period polyline stays within delta (the curve sampled by scipy, not by ipo)."""
    pts = np.array([[0, 0, 0], [20, 0, 0], [20.5, 0.8, 0], [20, 1.6, 0], [0, 2, 0.0]])
    e = Nurbs(1, 3, np.array([0, 0, 0, 0, 0.5, 1, 1, 1, 1.0]), np.ones(5), pts, 100.0)
    _, out, start = run([e])
    poly = np.vstack([start[None], out["pos_mm"]])
    dense = _nurbs_dense(e)
    # distance of each dense point from the nearest polyline segment among its neighbours
    j = np.searchsorted(np.cumsum(np.r_[0, np.linalg.norm(np.diff(poly, axis=0), axis=1)]),
                        np.cumsum(np.r_[0, np.linalg.norm(np.diff(dense, axis=0), axis=1)]))
    best = np.full(len(dense), np.inf)
    for off in (-2, -1, 0, 1):
        a = np.clip(j + off, 0, len(poly) - 2)
        p0, d = poly[a], poly[a + 1] - poly[a]
        u = np.clip(np.einsum("ij,ij->i", dense - p0, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-30), 0, 1)
        best = np.minimum(best, np.linalg.norm(dense - p0 - u[:, None] * d, axis=1))
    assert best.max() <= BASE.chord_tol_mm * 1.02
    assert_within_limits(out["pos_mm"], start)
    assert (out["limit"] == LIMIT_CURVATURE).any()


def test_g61_stops_at_the_corner_and_g64_does_not():
    corner = np.array([10.0, 0, 0])
    for path, stops in ((EXACT_STOP, True), (PathControl(blend_tol_mm=0.5), False)):
        _, out, _ = run([Line(1, (0, 0, 0), (10, 0, 0), 50.0, path), Line(2, (10, 0, 0), (10, 10, 0), 50.0, path)])
        d = np.linalg.norm(out["pos_mm"] - corner, axis=1)
        k = int(np.argmin(d))
        if stops:
            assert d[k] < 1e-12 and out["feed_mm_s"][k + 1] < 1.0
        else:
            assert d.min() > 0.05  # the blend cuts the corner, by no more than P
            assert out["feed_mm_s"][k] > 15.0


def test_tangent_junctions_are_crossed_at_full_feed():
    """Line -> tangent arc -> tangent line at 40 mm/s: the curvature limit sqrt(A R) is
    far above, so the feed stays at the programmed value across both junctions."""
    ents = [Line(1, (0, 0, 0), (10, 0, 0), 40.0), Arc(2, (10, 0, 0), (20, 10, 0), (10, 10, 0), "XY", True, 40.0),
            Line(3, (20, 10, 0), (20, 20, 0), 40.0)]
    _, out, start = run(ents)
    mid = (out["line"] == 2)
    assert np.all(np.abs(out["feed_mm_s"][mid] - 40.0) < 1e-6)
    assert_within_limits(out["pos_mm"], start)


def test_limit_reasons():
    # diagonal in XY at 150 mm/s: each axis would run 106 mm/s > 100
    _, out, _ = run([Line(1, (0, 0, 0), (100, 100, 0), 150.0)])
    assert (out["limit"] == LIMIT_AXIS).sum() > 100
    assert out["feed_mm_s"].max() == pytest.approx(100 * np.sqrt(2) * 0.995, rel=1e-3)
    # a radius 2 circle at 100 mm/s: per axis, v^2 / R |n_i| <= A, so sqrt(A R) = 44.7 mm/s
    # where the normal lies along an axis and up to sqrt(sqrt(2) A R) = 53.2 mm/s between
    _, out, _ = run([Arc(1, (2, 0, 0), (2, 0, 0), (0, 0, 0), "XY", True, 100.0)])
    assert (out["limit"] == LIMIT_CURVATURE).any()
    assert out["feed_mm_s"].max() <= np.sqrt(np.sqrt(2) * A[0] * 2.0)
    ang = np.arctan2(out["pos_mm"][:, 1], out["pos_mm"][:, 0])
    on_axis = np.abs(np.sin(2 * ang)) < 0.05
    assert out["feed_mm_s"][on_axis].max() <= np.sqrt(A[0] * 2.0) * 1.01
    _, out, _ = run([Line(1, (0, 0, 0), (10, 0, 0), 20.0)])
    assert (out["limit"] == LIMIT_PROGRAMMED).sum() > 300


def test_roughness_limiter_on_flat_and_steep_moves():
    """002 §4 conditions: 3518 mm/min on a horizontal pass, the programmed 5000 on a 30 deg slope."""
    cfg = dataclasses.replace(FINE, finishing=Finishing(1, 0.2, 3.3))
    f5000 = 5000 / 60
    slope = (40 * np.cos(np.radians(30)), 0, 40 * np.sin(np.radians(30)))
    ents = [Spindle(1, 12500, "cw"), Line(2, (0, 0, 0), (60, 0, 0), f5000, EXACT_STOP),
            Line(3, (60, 0, 0), tuple(np.add((60, 0, 0), slope)), f5000, EXACT_STOP)]
    items, out, _ = run(ents, start_mm=(0, 0, 0), cfg=dataclasses.replace(cfg, axes=tuple(
        dataclasses.replace(a, max_velocity_mm_s=200.0) for a in cfg.axes)))
    flat = out["feed_mm_s"][out["line"] == 2].max() * 60
    steep = out["feed_mm_s"][out["line"] == 3].max() * 60
    assert flat == pytest.approx(2 * 12500 * np.sqrt(2 * 3 * 0.0033 - 0.0033**2), rel=2e-4)
    assert flat <= 2 * 12500 * np.sqrt(2 * 3 * 0.0033 - 0.0033**2)
    assert (out["limit"] == LIMIT_ROUGHNESS).any()
    assert steep == pytest.approx(5000, rel=1e-6)
    assert isinstance(items[0], Spindle)


def test_events_dwell_and_stop_in_order():
    ents = [Line(1, (0, 0, 0), (5, 0, 0), 20.0), Message(2, "half way"), Line(3, (5, 0, 0), (10, 0, 0), 20.0),
            Dwell(4, 0.25), Line(5, (10, 0, 0), (10, 5, 0), 20.0), Stop(6, False), ProgramEnd(7)]
    items, out, _ = run(ents)
    kinds = [type(i).__name__ for i in items]
    k_msg, k_stop = kinds.index("Message"), kinds.index("Stop")
    before = np.concatenate([b.pos_mm for b in items[:k_msg] if isinstance(b, PeriodBatch)])
    np.testing.assert_allclose(before[-1], [5, 0, 0], atol=0.05)  # the message comes where line 1 ends
    dwell = out["line"] == 4
    assert dwell.sum() == 250 and np.all(out["feed_mm_s"][dwell] == 0)
    np.testing.assert_allclose(out["pos_mm"][dwell], [[10, 0, 0]] * 250, atol=1e-9)
    last = [b for b in items[:k_stop] if isinstance(b, PeriodBatch)][-1]
    np.testing.assert_allclose(last.pos_mm[-1], [10, 5, 0], atol=1e-9)
    assert kinds[-1] == "ProgramEnd"


@pytest.mark.parametrize("stop", [Dwell(5, 0.1), Stop(5, False)])
def test_a_blended_corner_before_an_event_does_not_trim_the_move_after_a_stop(stop):
    """Two blended rapids, an event (held at the second one's end, so its corner was built
    ahead), then a dwell or a stop: the move after it starts where the machine stands and
    moves no axis faster than its limit (a stale corner trim cut 0.12 mm off its start)."""
    ents = [Rapid(1, (0, 0, 10), (5, 5, 10), G64), Rapid(2, (5, 5, 10), (5, 5, 3.8), G64),
            Spindle(3, 1000.0, "cw"), Message(4, "at depth"), stop,
            Line(6, (5, 5, 3.8), (5, 5, 1.5), 10.0, G64), Line(7, (5, 5, 1.5), (55, 5, 1.5), 40.0, G64)]
    _, out, start = run(ents)
    assert_within_limits(out["pos_mm"], start)
    after = out["line"] == 6
    first = np.flatnonzero(after)[0]
    np.testing.assert_allclose(out["pos_mm"][first - 1], [5, 5, 3.8], atol=1e-9)
    assert np.abs(out["pos_mm"][first] - out["pos_mm"][first - 1]).max() <= 10.0 * T


def test_feed_override_and_live_change():
    line = [Line(1, (0, 0, 0), (100, 0, 0), 50.0)]
    _, out, _ = run(line, feed_override=0.5)
    assert out["feed_mm_s"].max() == pytest.approx(25.0, rel=1e-9)
    planner = FeedPlanner(FINE, start_mm=(0, 0, 0), batch_periods=200)
    pos = []
    for item in planner.run(line):
        pos.append(item.pos_mm)
        if len(pos) == 3:  # 0.6 s in: cruising at 50 mm/s
            planner.set_feed_override(0.2)
    pos = np.concatenate(pos)
    v, _ = finite_differences(pos, np.zeros(3))
    assert np.abs(v[550:590, 0] - 50).max() < 1e-6  # before the change
    assert np.abs(v[1000:1100, 0] - 10).max() < 1e-6  # braked to 20 %
    assert_within_limits(pos, np.zeros(3))
    np.testing.assert_allclose(pos[-1], [100, 0, 0], atol=1e-9)


def test_streams_with_bounded_look_ahead():
    """A 30,000-block program: the first batch comes out long before the last block is read."""
    read = []

    def blocks():
        for i in range(30000):
            x0, x1 = 0.1 * i, 0.1 * (i + 1)
            read.append(i)
            yield Line(i + 1, (x0, 0.01 * np.sin(x0), 0), (x1, 0.01 * np.sin(x1), 0), 30.0, G64)

    gen = plan_periods(blocks(), BASE, start_mm=(0, 0, 0))
    first = next(gen)
    assert isinstance(first, PeriodBatch) and len(read) < 5000
    total = len(first) + sum(len(b) for b in gen)
    assert total * T == pytest.approx(3000 / 30, rel=0.01)


def test_start_mismatch_is_an_error():
    with pytest.raises(ValueError, match="stands at"):
        list(plan_periods([Line(1, (1, 0, 0), (2, 0, 0), 10.0)], BASE, start_mm=(0, 0, 0)))


@pytest.mark.parametrize("name", ["line", "g2", "nurbs", "blended_corner", "tiny_rapid_blend",
                                  "reversal_at_blend"])
def test_scurve_mode_limits_jerk(name):
    """S-curve mode: finite-difference jerk within J (plus float noise), accel within A."""
    cfg = dataclasses.replace(FINE, accel_mode="scurve")
    j_max = np.array([a.max_jerk_mm_s3 for a in cfg.axes])
    ents = {"line": [Line(1, (0, 0, 0), (30, 10, 0), 60.0)],
            "g2": [Arc(1, (10, 0, 0), (10, 0, 0), (0, 0, 0), "XY", False, 50.0)],
            "nurbs": [quarter_nurbs(50.0)],
            "blended_corner": [Line(1, (0, 0, 0), (10, 0, 0), 40.0, PathControl(blend_tol_mm=0.2)),
                               Line(2, (10, 0, 0), (20, 10, 0), 40.0, PathControl(blend_tol_mm=0.2))],
            # g6_farfalla's start: a 90 degree rapid corner under G64 P0.01, a blend of radius
            # 0.024 mm crossed between two stops (its curvature step is too high to cross)
            "tiny_rapid_blend": [Rapid(1, (0, 0, 0), (0, 0, 10), G64), Rapid(2, (0, 0, 10), (54.5, 52.1, 10), G64)],
            # accelerating out of one G64 P0.1 blend and braking straight into the next: the
            # planned acceleration reverses from +A/2 to -A/2 (g1_lhchips4, source line 290)
            "reversal_at_blend": [Line(i + 1, p, q, 100.0, PathControl(blend_tol_mm=0.1)) for i, (p, q) in
                                  enumerate(zip([(0, 0, 0), (5, 0, 0), (6, 0.2, 0)],
                                                [(5, 0, 0), (6, 0.2, 0), (11, 0.2, 0)]))],
            }[name]
    _, out, start = run(ents, cfg=cfg)
    v, a = finite_differences(out["pos_mm"], start)
    jerk = np.diff(a, axis=0, prepend=np.zeros((1, 3))) / T
    assert np.all(np.abs(a) <= A + 1e-3)
    assert np.all(np.abs(jerk) <= j_max * 1.01), np.abs(jerk).max(0)
    np.testing.assert_allclose(out["pos_mm"][-1], ents[-1].end, atol=1e-9)
    _, trap, _ = run(ents)
    assert len(out["pos_mm"]) > len(trap["pos_mm"])  # jerk limiting costs time


def test_corner_blend_next_to_an_arc_stays_within_p():
    """Line into a non-tangent arc under G64 P0.05: the path is rounded (no stop) and stays
    within P (+ delta for the chords) of the programmed line and circle."""
    p = PathControl(blend_tol_mm=0.05)
    ents = [Line(1, (0, 0, 0), (10, 0, 0), 40.0, p), Arc(2, (10, 0, 0), (10, 10, 0), (15, 5, 0), "XY", True, 40.0, path=p)]
    _, out, start = run(ents)
    pos = out["pos_mm"]
    on_line = pos[:, 0] <= 10 - 1e-9
    dev_line = np.abs(pos[on_line, 1])
    dev_arc = np.abs(np.linalg.norm(pos[~on_line, :2] - [15, 5], axis=1) - np.hypot(5, 5))
    assert max(dev_line.max(), dev_arc.max()) <= 0.05 + BASE.chord_tol_mm
    near = np.linalg.norm(pos - [10, 0, 0], axis=1) < 0.2
    assert out["feed_mm_s"][near].min() > 5.0  # a sharp 45 deg corner would need < 1 mm/s
    assert_within_limits(pos, start)


# An inch G18 arc that meets the next straight at 16 deg (g1_stellabee1.ngc, source line 19946):
# the arc's end and its corner blend met with a tangent step of 4e-6 (the arc's spiral term),
# which halved the axis limits there while the speed stayed at the full-limit curvature cap.
ZX_ARC_LINE = """G20 G18 G64 G90 G94
G0 X1.2260 Y4.1380 Z-0.2183
G1 X1.2280 Z-0.2330 F999
X1.2300 Z-0.2343
X1.2340 Z-0.2285
G2 X1.2400 Z-0.1585 I-0.4266 K0.0718
G1 X1.2440 Z-0.1448
G2 X1.2520 Z-0.1389 I-0.0001 K0.0086
M2
"""


def _without_lead_rapid(entities):
    ents = list(entities)
    assert isinstance(ents[0], Rapid)
    return ents[1:], ents[0].end


def test_zx_arc_to_line_junction_stays_within_limits():
    ents, start = _without_lead_rapid(parse_text(ZX_ARC_LINE).entities)
    _, out, start = run(ents, start_mm=start)
    assert_within_limits(out["pos_mm"], start)
    np.testing.assert_allclose(out["pos_mm"][-1], np.array([1.2520, 4.1380, -0.1389]) * 25.4, atol=1e-9)


def test_stellabee_excerpt_stays_within_limits():
    """300 blocks of the G18 raster relief around source line 19946, entered from where the
    program stands before them."""
    from conftest import require_corpus
    lines = (require_corpus() / "g1_stellabee1.ngc").read_text().splitlines()
    first, last = 19796, 20096
    before = list(iter_entities(lines[:first - 1]))
    here = next(e for e in reversed(before) if hasattr(e, "end")).end
    text = ["G20 G17 G40", "G80 G90 G94", "G64 G18 F999",
            "G0 X%.6f Y%.6f Z%.6f" % tuple(np.divide(here, 25.4)), "G1"] + lines[first - 1:last]
    ents, start = _without_lead_rapid(e for e in iter_entities(text) if isinstance(e, MOTION_TYPES))
    _, out, start = run(ents, start_mm=start)
    assert_within_limits(out["pos_mm"], start)
    assert out["line"].min() == 6 and out["line"].max() == 5 + last - first + 1


def test_short_step_over_between_nurbs_accelerates_in_between():
    """A 0.2 mm G01 step-over between two NURBS passes (unblended 90 degree corners at both
    ends under G64 P0) is crossed accelerate-then-brake, not at the
    corners' crawl: its time lies between the triangle bounds at the full and at the
    halved (CORNER_SHARE) axis acceleration, from finite differences of the positions."""
    L, F = 0.2, 50.0
    knots = np.array([0, 0, 0, 1, 1, 1.0])
    p0 = PathControl(blend_tol_mm=0.0)
    out_pass = Nurbs(1, 2, knots, np.ones(3), np.array([[0, 0, 0], [5, 0, 0.5], [10, 0, 0.0]]), F, p0)
    back = Nurbs(3, 2, knots, np.ones(3), np.array([[10, L, 0], [5, L, 0.5], [0, L, 0.0]]), F, p0)
    _, out, start = run([out_pass, Line(2, (10, 0, 0), (10, L, 0), F, p0), back])
    on_line = out["line"] == 2
    t_line = on_line.sum() * T
    a = A[1] * ACCEL_USE
    assert 2 * np.sqrt(L / A[1]) <= t_line <= 2 * np.sqrt(L / (0.5 * a)) + 3 * T, t_line
    v, _ = finite_differences(out["pos_mm"], start)
    assert np.abs(v[on_line, 1]).max() >= 0.9 * np.sqrt(0.5 * a * L)  # peak of the half-accel triangle
    # accelerating away from a corner's cap and braking into the next is reported as such
    assert np.mean(out["limit"][on_line] == LIMIT_ACCEL) >= 0.9
    assert_within_limits(out["pos_mm"], start)


def test_nurbs_brakes_into_an_unblended_corner_at_the_end():
    """A NURBS pass ending in an unblended 90 degree corner (G64 P0) brakes within the last fraction of
    a millimetre, not over its last table interval: its time from standstill lies between
    accelerate-cruise-brake at the full axis limit and with braking at the halved one
    (CORNER_SHARE), cruise from the arc length by scipy's quadrature of |C'(u)|."""
    from scipy.integrate import quad

    F = 15.0
    pts = np.array([[0, 0, 0], [5, 0, 0.5], [10, 0, 0.0]])
    p0 = PathControl(blend_tol_mm=0.0)
    e = Nurbs(1, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.ones(3), pts, F, p0)
    length = quad(lambda u: np.linalg.norm(2 * ((1 - u) * (pts[1] - pts[0]) + u * (pts[2] - pts[1]))), 0, 1)[0]
    _, out, start = run([e, Line(2, (10, 0, 0), (10, 5, 0), F, p0)])
    t_curve = (out["line"] == 1).sum() * T
    a = A[0] * ACCEL_USE
    assert length / F + F / A[0] - 2 * T <= t_curve <= length / F + F / (2 * a) + F / a + 4 * T, t_curve
    assert_within_limits(out["pos_mm"], start)


def test_a_motion_that_does_not_start_where_the_machine_stands_is_refused_with_its_code_and_line():
    from ipo.errors import START, IpoError
    with pytest.raises(IpoError) as info:
        list(plan_periods([Line(3, (1.0, 0.0, 0.0), (2.0, 0.0, 0.0), 10.0)], default_config()))
    assert (info.value.code, info.value.line) == (START, 3)
    assert str(info.value) == "line 3: motion starts at [1.0, 0.0, 0.0] but the machine stands at [0.0, 0.0, 0.0]"


def test_a_builds_driver_changes_leave_the_intakes_drivers_alone():
    from ipo.feed.driver_changes import DriverChanges
    base = {0: "curve 0", 1: "curve 1"}
    ch = DriverChanges(base, next_index=5, make_drivers=lambda es: [f"driver of {e}" for e in es])
    ch[0] = "curve 0 trimmed"
    del ch[1]
    assert ch.add(["blend a"]) == (range(5, 6), ["driver of blend a"])
    assert ch.add(["blend b"]) == (range(6, 7), ["driver of blend b"])
    assert ch[0] == "curve 0 trimmed" and ch[6] == "driver of blend b"
    with pytest.raises(KeyError):
        ch[1]
    with pytest.raises(KeyError):
        del ch[9]
    assert base == {0: "curve 0", 1: "curve 1"}
    assert ch.changed == {0: "curve 0 trimmed", 1: None, 5: "driver of blend a", 6: "driver of blend b"}
