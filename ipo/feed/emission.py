"""The feed stage's output side: a planned profile -> periods on the grid -> PeriodBatch.

The planner (ipo.feed.planner) plans v^2 over the window's samples and refines it
(ipo.feed.lookahead.refine) into a `Profile`; this module puts it on the period grid
(where along the path each period ends, lookahead.sample_times and positions_at), turns
those arc lengths into machine positions (lines, arcs and blends evaluated exactly by arc
length, a NURBS walked by its stepper), quantises them to BLU increments
(ipo.interp.reference_word.quantise) and cuts the batches where events sit. S-curve mode
hands it its jerk-limited segments as another time law (ipo.feed.scurve.SegmentLaw).

It owns the state that belongs to the machine rather than to the plan: where the machine
stands (in mm and in BLU) and the period grid's phase. It reads the planner's window (ipo.feed.window: pieces, where
they start, their NURBS drivers, pending events) and changes nothing in it: it hands back
where it stopped and how many events it put out.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.config import MachineConfig
from ipo.feed.nurbs_driver import BlendCurve, NurbsDriver
from ipo.contracts import LIMIT_ACCEL, LIMIT_DWELL, PeriodBatch
from ipo.feed.lookahead import np_max, positions_at, sample_times
from ipo.feed.analytic import points_along
from ipo.feed.blends.compiled import bezier_points_runs
from ipo.feed.pieces import KIND_BLEND, KIND_NURBS, Pieces
from ipo.feed.sampling import GAUSS_W, GAUSS_X
from ipo.feed.window import Window
from ipo.interp.reference_word import quantise


@njit(cache=True, error_model="numpy")
def period_reasons(xs, src, cap, reason, centripetal, curvature_code, accel_code):
    """Limit reason of each refined interval (xs = v^2 at the refined points, src = the
    sample each refined point lies after).

    A period is limited by a cap where both ends of its interval run at their caps, or one
    does and the speed stays level; else it is accelerating or braking (away from a
    corner's cap, into a stop: accel_code), unless `centripetal` (one flag per sample
    interval, centripetal_binds) says an axis at its limit there owes most of it to the
    curvature: below a curvature peak's cap, where one path acceleration cannot meet the
    axis limits at both ends of an interval at the cap, that is `curvature_code`."""
    n = xs.shape[0] - 1
    out = np.empty(n, np.int8)
    for i in range(n):
        k0 = src[i]
        k1 = k0 + 1
        r0 = xs[i] >= cap[k0] * 0.995 and cap[k0] > 0
        r1 = xs[i + 1] >= cap[k1] * 0.995 and cap[k1] > 0
        level = abs(xs[i + 1] - xs[i]) <= 0.01 * np_max(xs[i], xs[i + 1])
        if r0 and (r1 or level):
            out[i] = reason[k0]
        elif r1 and level:
            out[i] = reason[k1]
        else:
            out[i] = curvature_code if centripetal[min(k0, centripetal.shape[0] - 1)] else accel_code
    return out


@njit(cache=True)
def centripetal_binds(s, t, kv, x, a_max, ascale):
    """Per sample interval: at one of its ends some axis runs within 1 % of its limit with
    the constant s'' of the interval, and the centripetal share kv_i x is most of it."""
    n = s.shape[0] - 1
    out = np.zeros(n, np.bool_)
    for k in range(n):
        ds = s[k + 1] - s[k]
        if not ds > 0:
            continue
        sdd = (x[k + 1] - x[k]) / (2.0 * ds)
        for end in range(2):
            xe = x[k + end]
            for a in range(3):
                cen = kv[k + end, a] * xe
                acc = t[k + end, a] * sdd + cen
                if abs(acc) >= 0.99 * ascale[k] * a_max[a] and abs(cen) >= 0.5 * abs(acc):
                    out[k] = True
    return out


class Profile(NamedTuple):
    """The plan over the window's samples 0..c, refined: arc length s and v^2 at the refined
    points, the sample each lies after (src), the limit reason of each refined interval,
    and the samples' own arc lengths (where a replan may start)."""

    s: np.ndarray
    v2: np.ndarray
    src: np.ndarray
    reason: np.ndarray
    s_samples: np.ndarray


