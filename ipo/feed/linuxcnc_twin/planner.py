"""The LinuxCNC 2.9 twin's entry point: entities in, the period stream LinuxCNC would make.

`plan_periods` has the interface of ipo.feed.planner.plan_periods (PeriodBatch and events),
so every plot, trace and comparison works with it. The pipeline per entity:

1. the canon layer (ipo.feed.linuxcnc_twin.canon) turns a motion into planner moves: naive-CAM
   chains of lines, circles, NURBS as biarcs, the path mode as terminal conditions;
2. the planner queue (ipo.feed.linuxcnc_twin.tp) blends and optimizes each move as it comes;
3. segments no later move can change are packed (columns.pack) and run, one servo period per
   cycle, by the compiled run cycle (cycle.run_cycles), which yields positions, speed, line;
4. positions are quantised to BLU (ipo.interp.reference_word.quantise) into PeriodBatches.

Task, between the interpreter and the planner, waits for the motion queue to empty before
any spindle, coolant, tool, message, dwell, program stop or end, digital output "now" or user
M-code (ipo.feed.linuxcnc_twin.waits): the twin stops there too, stands as long as task
typically takes, then emits the event. It assumes task keeps the queue ahead of the run cycle
(LinuxCNC's queue holds 2000 segments; run_linuxcnc.sh fills it before motion starts).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ipo.config import MachineConfig
from ipo.contracts import LIMIT_DWELL, PeriodBatch
from ipo.errors import START, IpoError
from ipo.feed.linuxcnc_twin.canon import Canon
from ipo.feed.linuxcnc_twin.columns import NF, NI, pack
from ipo.feed.linuxcnc_twin.cycle import Periods, run_cycles
from ipo.feed.linuxcnc_twin.settings import settings_of
from ipo.feed.linuxcnc_twin.tp import TrajectoryPlanner
from ipo.feed.linuxcnc_twin.waits import TaskWaits, stops_motion
from ipo.linuxcnc_ini import LinuxcncSettings
from ipo.interp.reference_word import quantise
from ipr.entities import MOTION_TYPES, Dwell, ProgramEnd

_START_TOL_MM = 1e-6
_CHUNK = 256  # segments packed and run per call while the program is read


class LinuxcncTwin:
    """Canon layer, planner queue and run cycle of one LinuxCNC 2.9 run."""

    def __init__(self, config: MachineConfig, settings: LinuxcncSettings, *, feed_override: float = 1.0,
                 start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096):
        if not (np.isfinite(feed_override) and feed_override > 0):
            raise ValueError(f"feed override must be a finite factor > 0, got {feed_override!r}")
        self.s = settings
        self.T = settings.servo_period_s
        self.blu_mm = config.blu_mm
        self.tp = TrajectoryPlanner(settings)
        start = tuple(float(c) for c in start_mm)
        self.canon = Canon(self.tp, start)
        self.params = np.array([self.T, feed_override, settings.max_feed_override,
                                settings.max_linear_velocity_mm_s, settings.ramp_freq_hz])
        self.pos = np.array(start, dtype=float)
        self.blu = np.rint(self.pos / self.blu_mm).astype(np.int64)
        self.F = np.zeros((0, NF))
        self.I = np.zeros((0, NI), np.int64)
        self.head = 0
        self.batch = int(batch_periods)
        self.inline: list[tuple[int, object]] = []  # (segments queued before it, event)
        self.waits = TaskWaits(settings)
        self.queued = 0  # segments handed to the run cycle so far

    def run(self, entities: Iterable) -> Iterator[PeriodBatch | object]:
        for e in entities:
            if isinstance(e, MOTION_TYPES):
                self._check_start(e)
                self.canon.motion(e)
                yield from self._execute(final=False)
            elif not stops_motion(e):
                self.canon.flush()
                self.inline.append((self.queued + len(self.tp.queue), e))
            else:
                yield from self._drain()
                if not isinstance(e, Dwell):
                    yield e
                if isinstance(e, ProgramEnd):
                    return
                yield from self._stand(self.waits.seconds(e), e.line)
        yield from self._drain()

    def _check_start(self, e) -> None:
        here = self.canon.chain[-1][0] if self.canon.chain else self.canon.end_point
        if max(abs(a - b) for a, b in zip(e.start, here)) > _START_TOL_MM:
            raise IpoError(START, f"motion starts at {list(e.start)} but the machine stands at {list(here)}", e.line)

    def _drain(self) -> Iterator:
        """Everything queued runs to a stop (task waits for the queue to empty)."""
        self.canon.flush()
        yield from self._execute(final=True)

    def _execute(self, *, final: bool) -> Iterator:
        n = len(self.tp.queue) if final else self.tp.ready()
        if not final and n < _CHUNK:
            return
        if n:
            F, I = pack(self.tp.take(n), queue_start=self.head >= len(self.F))
            self.F = np.concatenate([self.F[self.head:], F])
            self.I = np.concatenate([self.I[self.head:], I])
            self.head = 0
            self.queued += n
        base = self.queued - len(self.F)  # segment number of row 0
        while True:
            upto = len(self.F)
            if self.inline:
                upto = min(upto, self.inline[0][0] - base)
            out = Periods(np.empty((self.batch, 3)), np.empty(self.batch), np.empty(self.batch, np.int32),
                          np.empty(self.batch, np.int8))
            k, self.head = run_cycles(self.F, self.I, self.head, upto, final, self.params, self.pos, out)
            if k:
                yield self._batch(out.pos[:k], out.vel[:k], out.reason[:k], out.line[:k])
            while self.inline and self.inline[0][0] - base <= self.head:
                yield self.inline.pop(0)[1]
            if k < self.batch:
                return

    def _batch(self, pos, vel, reason, line) -> PeriodBatch:
        inc, end = quantise(pos, self.blu_mm, self.blu)
        qpos = (self.blu + np.cumsum(inc, axis=0)) * self.blu_mm
        self.blu = end
        return PeriodBatch(qpos, inc, vel.copy(), reason.copy(), line.copy())

    def _stand(self, seconds: float, line: int) -> Iterator[PeriodBatch]:
        n = int(round(seconds / self.T))
        while n > 0:
            k = min(n, self.batch)
            qpos = np.repeat((self.blu * self.blu_mm)[None, :], k, axis=0)
            yield PeriodBatch(qpos, np.zeros((k, 3), np.int64), np.zeros(k), np.full(k, LIMIT_DWELL, np.int8),
                              np.full(k, line, np.int32))
            n -= k


def plan_periods(entities: Iterable, config: MachineConfig, *, method: str | None = None,
                 feed_override: float = 1.0, start_mm=(0.0, 0.0, 0.0), batch_periods: int = 4096,
                 settings: LinuxcncSettings | None = None) -> Iterator[PeriodBatch | object]:
    """Period batches interleaved with the non-motion events, as LinuxCNC 2.9 would run them
    (`method` is vcnc's NURBS interpolator: LinuxCNC runs NURBS as biarcs, so it is unused);
    `settings`: LinuxCNC's (default: the machine's, ipo.feed.linuxcnc_twin.settings)."""
    return LinuxcncTwin(config, settings or settings_of(config), feed_override=feed_override, start_mm=start_mm,
                        batch_periods=batch_periods).run(entities)
