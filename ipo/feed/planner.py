"""The feed stage: entities in, per-period axis increments out.

Pipeline per window of entities: pieces (ipo.feed.pieces: lines, arcs, G64 corner blends,
NURBS) -> samples (ipo.feed.sampling) -> caps on v^2 from every limit (ipo.feed.limits, 002's
roughness limiter included) -> look-ahead profile (ipo.feed.lookahead) -> time
parameterisation at the interpolation period -> points and BLU increments of each
period (ipo.feed.emission; a NURBS walked by its stepper with the target step v*T).

Bounded memory: the planner holds a window that reaches one stopping distance beyond
what it commits, and it emits the committed part chunk by chunk.

S-curve mode (accel_mode = "scurve"): the per-period path steps pass a moving average
over 2 A / J seconds (ipo.feed.scurve), the planner gives the tangential and centripetal
shares half of each axis limit each, caps are spread over what the filter mixes, and
unblended corners become stops.

Feed override. `plan_periods(..., feed_override=f)` plans every feed move at f times its
programmed feed (rapids are not overridden; the other limits always hold). A real-time
controller can change it while running: build a `FeedPlanner`, iterate `planner.run(
entities)`, and call `planner.set_feed_override(f)` between batches; the periods not yet
emitted are replanned from the machine's current speed (braking at the machine's limits
if the new feed is lower), taking effect within one sample interval (<= 2 mm of path).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ipo.feed import lookahead as la
from ipo.config import METHODS, MachineConfig
from ipo.feed.limits import (CORNER_SHARE, axis_velocity_cap, g2_blend_limits, jerk_accel_scale, low_caps_to_stops,
                             lowest_smooth_x, min_blend_radius_mm, sample_caps, spread_min)
from ipo.contracts import LIMIT_CURVATURE, LIMIT_PROGRAMMED, PeriodBatch
from ipo.errors import START, IpoError
from ipo.feed.emission import PeriodOutput, centripetal_binds, period_reasons
from ipo.feed.pieces import KIND_ANALYTIC, Motion, Pieces, build, motion_length
from ipo.feed.roughness import cusp_height_mm
from ipo.feed.nurbs_driver import NurbsDriver
from ipo.feed.split import corner_parts
from ipo.feed.sampling import Samples, nurbs_table, sample
from ipo.feed.scurve import MovingAverage
from ipr.entities import (MOTION_TYPES, Auxiliary, Coolant, Dwell, Line, Message, Nurbs, ProgramEnd, Rapid,
                          Spindle, Stop, ToolChange)

# Plan with a sliver of headroom below the machine limits: the profile is linear in v^2
# between samples and is checked at the samples only.
ACCEL_USE = 0.985
VELOCITY_USE = 0.995
_BUILD_CHUNK = 2048  # motions turned into pieces per call
_START_TOL_MM = 1e-6
_STANDSTILL_X = 1e-12  # v^2 below this (v < 1 um/s) counts as standing still


class FeedPlanner:
    """Streaming look-ahead planner; see the module docstring."""

    def __init__(self, config: MachineConfig, *, method: str | None = None, feed_override: float = 1.0,
                 start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096):
        if not batch_periods >= 1:
            raise ValueError(f"batch_periods must be >= 1, got {batch_periods}")
        self.cfg = config
        self.method = method or config.method
        if self.method not in METHODS:
            raise ValueError(f"method {self.method!r} cannot follow a feed profile; choose one of {', '.join(METHODS)}")
        self.set_feed_override(feed_override)
        self.batch_periods = int(batch_periods)
        self.T = config.period_s
        self.v_max = np.array([a.max_velocity_mm_s for a in config.axes]) * VELOCITY_USE
        self.a_max = np.array([a.max_accel_mm_s2 for a in config.axes]) * ACCEL_USE
        # look-ahead state: pieces and samples not yet emitted (where the machine stands is
        # the output side's, self._output)
        self._motions: list[tuple] = []  # pending (entity, rpm, nurbs index), as Motion
        self._trim = 0.0
        self._pieces: Pieces | None = None
        self._piece_base = 0  # global index of self._pieces[0]
        self._pstart = np.zeros(0)  # global arc length where each held piece starts
        self._smp: Samples | None = None
        self._cap = np.zeros(0)
        self._reason = np.zeros(0, np.int8)
        self._corner = np.zeros(0, bool)
        self._x0 = 0.0  # v^2 at the first held sample
        self._s_end = 0.0  # arc length at the end of everything built
        self._phase = self.T  # time from the first held sample to the next period end
        self._events: list[tuple[float, object]] = []
        self._nurbs: dict[int, NurbsDriver] = {}
        self._s_last = 0.0  # planned arc length at the end of the last period
        self._fir = None
        self._j_max = None
        if config.accel_mode == "scurve":
            # the filter's own ramps use up to half of J; the steps of curvature where pieces
            # meet and the centripetal acceleration along curves get the other half
            self._j_max = np.array([a.max_jerk_mm_s3 for a in config.axes]) * (0.5 * ACCEL_USE)
            # the filter shifts the path acceleration along the path against the centripetal
            # share planned for each point: each gets half of every axis limit
            self.a_max = self.a_max / 2
            # a planned reversal from +A/2 to -A/2 steps an axis acceleration by A: the filter
            # spreads it over 2 A / J seconds, a jerk of J / 2
            self._fir = MovingAverage.for_limits(np.array([2 * a.max_accel_mm_s2 for a in config.axes]),
                                                 np.array([a.max_jerk_mm_s3 for a in config.axes]), self.T)
        self._blend_r_min = min_blend_radius_mm(self._fir, self.a_max, self._j_max, self.T)
        self._g2_limits = g2_blend_limits(self._fir, self.a_max, self._j_max, self.T)
        # the output side runs the filter; the planner reads only its span (fir.m)
        self._output = PeriodOutput(config, self._fir, start_mm=start_mm, batch_periods=self.batch_periods)
        self._n_nurbs = 0
        self._rpm = 0.0
        self._finishing = _finishing_params(config)
        self._v_top = float(np.linalg.norm(self.v_max))

    def set_feed_override(self, factor: float) -> None:
        """Scale the programmed feeds of the periods not yet emitted (1.0 = 100 %)."""
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"feed override must be a finite factor > 0, got {factor!r}")
        self._override = float(factor)
        self._override_changed = True

    # ---- entity intake -------------------------------------------------------------
    def run(self, entities: Iterable) -> Iterator[PeriodBatch | object]:
        """Period batches and events in order; the machine ends standing still."""
        motions = self._motions  # kept as the same list object: cleared in place
        for e in entities:
            tp = type(e)
            if tp is Line or tp is Rapid:  # the bulk of any program: keep this path lean
                if e.start == e.end:
                    continue  # a move to where the machine stands: no motion, no corner
                if not motions and self._smp is None:
                    self._check_start(e)
                motions.append((e, self._rpm, -1))
                if len(motions) > _BUILD_CHUNK:
                    self._build(final=False)
                    yield from self._plan(final=False)
            elif isinstance(e, MOTION_TYPES):
                self._take_motion(e)
                if len(self._motions) > _BUILD_CHUNK:
                    self._build(final=False)
                    yield from self._plan(final=False)
            elif isinstance(e, (Spindle, Coolant, Message, Auxiliary)):
                if self._smp is None and not self._motions:
                    yield e  # standing still: nothing to wait for
                else:
                    self._build_pending_event(e)
                if isinstance(e, Spindle):
                    self._rpm = e.rpm if e.direction is not None else 0.0
            elif isinstance(e, Dwell):
                yield from self._flush()
                yield from self._output.stand(e.seconds, e.line)
            elif isinstance(e, (Stop, ToolChange, ProgramEnd)):
                yield from self._flush()
                yield e
                if isinstance(e, ProgramEnd):
                    return
            else:
                raise TypeError(f"the feed stage cannot handle {type(e).__name__}")
        yield from self._flush()

    def _check_start(self, e) -> None:
        pos = self._output.pos
        if np.max(np.abs(np.array(e.start) - pos)) > _START_TOL_MM:
            raise IpoError(START, f"motion starts at {list(e.start)} but the machine stands at {pos.tolist()}",
                           e.line)

    def _take_motion(self, e) -> None:
        """Arcs and NURBS, a NURBS as its parts between its corners (lines take the lean path in run)."""
        if self._smp is None and not self._motions:
            self._check_start(e)
        for m in corner_parts(e) if isinstance(e, Nurbs) else (e,):
            self._motions.append(Motion(m, self._rpm, self._add_nurbs(m) if isinstance(m, Nurbs) else -1))

    def _add_nurbs(self, e: Nurbs) -> int:
        idx = self._n_nurbs
        self._n_nurbs += 1
        self._nurbs[idx] = NurbsDriver(e, nurbs_table(e, end_gap_mm=2 * self._v_top * self.T), self.method)
        return idx

    def _build_pending_event(self, e) -> None:
        """An event happens where the motions read so far end: at the end of the held-back
        motion (its end corner is not known yet, so the point is its programmed end)."""
        s_ev = self._s_end
        if self._motions:
            self._build(final=False)
            s_ev = self._s_end + motion_length(self._motions[0], self._nurbs) - self._trim
        self._events.append((s_ev, e))

    def _flush(self) -> Iterator:
        if self._motions:
            self._build(final=True)
        if self._smp is not None:
            yield from self._plan(final=True)
        for _, ev in self._events:
            yield ev
        self._events.clear()

    # ---- pieces and samples ----------------------------------------------------------
    def _build(self, *, final: bool) -> None:
        """Turn the pending motions into pieces and samples (all but the last unless final)."""
        motions = self._motions
        if len(motions) < 2 and not final:
            return
        pc, trim = build(motions, final=final, lead_trim_mm=self._trim,
                         blend_default_mm=self.cfg.g64_blend_tol_mm, rapid_mm_s=self.cfg.rapid_mm_s,
                         nurbs=self._nurbs, add_blend=self._add_nurbs, min_blend_radius_mm=self._blend_r_min,
                         g2_limits=self._g2_limits)
        if final:
            motions.clear()
        else:
            del motions[:-1]
            self._trim = trim
        self._append(pc)

    def _append(self, pc: Pieces) -> None:
        if len(pc) == 0:
            return
        tables = {int(i): self._nurbs[int(i)].table for i in pc.nurbs[pc.kind != KIND_ANALYTIC]}
        smp = sample(pc, self._s_end, tables, end_gap_mm=2 * self._v_top * self.T)
        if self._pieces is None:
            base = self._piece_base
            self._pieces = pc
            self._pstart = self._s_end + np.concatenate([[0.0], np.cumsum(pc.length)[:-1]])
        else:
            base = self._piece_base + len(self._pieces)
            self._pieces = Pieces.concat([self._pieces, pc])
            self._pstart = np.concatenate([self._pstart, self._s_end + np.concatenate(
                [[0.0], np.cumsum(pc.length)[:-1]])])
        smp.piece += base
        local = self._pieces
        if self._smp is None:
            cap, reason, corner = self._caps(smp, local)
            self._smp, self._cap, self._reason, self._corner = smp, cap, reason, corner
        else:
            # the last two held samples are capped again: a corner where the windows join
            # also caps the sample before it (limits.CORNER_SHARE)
            j = min(2, len(self._smp))
            joined = Samples.concat([self._smp.tail(len(self._smp) - j), smp])
            cap, reason, corner = self._caps(joined, local)
            lower = cap[:j] < self._cap[-j:]
            self._cap[-j:] = np.where(lower, cap[:j], self._cap[-j:])
            self._reason[-j:] = np.where(lower, reason[:j], self._reason[-j:])
            self._corner[-j:] |= corner[:j]
            self._smp = Samples.concat([self._smp, smp])
            self._cap = np.concatenate([self._cap, cap[j:]])
            self._reason = np.concatenate([self._reason, reason[j:]])
            self._corner = np.concatenate([self._corner, corner[j:]])
        self._s_end += float(pc.length.sum())

    def _caps(self, smp: Samples, pc: Pieces):
        rel = Samples(smp.s, smp.t, smp.kv, smp.piece - self._piece_base, smp.sigma)
        return sample_caps(rel, pc, self.v_max, self.a_max, self.T, self.cfg.chord_tol_mm, self._finishing,
                           self._j_max)

    # ---- look-ahead and emission -----------------------------------------------------
    def _soft_caps(self) -> tuple[np.ndarray, np.ndarray]:
        loc = self._smp.piece - self._piece_base
        feed = self._pieces.feed_mm_s[loc] * np.where(self._pieces.rapid[loc], 1.0, self._override)
        xf = feed**2
        hard = self._cap
        if self._fir is not None:
            hard = low_caps_to_stops(hard, self._smp.piece, lowest_smooth_x(self._fir, self.a_max, self.T))
            hard = spread_min(self._smp.s, hard, self._fir.m * self.T, self.T, float(np.linalg.norm(self.a_max)))
        prog = xf < hard
        return np.where(prog, xf, hard), np.where(prog, LIMIT_PROGRAMMED, self._reason).astype(np.int8)

    def _plan(self, *, final: bool) -> Iterator:
        while self._smp is not None and len(self._smp) > 1:
            self._override_changed = False
            smp = self._smp
            cap, reason = self._soft_caps()
            ascale = self._ascale(len(smp), cap)
            x = la.plan(smp.s, smp.t, smp.kv, cap, self.a_max, ascale, self._x0, 0.0)
            x[x < _STANDSTILL_X] = 0.0  # rounding residue of braking to a stop is a stop
            if final:
                c = len(smp) - 1
            else:
                # what lies one stopping distance (at this window's top speed) before the
                # window's end cannot depend on the moves not read yet
                reach = float(cap.max()) / (2 * self.a_max.min()) + 1e-3
                c = int(np.searchsorted(smp.s, self._s_end - reach, side="right")) - 1
                if c < 1:
                    return
            # stops inside (G61 and the like) are emitted one by one from the same plan, so
            # that the period grid lands exactly on each
            stops = list(np.nonzero(x[1:c] <= 0.0)[0] + 1) + [c]
            done = 0
            for k in stops:
                if k <= done:
                    continue
                halt = final or k < c
                yield from self._emit(k - done, x[done:], cap[done:], reason[done:], stop=halt)
                done = k
                if self._override_changed:
                    break
            if not (final or self._override_changed):
                return
        if final and self._smp is not None and len(self._smp) <= 1:
            self._reset_window()

    def _ascale(self, n: int, cap: np.ndarray) -> np.ndarray:
        """Share of the path acceleration in the first n - 1 sample intervals: halved next to
        sharp corners; in S-curve mode also kept within the jerk on curves (jerk_accel_scale)."""
        scale = np.where(self._corner[:n - 1] | self._corner[1:n], CORNER_SHARE, 1.0)
        if self._j_max is not None:
            scale = np.minimum(scale, jerk_accel_scale(self._smp.t[:n], self._smp.kv[:n], cap[:n], self.a_max,
                                                       float(self._j_max.min())))
        return scale

    def _emit(self, c: int, x: np.ndarray, cap: np.ndarray, reason: np.ndarray, *, stop: bool) -> Iterator:
        """Emit periods over samples 0..c, then drop them (keeping c as the new start)."""
        smp = self._smp
        ascale = self._ascale(c + 1, cap)
        loc = smp.piece[:c + 1] - self._piece_base
        feed = self._pieces.feed_mm_s[loc] * np.where(self._pieces.rapid[loc], 1.0, self._override)
        plateau = np.minimum(feed**2, axis_velocity_cap(smp.t[:c + 1], self.v_max))
        s, xs, src = la.refine(smp.s[:c + 1], smp.t[:c + 1], smp.kv[:c + 1], x[:c + 1], cap[:c + 1], plateau,
                               self.a_max, ascale)
        cen = centripetal_binds(smp.s[:c + 1], smp.t[:c + 1], smp.kv[:c + 1], x[:c + 1], self.a_max, ascale)
        seg_reason = period_reasons(xs, src, cap, reason, cen, LIMIT_CURVATURE)
        tc = la.sample_times(s, xs)
        c_ref = len(s) - 1
        t_next = self._phase
        s_prev = self._s_last
        k_stop = c
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
            sv, kseg = la.positions_at(np.minimum(times, tc[-1]), s, xs, tc)
            if exact_stop:
                sv[-1] = s[-1]
            yield from self._out(sv, s_prev, seg_reason[kseg], flush=stop and n == fit)
            s_prev = self._s_last = float(sv[-1])
            t_next = times[-1] + self.T
            if n == fit:
                break
            if self._override_changed:
                # finish the current sample interval on the old plan, then replan from there
                k_stop = min(int(src[kseg[-1]]) + 1, c)
                r_stop = int(np.searchsorted(s, smp.s[k_stop], side="left"))
                t_stop = tc[r_stop]
                more = int(np.floor((t_stop - t_next) / self.T + 1e-9)) + 1 if t_next <= t_stop else 0
                if more:
                    times = t_next + self.T * np.arange(more)
                    sv, kseg = la.positions_at(times, s, xs, tc)
                    yield from self._out(sv, s_prev, seg_reason[kseg], flush=False)
                    s_prev = self._s_last = float(sv[-1])
                    t_next = times[-1] + self.T
                break
        self._phase = t_next - (tc[r_stop] if k_stop < c else tc[c_ref])
        self._x0 = float(x[k_stop])
        self._drop(k_stop)
        if stop and k_stop == c:
            self._phase = self.T

    def _out(self, sv: np.ndarray, s_prev: float, limit: np.ndarray, *, flush: bool) -> Iterator:
        """Periods to the output side, with the window as it stands now."""
        return self._output.periods(sv, s_prev, limit, self._pieces, self._pstart, self._nurbs, self._events,
                                    flush=flush)

    def _drop(self, k: int) -> None:
        """Forget samples before k and the pieces no sample refers to any more."""
        self._smp = self._smp.tail(k)
        self._cap, self._reason, self._corner = self._cap[k:], self._reason[k:], self._corner[k:]
        first = int(self._smp.piece[0]) - self._piece_base
        if self._fir is not None:  # the filter output lags: keep the pieces it still needs
            lag = int(np.searchsorted(self._pstart, self._output.s_out, side="right")) - 1
            first = min(first, max(lag, 0))
        if first > 0:
            for i in np.unique(self._pieces.nurbs[:first]):
                if i >= 0 and i not in set(self._pieces.nurbs[first:].tolist()):
                    self._nurbs.pop(int(i), None)
            self._pieces = self._pieces.take(slice(first, None))
            self._pstart = self._pstart[first:]
            self._piece_base += first

    def _reset_window(self) -> None:
        if self._pieces is not None:
            self._piece_base += len(self._pieces)
        self._pieces, self._smp = None, None
        self._pstart = np.zeros(0)
        self._cap, self._reason, self._corner = np.zeros(0), np.zeros(0, np.int8), np.zeros(0, bool)
        self._x0 = 0.0


def _finishing_params(cfg: MachineConfig):
    fin = cfg.finishing
    if fin is None:
        return None
    tool = cfg.tools[fin.tool]
    target = (cusp_height_mm(tool.ball_radius_mm, fin.pick_feed_mm) if fin.roughness_target_um == "isotropic"
              else fin.roughness_target_um * 1e-3)
    return tool.ball_radius_mm, fin.pick_feed_mm, target, tool.flutes


def plan_periods(entities: Iterable, config: MachineConfig, *, method: str | None = None,
                 feed_override: float = 1.0, start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096
                 ) -> Iterator[PeriodBatch | object]:
    """Period batches interleaved with the non-motion events (see FeedPlanner)."""
    return FeedPlanner(config, method=method, feed_override=feed_override, start_mm=start_mm,
                       batch_periods=batch_periods).run(entities)