class RefinedLaw:
    """A refined Profile as a time law for PeriodOutput.emit_law: constant path acceleration
    between its points (lookahead.sample_times, positions_at)."""

    def __init__(self, prof: Profile):
        self.prof = prof
        self.tc = sample_times(prof.s, prof.v2)
        self.duration = float(self.tc[-1])
        self.last = len(prof.s_samples) - 1  # the window sample it ends on
        self.s_end = float(prof.s[-1])

    def at(self, times: np.ndarray, s_prev: float):
        """Arc length at each time, the limit reason of each period, and the refined interval
        each falls in."""
        sv, k = positions_at(times, self.prof.s, self.prof.v2, self.tc)
        return sv, self.prof.reason[k], k

    def cut_after(self, k: int) -> tuple[int, float]:
        """Where a replan may start after refined interval k: the next window sample, and when."""
        k_stop = min(int(self.prof.src[k]) + 1, self.last)
        r = int(np.searchsorted(self.prof.s, self.prof.s_samples[k_stop], side="left"))
        return k_stop, float(self.tc[r])


class PeriodOutput:
    """Machine position and period grid state; see the module docstring."""

    def __init__(self, config: MachineConfig, *, start_mm, batch_periods: int):
        self.T = config.period_s
        self.blu_mm = config.blu_mm
        self.batch_periods = batch_periods
        self.pos = np.array(start_mm, dtype=float)
        self.blu = np.rint(self.pos / config.blu_mm).astype(np.int64)
        self._phase = self.T  # time from the first held sample to the next period end
        self._s_last = 0.0  # planned arc length at the end of the last period

    def emit(self, prof: Profile, window: Window, *, stop: bool, replan: Callable[[], bool]):
        """Periods along a refined profile (RefinedLaw); see emit_law."""
        return (yield from self.emit_law(RefinedLaw(prof), window, stop=stop, replan=replan))

    def emit_law(self, law, window: Window, *, stop: bool, replan: Callable[[], bool]):
        """Periods along a time law up to its end (law.duration; RefinedLaw, or S-curve mode's
        segments, ipo.feed.scurve.SegmentLaw), where the machine stops if `stop`. When
        `replan()` turns true (a feed override changed) it runs on to where the law allows a
        new plan to start (law.cut_after) and ends there. The generator returns (k, n): the
        window sample it ended on (the next plan starts there) and how many of the window's
        events it put out."""
        t_next, s_prev, k_stop, used = self._phase, self._s_last, law.last, 0
        t_stop = law.duration
        while True:
            fit = int(np.floor((law.duration - t_next) / self.T + 1e-9)) + 1 if t_next <= law.duration + 1e-12 else 0
            n = min(fit, self.batch_periods)
            times = t_next + self.T * np.arange(n)
            last = times[-1] if n else t_next - self.T
            exact_stop = stop and n == fit and law.duration - last > 1e-12
            if exact_stop:
                times = np.append(times, law.duration)  # the stop is reached exactly at a period's end
            if len(times) == 0:
                break
            sv, reason, idx = law.at(np.minimum(times, law.duration), s_prev)
            if exact_stop:
                sv[-1] = law.s_end
            used = yield from self._batch(sv, s_prev, reason, window, used)
            s_prev = self._s_last = float(sv[-1])
            t_next = times[-1] + self.T
            if n == fit:
                break
            if replan():
                k_stop, t_stop = law.cut_after(int(idx[-1]))
                more = int(np.floor((t_stop - t_next) / self.T + 1e-9)) + 1 if t_next <= t_stop else 0
                if more:
                    times = t_next + self.T * np.arange(more)
                    sv, reason, _ = law.at(times, s_prev)
                    used = yield from self._batch(sv, s_prev, reason, window, used)
                    s_prev = self._s_last = float(sv[-1])
                    t_next = times[-1] + self.T
                break
        self._phase = t_next - (t_stop if k_stop < law.last else law.duration)
        if stop and k_stop == law.last:
            self._phase = self.T
        return k_stop, used

    def _batch(self, sv: np.ndarray, s_prev: float, limit: np.ndarray, window: Window, used: int):
        """Points at arc lengths sv, quantised; split where events sit (the window's from
        index `used` on). Returns the index after the last event put out."""
        pieces, pstart, nurbs, events = window.pieces, window.pstart, window.drivers, window.events
        loc, pos = points_along(pieces.geometry, pstart, pieces.length, sv)
        mask = pieces.kind[loc] == KIND_NURBS
        if mask.any():
            _nurbs_points(pos, loc, sv, s_prev, mask, pieces, pstart, nurbs)
        blend = np.nonzero(pieces.kind[loc] == KIND_BLEND)[0]
        if len(blend):
            pos[blend] = _blend_points(loc[blend], sv[blend], pieces, pstart, nurbs)
        feed = np.diff(sv, prepend=s_prev) / self.T
        line = pieces.line[loc]
        inc, end = quantise(pos, self.blu_mm, self.blu)
        qpos = (self.blu + np.cumsum(inc, axis=0)) * self.blu_mm
        self.blu = end
        self.pos = pos[-1].copy()
        cut = 0
        while used < len(events) and events[used][0] <= sv[-1] + 1e-9:
            s_ev, ev = events[used]
            used += 1
            j = max(int(np.searchsorted(sv, s_ev + 1e-9, side="right")), cut)
            if j > cut:
                yield PeriodBatch(qpos[cut:j], inc[cut:j], feed[cut:j], limit[cut:j], line[cut:j])
            cut = j
            yield ev
        if cut < len(sv):
            yield PeriodBatch(qpos[cut:], inc[cut:], feed[cut:], limit[cut:], line[cut:])
        return used

    def stand(self, seconds: float, line: int) -> Iterator[PeriodBatch]:
        """A dwell: periods standing where the machine is."""
        n = int(round(seconds / self.T))
        while n > 0:
            k = min(n, self.batch_periods)
            qpos = np.repeat((self.blu * self.blu_mm)[None, :], k, axis=0)
            yield PeriodBatch(qpos, np.zeros((k, 3), np.int64), np.zeros(k),
                              np.full(k, LIMIT_DWELL, np.int8), np.full(k, line, np.int32))
            n -= k


