"""The feed stage's output side: a planned profile -> periods on the grid -> PeriodBatch.

The planner (ipo.feed.planner) plans v^2 over the window's samples and refines it
(ipo.feed.lookahead.refine) into a `Profile`; this module puts it on the period grid
(where along the path each period ends, lookahead.sample_times and positions_at), turns
those arc lengths into machine positions (lines, arcs and blends evaluated exactly by arc
length, a NURBS walked by its stepper), quantises them to BLU increments
(ipo.interp.reference_word.quantise), passes them through the S-curve filter in that mode
(ipo.feed.scurve) and cuts the batches where events sit.

It owns the state that belongs to the machine rather than to the plan: where the machine
stands (in mm and in BLU), the S-curve filter with the arc length it has put out, and
the period grid's phase. It reads the planner's window (ipo.feed.window: pieces, where
they start, their NURBS drivers, pending events) and changes nothing in it: it hands back
where it stopped and how many events it put out.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.config import MachineConfig
from ipo.feed.nurbs_driver import NurbsDriver
from ipo.contracts import LIMIT_ACCEL, LIMIT_DWELL, PeriodBatch
from ipo.feed.lookahead import np_max, positions_at, sample_times
from ipo.feed.analytic import points_along
from ipo.feed.pieces import KIND_BLEND, KIND_NURBS, Pieces
from ipo.feed.window import Window
from ipo.interp.reference_word import quantise
from ipo.feed.scurve import MovingAverage


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


class PeriodOutput:
    """Machine position, S-curve filter and period grid state; see the module docstring."""

    def __init__(self, config: MachineConfig, fir: MovingAverage | None, *, start_mm, batch_periods: int):
        self.T = config.period_s
        self.blu_mm = config.blu_mm
        self.batch_periods = batch_periods
        self.fir = fir
        self.pos = np.array(start_mm, dtype=float)
        self.blu = np.rint(self.pos / config.blu_mm).astype(np.int64)
        self.s_out = 0.0  # arc length of the last period sent (S-curve filter output)
        self._phase = self.T  # time from the first held sample to the next period end
        self._s_last = 0.0  # planned arc length at the end of the last period

    def emit(self, prof: Profile, window: Window, *, stop: bool, replan: Callable[[], bool]):
        """Periods along the profile up to its last sample, where the machine stops if
        `stop`. When `replan()` turns true (a feed override changed) it finishes the current
        sample interval and ends there. The generator returns (k, n): the sample it ended on
        (the next plan starts there) and how many of the window's events it put out."""
        s, xs, src, seg_reason = prof.s, prof.v2, prof.src, prof.reason
        c = len(prof.s_samples) - 1
        tc = sample_times(s, xs)
        t_next, s_prev, k_stop, used = self._phase, self._s_last, c, 0
        while True:
            fit = int(np.floor((tc[-1] - t_next) / self.T + 1e-9)) + 1 if t_next <= tc[-1] + 1e-12 else 0
            n = min(fit, self.batch_periods)
            times = t_next + self.T * np.arange(n)
            last = times[-1] if n else t_next - self.T
            exact_stop = stop and n == fit and tc[-1] - last > 1e-12
            if exact_stop:
                times = np.append(times, tc[-1])  # the stop is reached exactly at a period's end
            if len(times) == 0:
                break
            sv, kseg = positions_at(np.minimum(times, tc[-1]), s, xs, tc)
            if exact_stop:
                sv[-1] = s[-1]
            used = yield from self._periods(sv, s_prev, seg_reason[kseg], window, used, flush=stop and n == fit)
            s_prev = self._s_last = float(sv[-1])
            t_next = times[-1] + self.T
            if n == fit:
                break
            if replan():
                # finish the current sample interval on the old plan, then replan from there
                k_stop = min(int(src[kseg[-1]]) + 1, c)
                r_stop = int(np.searchsorted(s, prof.s_samples[k_stop], side="left"))
                t_stop = tc[r_stop]
                more = int(np.floor((t_stop - t_next) / self.T + 1e-9)) + 1 if t_next <= t_stop else 0
                if more:
                    times = t_next + self.T * np.arange(more)
                    sv, kseg = positions_at(times, s, xs, tc)
                    used = yield from self._periods(sv, s_prev, seg_reason[kseg], window, used, flush=False)
                    s_prev = self._s_last = float(sv[-1])
                    t_next = times[-1] + self.T
                break
        self._phase = t_next - (tc[r_stop] if k_stop < c else tc[len(s) - 1])
        if stop and k_stop == c:
            self._phase = self.T
        return k_stop, used

    def _periods(self, sv: np.ndarray, s_prev: float, limit: np.ndarray, window: Window, used: int, *,
                 flush: bool):
        """Planned arc lengths sv of consecutive periods to the machine, through the S-curve
        filter in that mode; `flush` runs the filter out at a stop. The window's events from
        index `used` on that are due by the end are yielded in place; the generator returns
        the index after the last one put out."""
        if self.fir is None:
            return (yield from self._batch(sv, s_prev, limit, window, used))
        smooth = self.fir.filter(np.diff(sv, prepend=s_prev), run_out=flush)
        if flush:
            limit = np.concatenate([limit, np.full(self.fir.m - 1, LIMIT_ACCEL, np.int8)])
        s_f = self.s_out + np.cumsum(smooth)
        if flush:
            s_f[-1] = sv[-1]  # the filter has run out: the stop itself, without rounding
        prev = self.s_out
        self.s_out = float(s_f[-1])
        return (yield from self._batch(s_f, prev, limit, window, used))

    def _batch(self, sv: np.ndarray, s_prev: float, limit: np.ndarray, window: Window, used: int):
        """Points at arc lengths sv, quantised; split where events sit (the window's from
        index `used` on). Returns the index after the last event put out."""
        pieces, pstart, nurbs, events = window.pieces, window.pstart, window.drivers, window.events
        loc, pos = points_along(pieces.geometry, pstart, pieces.length, sv)
        mask = pieces.kind[loc] == KIND_NURBS
        if mask.any():
            _nurbs_points(pos, loc, sv, s_prev, mask, pieces, pstart, nurbs)
        blend = np.nonzero(pieces.kind[loc] == KIND_BLEND)[0]
        if len(blend):  # loc does not decrease: each blend's periods are one run
            for at in np.split(blend, np.nonzero(np.diff(loc[blend]))[0] + 1):
                p = loc[at[0]]
                drv = nurbs[int(pieces.nurbs[p])]
                pos[at] = drv.table.points_at(drv.entity, sv[at] - pstart[p])
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
