"""The feed stage: entities in, per-period axis increments out.

Pipeline per window of entities: the intake holds the motions read and builds them into
pieces (ipo.feed.intake, ipo.feed.pieces: lines, arcs, G64 corner blends, NURBS) -> the
window samples and caps them (ipo.feed.window, ipo.feed.sampling, ipo.feed.limits with
002's roughness limiter) -> this module plans the look-ahead profile over the window
(ipo.feed.lookahead) -> the output side puts it on the period grid and turns it into
points and BLU increments (ipo.feed.emission; a NURBS walked by its stepper with the
target step v*T).

Bounded memory: the planner holds a window that reaches one stopping distance beyond
what it commits, and it emits the committed part chunk by chunk.

S-curve mode (accel_mode = "scurve"): the acceleration-limited profile becomes jerk-limited
segments between anchors (ipo.feed.scurve, ipo.feed.jerk_plan), with the tangential and
centripetal shares of each axis limit split only where the path curves; unblended corners
become stops.

Feed override. `plan_periods(..., feed_override=f)` plans every feed move at f times its
programmed feed (rapids are not overridden; the other limits always hold). A real-time
controller can change it while running: build a `FeedPlanner`, iterate `planner.run(
entities)`, and call `planner.set_feed_override(f)` between batches; the periods not yet
emitted are replanned from the machine's current speed (braking at the machine's limits
if the new feed is lower), taking effect within one sample interval (<= 2 mm of path).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from functools import partial

import numpy as np

from ipo.feed import lookahead as la
from ipo.config import METHODS, MachineConfig
from ipo.feed.limits import CORNER_SHARE, axis_velocity_cap, g2_blend_limits, min_blend_radius_mm, sample_caps
from ipo.contracts import LIMIT_ACCEL, LIMIT_CURVATURE, LIMIT_PROGRAMMED, PeriodBatch
from ipo.errors import START, IpoError
from ipo.feed.emission import PeriodOutput, Profile, centripetal_binds, period_reasons
from ipo.feed.intake import CornerRules, Intake
from ipo.feed.merge import merge_collinear
from ipo.roughness import cusp_height_mm
from ipo.feed.window import Window
from ipr.entities import (MOTION_TYPES, Auxiliary, Coolant, Dwell, Line, Message, ProgramEnd, Rapid, Spindle,
                          Stop, ToolChange)

# Plan with a sliver of headroom below the machine limits: the profile is linear in v^2
# between samples and is checked at the samples only.
ACCEL_USE = 0.985
VELOCITY_USE = 0.995
_START_TOL_MM = 1e-6
_STANDSTILL_X = 1e-12  # v^2 below this (v < 1 um/s) counts as standing still



def nurbs_end_gap_mm(config: MachineConfig) -> float:
    """The gap of the end samples of the planner's NURBS tables (sampling.nurbs_table): two
    periods at the top path speed. The controller's check tables the curves the same way."""
    v_top = float(np.linalg.norm(np.array([a.max_velocity_mm_s for a in config.axes]) * VELOCITY_USE))
    return 2 * v_top * config.period_s