def _blend_points(loc: np.ndarray, sv: np.ndarray, pieces: Pieces, pstart: np.ndarray,
                  nurbs: dict[int, BlendCurve]) -> np.ndarray:
    """Points of the blend pieces loc at arc lengths sv, every blend in one compiled call
    (loc does not decrease: each blend's periods are one run)."""
    first = np.flatnonzero(np.diff(loc, prepend=-1, append=-1))
    ctrl, tab_s, tab_u = [], [], []
    for k in pieces.nurbs[loc[first[:-1]]].tolist():
        drv = nurbs[k]
        ctrl.append(drv.points)
        tab_s.append(drv.table.s)
        tab_u.append(drv.table.u)
    return bezier_points_runs(np.concatenate(ctrl, dtype=float), _firsts(ctrl), np.concatenate(tab_s),
                              np.concatenate(tab_u), _firsts(tab_s), sv - pstart[loc], first, GAUSS_X,
                              GAUSS_W)


def _firsts(parts: list) -> np.ndarray:
    """Where each of parts starts in their concatenation, and where the last ends."""
    return np.cumsum([0] + [len(x) for x in parts])


def _nurbs_points(pos, loc, sv, s_prev, mask, pieces: Pieces, pstart: np.ndarray,
                  nurbs: dict[int, NurbsDriver]) -> None:
    """Fill pos where mask is set by walking each NURBS piece's stepper, run by run, so
    that each stepper sees its periods in order with the step from the one before."""
    idx = np.nonzero(mask)[0]
    runs = np.split(idx, np.nonzero(np.diff(idx) != 1)[0] + 1)
    for run in runs:
        p = int(loc[run[0]])
        if not np.all(loc[run] == p):
            sub = np.split(run, np.nonzero(np.diff(loc[run]) != 0)[0] + 1)
        else:
            sub = [run]
        for r in sub:
            p = int(loc[r[0]])
            before = sv[r[0] - 1] if r[0] > 0 else s_prev
            drv = nurbs[int(pieces.nurbs[p])]
            pos[r] = drv.points(sv[r] - pstart[p], before - pstart[p])
