"""S-curve (jerk-limited) mode: the window's jerk-limited profile, committed and put out by period.

Per look-ahead window: the acceleration-limited profile under every cap (ipo.feed.lookahead,
the whole axis budget: the split between tangential and centripetal shares is made by
ipo.feed.jerk_plan only where the path curves) -> anchors and jerk-limited segments between
them (ipo.feed.jerk_plan) -> the segments up to the last anchor from which the machine can
still stop before the window's end with its jerk limit are committed -> period ends on that
time line (SegmentLaw) -> ipo.feed.emission. A stop (G61, an unblended corner, the program's
end) is an anchor at speed 0 and the period grid lands exactly on it, as in trapezoid mode. A
feed override change takes effect at the next anchor: the rest is planned again from there.

The rest of the committed window's plan, from the committed anchor to its stop at the window's
end, is kept with the window (Window.tail): jerk_plan's passes and checks are a search, not a
proof, and with more path read they can miss a braking from the committed speed that the last
plan found (a straight into a tight curve near v^2 kappa = A whose look-ahead profile falls
away right after the anchor: tests/ipo/feed/test_scurve_windows.py). A window whose plan finds
none takes the next gap of that rest instead, once it passes every check of jerk_plan's step 4
against today's caps, and plans again from the anchor that ends it; at worst the machine stops
where the last window ended, the stop that plan had anyway.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from ipo.contracts import LIMIT_ACCEL
from ipo.errors import SCURVE, IpoError
from ipo.feed import jerk_checks, jerk_plan, jerk_profile
from ipo.feed.jerk_anchors import curved_intervals
from ipo.feed import lookahead as la
from ipo.feed.jerk_profile import transition_distance

_STANDSTILL_X = 1e-12
_STANDSTILL_V = 1e-6
# a straight shorter than this between curved pieces is planned as part of the curve (with
# its share of the jerk) rather than as a segment of its own with zero acceleration at both
# ends (a polyline's micron remnants between blends)
STRAIGHT_MIN_MM = 0.5
# the shares of the axis jerk and acceleration a curved gap is taken to keep when judging how far
# before a window's end its plan still depends on what follows (a longer reach commits less). On
# a curve near v^2 kappa = A the tangential share is small: with the whole acceleration,
# g1_lhchips4's fitted chains (ipo.feed.blends.chain_fit) committed 115 mm/s where braking to a
# curve 10 mm on, under the curvature's share of the axes, could not start in time (line 4331:
# no jerk-limited profile); half of it plans the same cycle there
REACH_JERK_SHARE = 0.5
REACH_ACC_SHARE = 0.5


class Segments(NamedTuple):
    """Anchors (sample indices) with their speeds, and per gap the peak speed and limits."""

    idx: np.ndarray
    w: np.ndarray
    vp: np.ndarray
    ag: np.ndarray
    jg: np.ndarray


def plan_window(s, t, kv, x_acc, a_axis, j_axis, v0: float, period_s: float) -> Segments | None:
    """The jerk-limited segments of a window that ends at a stop (jerk_plan.plan), None where
    the plan did not converge."""
    idx, w, vp, ag, jg, ok = jerk_plan.plan(jerk_plan.Geometry(s, t, kv), x_acc,
                                            jerk_plan.AxisLimits(a_axis, j_axis, period_s), v0, 0.0, STRAIGHT_MIN_MM)
    return Segments(idx, w, vp, ag, jg) if ok else None


def tail_gap(tail: Segments | None, geo: jerk_plan.Geometry, cap: np.ndarray, lim: jerk_plan.AxisLimits,
             line: int) -> Segments:
    """The last plan's rest (Window.tail), to be committed up to its next anchor where this
    window's plan found none: its first gap must pass jerk_plan's step-4 checks against the caps
    as they are now (an override may have lowered them, a corner where the windows join too)."""
    if tail is not None and len(tail.idx) > 1:
        lo, hi = int(tail.idx[0]), int(tail.idx[1])
        if hi == lo:  # a piece joint's two samples: no path between them to check (as in jerk_plan)
            return tail
        curved = curved_intervals(geo.s, geo.t, geo.kv, STRAIGHT_MIN_MM)
        gap = jerk_checks.Segment(tail.w[0], tail.vp[0], tail.w[1], tail.ag[0], tail.jg[0])
        worst, over = jerk_checks.check(geo, jerk_checks.rates(geo.s, geo.kv), cap, lo, hi, gap, lim,
                                        bool(curved[lo]), True)
        if worst < 0 and over == 0:
            return tail
    raise IpoError(SCURVE, "no jerk-limited profile within the axis limits was found here", line)


def stop_reach_mm(v_top: float, a_axis: np.ndarray, j_axis: np.ndarray) -> float:
    """Path length in which the machine stops from v_top with the smallest path limits a curve
    leaves it: how far before a window's end its plan still depends on what follows."""
    return transition_distance(v_top, 0.0, REACH_ACC_SHARE * float(a_axis.min()),
                               REACH_JERK_SHARE * float(j_axis.min())) + 1e-3


