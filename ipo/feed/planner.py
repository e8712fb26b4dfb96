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
from ipo.feed.merge import merge_collinear
from ipo.feed.emission import PeriodOutput, centripetal_binds, period_reasons
from ipo.feed.pieces import KIND_ANALYTIC, Motion, Pieces, build, motion_length
from ipo.roughness import cusp_height_mm
from ipo.feed.nurbs_driver import NurbsDriver
from ipo.feed.split import corner_parts
from ipo.feed.window import Window
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



def nurbs_end_gap_mm(config: MachineConfig) -> float:
    """The gap of the end samples of the planner's NURBS tables (sampling.nurbs_table): two
    periods at the top path speed. The controller's check tables the curves the same way."""
    v_top = float(np.linalg.norm(np.array([a.max_velocity_mm_s for a in config.axes]) * VELOCITY_USE))
    return 2 * v_top * config.period_s

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
        self._motions: list[tuple] = []  # intake: pending (entity, rpm, nurbs index), as Motion
        self._trim = 0.0  # how much of the held-back motion's start its corner blend took
        self._win = Window()  # the look-ahead window (where the machine stands is self._output's)
        self._phase = self.T  # time from the first held sample to the next period end
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
        # the corner settings pieces.build takes (S-curve mode: arcs no tighter than this; the
        # curvature-continuous corners' limits), public so that a study can force arcs
        self.min_blend_radius_mm = min_blend_radius_mm(self._fir, self.a_max, self._j_max, self.T)
        self.g2_limits = g2_blend_limits(self._fir, self.a_max, self._j_max, self.T)
        # the output side runs the filter; the planner reads only its span (fir.m)
        self._output = PeriodOutput(config, self._fir, start_mm=start_mm, batch_periods=self.batch_periods)
        self._rpm = 0.0
        self._finishing = _finishing_params(config)
        self._end_gap_mm = nurbs_end_gap_mm(config)

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
        for e in merge_collinear(entities):  # G64 Q
            tp = type(e)
            if tp is Line or tp is Rapid:  # the bulk of any program: keep this path lean
                if e.start == e.end:
                    continue  # a move to where the machine stands: no motion, no corner
                if not motions and self._win.samples is None:
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
                if self._win.samples is None and not self._motions:
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
        if self._win.samples is None and not self._motions:
            self._check_start(e)
        for m in corner_parts(e) if isinstance(e, Nurbs) else (e,):
            idx = self._win.add_driver(self._driver(m)) if isinstance(m, Nurbs) else -1
            self._motions.append(Motion(m, self._rpm, idx))

    def _driver(self, e: Nurbs) -> NurbsDriver:
        return NurbsDriver(e, nurbs_table(e, end_gap_mm=self._end_gap_mm), self.method)

    def _build_pending_event(self, e) -> None:
        """An event happens where the motions read so far end: at the end of the held-back
        motion (its end corner is not known yet, so the point is its programmed end)."""
        s_ev = self._win.s_end_mm
        if self._motions:
            self._build(final=False)
            s_ev = self._win.s_end_mm + motion_length(self._motions[0], self._win.drivers) - self._trim
        self._win.events.append((s_ev, e))

    def _flush(self) -> Iterator:
        if self._motions:
            self._build(final=True)
        if self._win.samples is not None:
            yield from self._plan(final=True)
        for _, ev in self._win.events:
            yield ev
        self._win.events.clear()

    # ---- pieces and samples ----------------------------------------------------------
    def _build(self, *, final: bool) -> None:
        """Turn the pending motions into pieces and samples (all but the last unless final)."""
        motions, win = self._motions, self._win
        if len(motions) < 2 and not final:
            return
        built = build(motions, final=final, lead_trim_mm=self._trim, blend_default_mm=self.cfg.g64_blend_tol_mm,
                      rapid_mm_s=self.cfg.rapid_mm_s, drivers=win.drivers, next_index=win.n_drivers,
                      make_driver=self._driver, min_blend_radius_mm=self.min_blend_radius_mm,
                      g2_limits=self.g2_limits)
        win.apply(built.drivers.changed, built.drivers.added)
        if final:
            motions.clear()
            # the last motion was built whole: nothing is held back, so no corner of it
            # reaches into the next motion (a stale trim cut the start off the first move
            # after a dwell or a stop that followed an event)
            self._trim = 0.0
        else:
            del motions[:-1]
            self._trim = built.trim_mm
        pc = built.pieces
        if len(pc) == 0:
            return
        tables = {int(i): win.drivers[int(i)].table for i in pc.nurbs[pc.kind != KIND_ANALYTIC]}
        win.append(pc, sample(pc, win.s_end_mm, tables, end_gap_mm=self._end_gap_mm), self._caps)

    def _caps(self, rel: Samples, pc: Pieces):
        return sample_caps(rel, pc, self.v_max, self.a_max, self.T, self.cfg.chord_tol_mm, self._finishing,
                           self._j_max)

    # ---- look-ahead and emission -----------------------------------------------------
    def _soft_caps(self) -> tuple[np.ndarray, np.ndarray]:
        win = self._win
        loc = win.samples.piece - win.piece_base
        feed = win.pieces.feed_mm_s[loc] * np.where(win.pieces.rapid[loc], 1.0, self._override)
        xf = feed**2
        hard = win.cap
        if self._fir is not None:
            hard = low_caps_to_stops(hard, win.samples.piece, lowest_smooth_x(self._fir, self.a_max, self.T))
            hard = spread_min(win.samples.s, hard, self._fir.m * self.T, self.T, float(np.linalg.norm(self.a_max)))
        prog = xf < hard
        return np.where(prog, xf, hard), np.where(prog, LIMIT_PROGRAMMED, win.reason).astype(np.int8)

    def _plan(self, *, final: bool) -> Iterator:
        while self._win.samples is not None and len(self._win.samples) > 1:
            self._override_changed = False
            smp = self._win.samples
            cap, reason = self._soft_caps()
            ascale = self._ascale(len(smp), cap)
            x = la.plan(smp.s, smp.t, smp.kv, cap, self.a_max, ascale, self._win.x0_v2, 0.0)
            x[x < _STANDSTILL_X] = 0.0  # rounding residue of braking to a stop is a stop
            if final:
                c = len(smp) - 1
            else:
                # what lies one stopping distance (at this window's top speed) before the
                # window's end cannot depend on the moves not read yet
                reach = float(cap.max()) / (2 * self.a_max.min()) + 1e-3
                c = int(np.searchsorted(smp.s, self._win.s_end_mm - reach, side="right")) - 1
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
        if final and self._win.samples is not None and len(self._win.samples) <= 1:
            self._win.reset()

    def _ascale(self, n: int, cap: np.ndarray) -> np.ndarray:
        """Share of the path acceleration in the first n - 1 sample intervals: halved next to
        sharp corners; in S-curve mode also kept within the jerk on curves (jerk_accel_scale)."""
        win = self._win
        scale = np.where(win.corner[:n - 1] | win.corner[1:n], CORNER_SHARE, 1.0)
        if self._j_max is not None:
            scale = np.minimum(scale, jerk_accel_scale(win.samples.t[:n], win.samples.kv[:n], cap[:n], self.a_max,
                                                       float(self._j_max.min())))
        return scale

    def _emit(self, c: int, x: np.ndarray, cap: np.ndarray, reason: np.ndarray, *, stop: bool) -> Iterator:
        """Emit periods over samples 0..c, then drop them (keeping c as the new start)."""
        smp = self._win.samples
        ascale = self._ascale(c + 1, cap)
        loc = smp.piece[:c + 1] - self._win.piece_base
        feed = self._win.pieces.feed_mm_s[loc] * np.where(self._win.pieces.rapid[loc], 1.0, self._override)
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
        self._win.x0_v2 = float(x[k_stop])
        self._win.drop(k_stop, None if self._fir is None else self._output.s_out)
        if stop and k_stop == c:
            self._phase = self.T

    def _out(self, sv: np.ndarray, s_prev: float, limit: np.ndarray, *, flush: bool) -> Iterator:
        """Periods to the output side, which reads the window as it stands now."""
        used = yield from self._output.periods(sv, s_prev, limit, self._win, flush=flush)
        self._win.take_events(used)

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
