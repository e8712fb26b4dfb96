"""The grbl twin's entry point: the board's segments sampled at the machine's period.

`plan_periods` has the interface of ipo.feed.planner.plan_periods and yields the same
stream: PeriodBatch runs (positions quantised to BLU, increments, path speed, limit reason,
source line) and the program's events where grbl carries them out. Inside a segment grbl
steps at one rate, so a period's position is interpolated linearly in time within the
segment it ends in; where no segment runs the machine stands (a dwell, a spindle change, a
starved planner: LIMIT_DWELL).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ipo.config import MachineConfig
from ipo.contracts import LIMIT_ACCEL, LIMIT_AXIS, LIMIT_DWELL, LIMIT_PROGRAMMED, PeriodBatch
from ipo.feed.grbl_twin.board import Board
from ipo.feed.grbl_twin.stepper import F_CPU_HZ, RAMP_CRUISE, Segment
from ipo.feed.grbl_twin.wire import WireLine, from_entities
from ipo.grbl_settings import GrblSettings, from_machine
from ipo.interp.reference_word import quantise
from ipr.entities import ProgramEnd


def settings_of(config: MachineConfig) -> GrblSettings:
    """The `$$` the twin runs with: the machine file's [grbl] settings, else from its axes."""
    return config.grbl_settings or from_machine(config.axes, config.blu_mm)


def plan_periods(entities: Iterable, config: MachineConfig, *, method: str | None = None,
                 feed_override: float = 1.0, start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096,
                 wire: Iterable[WireLine] | None = None, answer_s: float | None = None
                 ) -> Iterator[PeriodBatch | object]:
    """Period batches and events of the program as a grbl 1.1 board runs it. `wire`: the
    lines the grbl link sends for these entities (machine.grbl), else made from the entities
    with no serial link. `method` (vcnc's NURBS interpolator) has no meaning for grbl."""
    if not (np.isfinite(feed_override) and feed_override > 0):
        raise ValueError(f"feed override must be a finite factor > 0, got {feed_override!r}")
    settings = settings_of(config)
    board = Board(settings, start_mm=start_mm, baud=config.grbl_baud, feed_override=feed_override,
                  answer_s=answer_s)
    lines = from_entities(entities) if wire is None else wire
    return _Sampler(config, settings, start_mm, batch_periods, feed_override).run(board.run(lines))


class _Sampler:
    """Segments and stands on grbl's clock -> periods of the machine's period."""

    def __init__(self, config: MachineConfig, settings: GrblSettings, start_mm, batch_periods: int,
                 feed_override: float):
        self.T = config.period_s
        self.blu_mm = config.blu_mm
        self.batch = batch_periods
        self.per_step_mm = 1.0 / np.asarray(settings.steps_per_mm, float)
        self.override = feed_override
        self.k = 1  # the next period ends at k * T
        self.pos = np.asarray(start_mm, float)  # the commanded position at the last period's end
        self.blu = np.rint(self.pos / self.blu_mm).astype(np.int64)
        self.line = 0
        self.segs: list = []  # (t0, t1, p0, p1, line, reason) not yet sampled

    def run(self, records: Iterator[tuple]) -> Iterator[PeriodBatch | object]:
        t_end = 0.0
        entity = None
        for rec in records:
            if rec[0] == "segment":
                _, t0, seg, t1 = rec
                self.segs.append((t0, t1, np.multiply(seg.from_steps, self.per_step_mm),
                                  np.multiply(seg.to_steps, self.per_step_mm), seg.line, _reason(seg)))
                t_end = t1
                if (t1 - self.k * self.T) >= self.batch * self.T:
                    yield from self._periods(t1, LIMIT_DWELL)
            elif rec[0] == "stand":
                _, t_from, t_to, line = rec
                yield from self._periods(t_from, LIMIT_DWELL)
                self.line = line
                yield from self._periods(t_to, LIMIT_DWELL)
                t_end = max(t_end, t_to)
            else:
                _, t, entity, moving = rec
                if isinstance(entity, ProgramEnd):
                    break
                yield from self._periods(t_end if moving else t, LIMIT_DWELL)
                yield entity
        if t_end > 0:  # the last period ends at or after the last motion
            yield from self._periods(max(t_end, (self.k - 1) * self.T) + self.T * (1 - 1e-9), LIMIT_DWELL)
        if isinstance(entity, ProgramEnd):
            yield entity

    def _periods(self, t_limit: float, stand_reason: int) -> Iterator[PeriodBatch]:
        """Every period ending by t_limit, from the segments held (standing outside them)."""
        n = int(np.floor(t_limit / self.T + 1e-9)) - self.k + 1
        if n <= 0:
            return
        times = (self.k + np.arange(n)) * self.T
        self.k += n
        if self.segs:
            t0, t1, p0, p1, line, reason = (np.asarray(c) for c in zip(*self.segs))
            last = int(np.searchsorted(t1, t_limit, side="right"))  # segments wholly done by t_limit
            i = np.searchsorted(t1, times, side="left")
            inside = i < len(t1)
            j = np.minimum(i, len(t1) - 1)
            frac = np.clip((times - t0[j]) / np.maximum(t1[j] - t0[j], 1e-300), 0.0, 1.0)
            moving = inside & (times > t0[j])
            pos = np.where(inside[:, None], p0[j] + frac[:, None] * (p1[j] - p0[j]), p1[-1][None, :])
            lim = np.where(moving, reason[j], stand_reason).astype(np.int8)
            lines = np.where(inside, line[j], line[-1]).astype(np.int32)
            self.line = int(line[min(last, len(t1)) - 1]) if last else self.line
            del self.segs[:last]
        else:
            pos = np.repeat(self.pos[None, :], n, axis=0)
            lim = np.full(n, stand_reason, np.int8)
            lines = np.full(n, self.line, np.int32)
        feed = np.linalg.norm(np.diff(pos, axis=0, prepend=self.pos[None, :]), axis=1) / self.T
        inc, end = quantise(pos, self.blu_mm, self.blu)
        qpos = (self.blu + np.cumsum(inc, axis=0)) * self.blu_mm
        self.blu, self.pos = end, pos[-1].copy()
        for a in range(0, n, self.batch):
            b = slice(a, a + self.batch)
            yield PeriodBatch(qpos[b], inc[b], feed[b], lim[b], lines[b])


def _reason(seg: Segment) -> int:
    if seg.ramp != RAMP_CRUISE:
        return LIMIT_ACCEL
    return LIMIT_AXIS if seg.axis_limited else LIMIT_PROGRAMMED


def motion_span(lines: Iterable[WireLine], settings: GrblSettings, *, start_mm=(0.0, 0.0, 0.0),
                baud: float | None = None, answer_s: float | None = None) -> tuple[float, float]:
    """(first step, last step) of the lines on grbl's clock, in seconds from the first byte sent,
    as grbl's position counter (sys_position, which grbl-sim logs) changes. The step interrupt's
    Bresenham counters start half full, so the longest axis steps at half-step points of its
    progress: the first step half a step into the motion, the last half a step before its end,
    on the grid of the interrupt (2**level runs per step under AMASS)."""
    first = last = None
    for rec in Board(settings, start_mm=start_mm, baud=baud, answer_s=answer_s).run(lines):
        if rec[0] == "segment":
            seg = rec[2]
            half = (1 << seg.amass_level) // 2  # interrupt runs in half a step
            if first is None:
                first = rec[1] + half * seg.isr_ticks / F_CPU_HZ
            last = rec[3] - max(half, 1) * seg.isr_ticks / F_CPU_HZ
    return (0.0, 0.0) if first is None else (first, last)
