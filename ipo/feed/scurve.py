"""S-curve (jerk-limited) mode: the window's jerk-limited profile, committed and put out by period.

Per look-ahead window: the acceleration-limited profile under every cap (ipo.feed.lookahead,
the whole axis budget: the split between tangential and centripetal shares is made by
ipo.feed.jerk_plan only where the path curves) -> anchors and jerk-limited segments between
them (ipo.feed.jerk_plan) -> the segments up to the last anchor from which the machine can
still stop before the window's end with its jerk limit are committed -> period ends on that
time line -> ipo.feed.emission. A stop (G61, an unblended corner, the program's end) is an
anchor at speed 0 and the period grid lands exactly on it, as in trapezoid mode. A feed
override change takes effect at the next anchor: the rest is planned again from there.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from ipo.contracts import LIMIT_ACCEL
from ipo.errors import SCURVE, IpoError
from ipo.feed import jerk_plan
from ipo.feed import lookahead as la
from ipo.feed.jerk_profile import TANGENTIAL_JERK_SHARE, transition_distance

_STANDSTILL_X = 1e-12
_STANDSTILL_V = 1e-6
# a straight shorter than this between curved pieces is planned as part of the curve (with
# its share of the jerk) rather than as a segment of its own with zero acceleration at both
# ends (a polyline's micron remnants between blends)
STRAIGHT_MIN_MM = 0.5


class Segments(NamedTuple):
    """Anchors (sample indices) with their speeds, and per gap the peak speed and limits."""

    idx: np.ndarray
    w: np.ndarray
    vp: np.ndarray
    ag: np.ndarray
    jg: np.ndarray

    def head(self, g: int) -> "Segments":
        """The first g gaps (anchors 0..g)."""
        return Segments(self.idx[:g + 1], self.w[:g + 1], self.vp[:g], self.ag[:g], self.jg[:g])


def plan_window(s, t, kv, x_acc, a_axis, j_axis, v0: float, line: int) -> Segments:
    """The jerk-limited segments of a window that ends at a stop (jerk_plan.plan)."""
    idx, w, vp, ag, jg, ok = jerk_plan.plan(s, t, kv, x_acc, a_axis, j_axis, v0, 0.0, STRAIGHT_MIN_MM)
    if not ok:
        raise IpoError(SCURVE, "no jerk-limited profile within the axis limits was found here", line)
    return Segments(idx, w, vp, ag, jg)


def stop_reach_mm(v_top: float, a_axis: np.ndarray, j_axis: np.ndarray) -> float:
    """Path length in which the machine stops from v_top with the smallest path limits a curve
    leaves it: how far before a window's end its plan still depends on what follows."""
    return transition_distance(v_top, 0.0, float(a_axis.min()), TANGENTIAL_JERK_SHARE * float(j_axis.min())) + 1e-3


def period_limits(sv: np.ndarray, s_prev: float, period_s: float, s: np.ndarray, cap: np.ndarray,
                  reason: np.ndarray) -> np.ndarray:
    """The LIMIT_* code of each period: the cap of its sample interval where the period runs
    within 1 % of it, else the acceleration (the jerk-limited speed changes)."""
    k = np.clip(np.searchsorted(s, sv, side="right") - 1, 0, len(s) - 1)
    v = np.diff(sv, prepend=s_prev) / period_s
    at_cap = (cap[k] > 0) & (v * v >= 0.98 * cap[k])
    return np.where(at_cap, reason[k], LIMIT_ACCEL).astype(np.int8)


def run(planner, final: bool) -> Iterator:
    """The planner's window in S-curve mode: plan, commit, emit; again while the override
    changed or everything must go out (final)."""
    win = planner._win
    while win.samples is not None and len(win.samples) > 1:
        planner._override_changed = False
        smp = win.samples
        cap, reason = planner._soft_caps()
        x = la.plan(smp.s, smp.t, smp.kv, cap, planner.a_max, planner._ascale(len(smp), cap), win.x0_v2, 0.0)
        x[x < _STANDSTILL_X] = 0.0
        line = int(win.pieces.line[smp.piece[0] - win.piece_base])
        seg = plan_window(smp.s, smp.t, smp.kv, x, planner.a_max, planner._j_axis, float(np.sqrt(win.x0_v2)), line)
        m = len(seg.idx)
        if final:
            commit = m - 1
        else:
            reach = stop_reach_mm(float(np.sqrt(cap.max())), planner.a_max, planner._j_axis)
            c = int(np.searchsorted(smp.s, win.s_end_mm - reach, side="right")) - 1
            commit = int(np.searchsorted(seg.idx, c, side="right")) - 1
            if commit < 1:
                return
        done = yield from _emit(planner, seg.head(commit), cap, reason, final=final and commit == m - 1)
        win.x0_v2 = float(seg.w[done]) ** 2
        win.drop(int(seg.idx[done]))
        if not (final or planner._override_changed):
            return
    if final and win.samples is not None and len(win.samples) <= 1:
        win.reset()


def _emit(planner, seg: Segments, cap: np.ndarray, reason: np.ndarray, *, final: bool):
    """Periods over the committed gaps; returns the anchor the window now starts at (the last
    one, or the next one after an override change)."""
    T = planner.T
    s = planner._win.samples.s
    dur = jerk_plan.durations(s, seg.idx, seg.w, seg.vp, seg.ag, seg.jg)
    t_start = np.concatenate([[0.0], np.cumsum(dur)])
    G = len(dur)
    ends = [g for g in range(1, G) if seg.w[g] <= _STANDSTILL_V] + [G]
    g0 = 0
    for e in ends:
        stop = seg.w[e] <= _STANDSTILL_V and (e < G or final)
        t_end = t_start[e]
        t_next = t_start[g0] + planner._phase
        while True:
            fit = int(np.floor((t_end - t_next) / T + 1e-9)) + 1 if t_next <= t_end + 1e-12 else 0
            n = min(fit, planner.batch_periods)
            times = t_next + T * np.arange(n)
            last = times[-1] if n else t_next - T
            exact = stop and n == fit and t_end - last > 1e-12
            if exact:
                times = np.append(times, t_end)  # the stop falls exactly on a period's end
            if len(times) == 0:
                break
            sv, gap = jerk_plan.arc_lengths_at(np.minimum(times, t_end), s, seg.idx, seg.w, seg.vp, seg.ag, seg.jg,
                                               t_start)
            if exact:
                sv[-1] = s[seg.idx[e]]
            limits = period_limits(sv, planner._s_last, T, s, cap, reason)
            yield from planner._out(sv, planner._s_last, limits)
            planner._s_last = float(sv[-1])
            t_next = times[-1] + T
            if n == fit:
                break
            if planner._override_changed:
                # finish the gap under way on the old plan; the rest is planned again from its end
                g_stop = int(gap[-1]) + 1
                more = int(np.floor((t_start[g_stop] - t_next) / T + 1e-9)) + 1 if t_next <= t_start[g_stop] else 0
                if more:
                    times = t_next + T * np.arange(more)
                    sv, _ = jerk_plan.arc_lengths_at(times, s, seg.idx, seg.w, seg.vp, seg.ag, seg.jg, t_start)
                    yield from planner._out(sv, planner._s_last, period_limits(sv, planner._s_last, T, s, cap, reason))
                    planner._s_last = float(sv[-1])
                    t_next = times[-1] + T
                planner._phase = t_next - t_start[g_stop]
                return g_stop
        planner._phase = T if stop else t_next - t_end
        g0 = e
    return G