def period_limits(sv: np.ndarray, s_prev: float, period_s: float, s: np.ndarray, cap: np.ndarray,
                  reason: np.ndarray) -> np.ndarray:
    """The LIMIT_* code of each period: the cap of its sample interval where the period runs
    within 1 % of it, else the acceleration (the jerk-limited speed changes)."""
    k = np.clip(np.searchsorted(s, sv, side="right") - 1, 0, len(s) - 1)
    v = np.diff(sv, prepend=s_prev) / period_s
    at_cap = (cap[k] > 0) & (v * v >= 0.98 * cap[k])
    return np.where(at_cap, reason[k], LIMIT_ACCEL).astype(np.int8)


class SegmentLaw:
    """Jerk-limited segments as a time law for the output side (emission.PeriodOutput.emit_law):
    anchors at window samples seg.idx (the first at sample 0), times from the first anchor."""

    def __init__(self, seg: Segments, s: np.ndarray, cap: np.ndarray, reason: np.ndarray, period_s: float):
        self.seg, self.s, self.cap, self.reason, self.T = seg, s, cap, reason, period_s
        dur = jerk_profile.durations(s, seg.idx, seg.w, seg.vp, seg.ag, seg.jg)
        self.t_start = np.concatenate([[0.0], np.cumsum(dur)])
        self.duration = float(self.t_start[-1])
        self.last = int(seg.idx[-1])
        self.s_end = float(s[self.last])

    def at(self, times: np.ndarray, s_prev: float):
        seg = self.seg
        sv, gap = jerk_profile.arc_lengths_at(times, self.s, seg.idx, seg.w, seg.vp, seg.ag, seg.jg, self.t_start)
        return sv, period_limits(sv, s_prev, self.T, self.s, self.cap, self.reason), gap

    def cut_after(self, g: int) -> tuple[int, float]:
        """A replan starts at the anchor that ends gap g."""
        return int(self.seg.idx[g + 1]), float(self.t_start[g + 1])


def run(planner, win, output, final: bool) -> Iterator:
    """The planner's window in S-curve mode: plan, commit, emit (stop by stop, so that the
    period grid lands on each); again while the override changed, everything must go out, or the
    window's plan found nothing and the last plan's next gap went out instead (tail_gap)."""
    while win.samples is not None and len(win.samples) > 1:
        planner._override_changed = False
        smp = win.samples
        cap, reason = planner._soft_caps()
        x = la.plan(smp.s, smp.t, smp.kv, cap, planner.a_max, planner._ascale(len(smp), cap), win.x0_v2, 0.0)
        x[x < _STANDSTILL_X] = 0.0
        seg = plan_window(smp.s, smp.t, smp.kv, x, planner.a_max, planner.j_axis, float(np.sqrt(win.x0_v2)),
                          planner.T)
        fallback = seg is None
        if fallback:
            line = int(win.pieces.line[smp.piece[0] - win.piece_base])
            seg = tail_gap(win.tail, jerk_plan.Geometry(smp.s, smp.t, smp.kv), cap,
                           jerk_plan.AxisLimits(planner.a_max, planner.j_axis, planner.T), line)
            commit = 1
        elif final:
            commit = len(seg.idx) - 1
        else:
            reach = stop_reach_mm(float(np.sqrt(cap.max())), planner.a_max, planner.j_axis)
            c = int(np.searchsorted(smp.s, win.s_end_mm - reach, side="right")) - 1
            commit = int(np.searchsorted(seg.idx, c, side="right")) - 1
            if commit < 1:
                return
        ends = [g for g in range(1, commit) if seg.w[g] <= _STANDSTILL_V] + [commit]
        done = 0
        for e in ends:
            base = int(seg.idx[done])
            part = Segments(seg.idx[done:e + 1] - base, seg.w[done:e + 1], seg.vp[done:e], seg.ag[done:e],
                            seg.jg[done:e])
            law = SegmentLaw(part, win.samples.s, cap[base:], reason[base:], planner.T)
            k_stop, used = yield from output.emit_law(law, win, stop=bool(part.w[-1] <= _STANDSTILL_V),
                                                      replan=lambda: planner._override_changed)
            win.take_events(used)
            win.x0_v2 = float(part.w[int(np.searchsorted(part.idx, k_stop))]) ** 2
            win.drop(k_stop)
            if planner._override_changed:
                break
            done = e
        win.tail = None if planner._override_changed else Segments(
            seg.idx[commit:] - seg.idx[commit], seg.w[commit:], seg.vp[commit:], seg.ag[commit:], seg.jg[commit:])
        if not (final or fallback or planner._override_changed):
            return
    if final and win.samples is not None and len(win.samples) <= 1:
        win.reset()