class FeedPlanner:
    """Streaming look-ahead planner; see the module docstring.

    The thin loop between the feed stage's three owners: the intake (ipo.feed.intake:
    motions read, built into pieces), the window (ipo.feed.window: pieces, samples, caps
    and events between intake and emission) and the output side (ipo.feed.emission: the
    period grid, where the machine stands). It plans v^2 over the window and hands each
    result to the one that owns what comes next."""

    def __init__(self, config: MachineConfig, *, method: str | None = None, feed_override: float = 1.0,
                 start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096, corners: CornerRules | None = None):
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
        self._j_max = None  # S-curve mode: the share of each axis jerk the curvature steps' caps get
        self.j_axis = None  # S-curve mode: each axis's jerk limit (with the planner's margin)
        if config.accel_mode == "scurve":
            self.j_axis = np.array([a.max_jerk_mm_s3 for a in config.axes]) * ACCEL_USE
            # the steps of curvature where pieces meet get half of J (ipo.feed.limits); the
            # path's own jerk is checked with the curvature's terms as they are (jerk_plan)
            self._j_max = 0.5 * self.j_axis
        # the corner settings of S-curve mode (arcs no tighter than this; the
        # curvature-continuous corners' limits); a study may pass its own to force arcs
        self.corners = corners or CornerRules(min_blend_radius_mm(self.a_max, self._j_max, self.T),
                                              g2_blend_limits(self.a_max, self._j_max, self.T))
        end_gap_mm = nurbs_end_gap_mm(config)
        self._intake = Intake(method=self.method, end_gap_mm=end_gap_mm, blend_default_mm=config.g64_blend_tol_mm,
                              rapid_mm_s=config.rapid_mm_s, corners=self.corners)
        self._win = Window(partial(sample_caps, v_max=self.v_max, a_max=self.a_max, period_s=self.T,
                                   delta_mm=config.chord_tol_mm, finishing=_finishing_params(config),
                                   j_max=self._j_max), end_gap_mm)
        self._output = PeriodOutput(config, start_mm=start_mm, batch_periods=self.batch_periods)

    def set_feed_override(self, factor: float) -> None:
        """Scale the programmed feeds of the periods not yet emitted (1.0 = 100 %)."""
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"feed override must be a finite factor > 0, got {factor!r}")
        self._override = float(factor)
        self._override_changed = True

    # ---- entity intake -------------------------------------------------------------
    def run(self, entities: Iterable) -> Iterator[PeriodBatch | object]:
        """Period batches and events in order; the machine ends standing still."""
        intake, win = self._intake, self._win
        for e in merge_collinear(entities):  # G64 Q
            tp = type(e)
            if tp is Line or tp is Rapid:  # the bulk of any program: keep this path lean
                if e.start == e.end:
                    continue  # a move to where the machine stands: no motion, no corner
                if win.samples is None and not intake.pending:  # the window's test first: a slot, no call
                    self._check_start(e)
                if intake.add_line(e):
                    self._extend(final=False)
                    yield from self._plan(final=False)
            elif isinstance(e, MOTION_TYPES):
                if win.samples is None and not intake.pending:
                    self._check_start(e)
                if intake.add(e):
                    self._extend(final=False)
                    yield from self._plan(final=False)
            elif isinstance(e, (Spindle, Coolant, Message, Auxiliary)):
                if win.samples is None and not intake.pending:
                    yield e  # standing still: nothing to wait for
                else:
                    self._extend(final=False)
                    win.add_event(intake.event_at_mm(win.s_end_mm), e)
                if isinstance(e, Spindle):
                    intake.spindle(e)
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

    def _extend(self, *, final: bool) -> None:
        """What the intake can build now, into the window."""
        new = self._intake.build(final=final)
        if new is not None:
            self._win.extend(new.pieces, new.drivers)

    def _flush(self) -> Iterator:
        self._extend(final=True)
        if self._win.samples is not None:
            yield from self._plan(final=True)
        yield from self._win.pop_events()

    # ---- look-ahead and emission -----------------------------------------------------
    def _feed_v2(self, n: int) -> np.ndarray:
        """Programmed v^2 at the first n samples, with the feed override (not on rapids)."""
        win = self._win
        pc = win.pieces  # per piece, then to the samples: a window has ~20 samples per piece
        return ((pc.feed_mm_s * np.where(pc.rapid, 1.0, self._override))**2)[win.samples.piece[:n] - win.piece_base]

    def _soft_caps(self) -> tuple[np.ndarray, np.ndarray]:
        win = self._win
        xf = self._feed_v2(len(win.samples))
        hard = win.cap
        prog = xf < hard
        return np.where(prog, xf, hard), np.where(prog, LIMIT_PROGRAMMED, win.reason).astype(np.int8)

    def _plan(self, *, final: bool) -> Iterator:
        if self.j_axis is not None:
            from ipo.feed import scurve   # S-curve mode only: its jerk_* modules, ~5 ms to load, stay out of a trapezoid run

            yield from scurve.run(self, self._win, self._output, final)
            return
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
        sharp corners."""
        win = self._win
        return np.where(win.corner[:n - 1] | win.corner[1:n], CORNER_SHARE, 1.0)

    def _emit(self, c: int, x: np.ndarray, cap: np.ndarray, reason: np.ndarray, *, stop: bool) -> Iterator:
        """The plan x over samples 0..c, refined, to the output side; then drop what it put
        out (the sample it ended on is the new start)."""
        smp = self._win.samples
        ascale = self._ascale(c + 1, cap)
        plateau = np.minimum(self._feed_v2(c + 1), axis_velocity_cap(smp.t[:c + 1], self.v_max))
        s, xs, src = la.refine(smp.s[:c + 1], smp.t[:c + 1], smp.kv[:c + 1], x[:c + 1], cap[:c + 1], plateau,
                               self.a_max, ascale)
        cen = centripetal_binds(smp.s[:c + 1], smp.t[:c + 1], smp.kv[:c + 1], x[:c + 1], self.a_max, ascale)
        reasons = period_reasons(xs, src, cap, reason, cen, LIMIT_CURVATURE, LIMIT_ACCEL)
        prof = Profile(s, xs, src, reasons, smp.s[:c + 1])
        k_stop, used = yield from self._output.emit(prof, self._win, stop=stop,
                                                    replan=lambda: self._override_changed)
        self._win.take_events(used)
        self._win.x0_v2 = float(x[k_stop])
        self._win.drop(k_stop)


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
