"""The workpiece: a Z-map over the stock, lowered by the tool swept between consecutive period positions.

It is a receiver of the drive's rows (Drive(sinks=[...]).write): it owns the heights and the line that
cut each node, and hands back a Surface. Positions arrive in machine coordinates, the drive's controlled
point: the work offset (G54) is taken off, and so is the cutting tool's length (tools.N.length_mm, its
tip below the gauge line the machine positions), so that the stock is cut where the tip actually is,
whatever length offset (G43, G43.1) the program applied. Tool changes (T… M6) reach it through `event`,
in program order.

The rows are kept and handed in batches of HANDOFF_PERIODS to the removal thread, which cuts them in
order while the run goes on (the kernels release the GIL; removal.py answers for a whole batch at once,
so the larger the batch, the fewer times a node is revisited); a tool change hands over what is kept
first, and `surface` hands over the rest and waits for the thread. Batches handed over while the thread
was busy are joined before it cuts them (joined_batches). The heights do not depend on where the batches
end: a node is the float32 rounding of the minimum over every segment, and rounding is monotone. While the run goes on the thread cuts on one core (the run has the other); from the moment
`surface` is called, what is left is cut on every core, from the next chunk of blocks of the batch being
cut (removal.cut asks between chunks). With `teeth` each write is cut at once, period by period
(teeth.py), on the caller's thread.
"""
from __future__ import annotations

import os
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from machine.workpiece.removal import cut, timed_plan
from machine.workpiece.stock import Grid, Stock
from machine.workpiece.teeth import sweep_teeth
from machine.workpiece.tiles import COUNTS, TILE, Batch, ZMap
from machine.workpiece.tool import Cutter, cutter_from_table

# Periods per batch handed to the removal thread (3 MB of positions). Smaller batches revisit nodes more
# often: on finish_g01.nc (a pass is about 1,700 periods, the ball reaches 30 passes) the removal took
# the same CPU time at 65,536 periods as in one batch of the whole program, 1.6x at 16,384.
HANDOFF_PERIODS = 1 << 17


@dataclass(slots=True)
class Surface:
    """The machined heights z_mm[j, i] over x_mm[i], y_mm[j]; line[j, i] the source line whose motion
    cut the node to its height (0: never cut)."""

    x_mm: np.ndarray
    y_mm: np.ndarray
    z_mm: np.ndarray
    line: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def grid_mm(self) -> float:
        return float(self.x_mm[1] - self.x_mm[0]) if len(self.x_mm) > 1 else float(self.meta.get("grid_mm", 0.0))


def available_cpus() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def joined_batches(batches: list[Batch]) -> list[Batch]:
    """The batches in order, each that continues the one before (its first position that one's last, the same
    cutter) joined to it. Fewer batches revisit fewer nodes: on finish_g01.nc the removal thread is still
    cutting the first batch when the run ends, and the second and the rest are then cut as one. The heights
    do not depend on where the batches end (see the module's docstring)."""
    out: list[Batch] = []
    for batch in batches:
        last = out[-1] if out else None
        if (last is None or batch.stamp_first or (batch.core, batch.corner) != (last.core, last.corner)
                or not np.array_equal(batch.pos[0], last.pos[-1])):
            out.append(batch)
            continue
        out[-1] = Batch(np.concatenate((last.pos, batch.pos[1:])), np.concatenate((last.lines, batch.lines)),
                        last.core, last.corner, last.stamp_first)
    return out


class Workpiece:
    """Stock, grid, cutter and the height field; `write(rows)` takes a batch of periods."""

    def __init__(self, stock: Stock, grid: Grid, cutter: Cutter, *, start_mm, offset_mm=(0.0, 0.0, 0.0),
                 tools: dict | None = None, teeth: bool = False, threads: int | None = None,
                 pick_mm: float | None = None):
        self.stock, self.grid, self.cutter = stock, grid, cutter
        self.pick_mm = pick_mm  # the finishing pick feed for this tool, if the machine file gives one
        self.tools = tools or {}
        self.offset_mm = np.asarray(offset_mm, dtype=float)
        top = float(stock.max_mm[2])
        self.z = np.full((grid.ny, grid.nx), top, dtype=np.float32)
        self.line = np.zeros((grid.ny, grid.nx), dtype=np.int32)
        self._tile_max = np.full((-(-grid.ny // TILE), -(-grid.nx // TILE)), top)
        self._last = self.tip(np.asarray(start_mm, dtype=float)[None, :])
        self._stamped = False
        self.teeth = teeth  # cut with the flutes' edges at the rows' spindle angles (tooth-pass marks)
        self._spindle = np.zeros(1)
        self.threads = threads or available_cpus()
        self._kept: list[tuple[np.ndarray, np.ndarray]] = []
        self._kept_periods = 0
        self._worker: ThreadPoolExecutor | None = None
        self._jobs: list[Future] = []
        self._pending: list[Batch] = []  # handed to the removal thread and not yet begun (_cut_pending)
        self._pending_lock = threading.Lock()
        self._finishing = False  # the run has ended: the removal thread may take every core
        # the removal's own time: the hand-offs on the caller's thread, the cuts on the removal thread
        self._caller_wall_s = self._caller_cpu_s = self._cut_wall_s = self._cut_cpu_s = 0.0
        self.wait_s = 0.0  # how long `surface` waited for the removal thread
        self.counts = np.zeros(COUNTS, np.int64)  # see removal.cut
        self.periods = 0

    def tip(self, pos_mm: np.ndarray) -> np.ndarray:
        """The cutting tip in work coordinates for the drive's positions (machine coordinates, gauge line)."""
        return pos_mm - self.offset_mm - np.array([0.0, 0.0, self.cutter.length_mm])

    @property
    def wall_s(self) -> float:
        """The removal's own wall time: its hand-offs and its cuts, wherever they ran."""
        return self._caller_wall_s + self._cut_wall_s

    @property
    def cpu_s(self) -> float:
        """The removal's own CPU time (its threads', not the run's)."""
        return self._caller_cpu_s + self._cut_cpu_s

    @contextmanager
    def _timed(self):
        """Adds the time inside, on the caller's thread, to the removal's own."""
        t0, c0 = time.perf_counter(), time.thread_time()
        try:
            yield
        finally:
            self._caller_wall_s += time.perf_counter() - t0
            self._caller_cpu_s += time.thread_time() - c0

    def write(self, rows: dict) -> None:
        if not len(rows["pos_mm"]):
            return
        with self._timed():
            pos = self.tip(np.asarray(rows["pos_mm"], dtype=float))
            lines = np.asarray(rows["line"], dtype=np.int32)
            self.periods += len(pos)
            if self.teeth:
                self._cut_teeth(pos, lines, np.asarray(rows["spindle_rad"], dtype=float))
                return
            self._kept.append((pos, lines))
            self._kept_periods += len(pos)
            if self._kept_periods >= HANDOFF_PERIODS:
                self._hand_off()

    def _geo(self) -> tuple[float, float, float, float]:
        return self.grid.origin_x, self.grid.origin_y, self.grid.grid_mm, float(self.stock.min_mm[2])

    def _zmap(self) -> ZMap:
        return ZMap(self.z, self.line, self._tile_max, *(float(v) for v in self._geo()))

    def _hand_off(self) -> None:
        """What is kept, with the cutter of now, to the removal thread (which cuts batches in order)."""
        if not self._kept:
            return
        pos = np.concatenate([self._last] + [p for p, _ in self._kept])
        lines = np.concatenate([n for _, n in self._kept])
        self._kept, self._kept_periods = [], 0
        batch = Batch(pos, lines, float(self.cutter.core_mm), float(self.cutter.corner_mm), not self._stamped)
        if self._worker is None:
            self._worker = ThreadPoolExecutor(1, thread_name_prefix="vcnc-removal")
        with self._pending_lock:
            self._pending.append(batch)
        self._jobs.append(self._worker.submit(self._cut_pending))
        self._stamped = True
        self._last = pos[-1:].copy()

    def _cut_pending(self) -> None:
        """On the removal thread: the batches handed over since it began the last, in order, those that continue
        one another with one cutter as one batch (joined_batches)."""
        with self._pending_lock:
            batches, self._pending = self._pending, []
        for batch in joined_batches(batches):
            self._cut(batch)

    def _plan_ahead(self) -> None:
        """When the run has ended: the batches the removal thread has not begun, joined, planned at once on a thread
        of their own (removal.plan needs no heights) beside the batch being cut, then cut in order: the plan of
        what is left does not stand alone on one core while the other waits (on finish_g01.nc about 10 ms)."""
        with self._pending_lock:
            batches, self._pending = joined_batches(self._pending), []
        if not batches:
            return
        planner = ThreadPoolExecutor(1, thread_name_prefix="vcnc-plan")
        zm = self._zmap()
        ready = [(batch, planner.submit(timed_plan, zm, batch)) for batch in batches]
        planner.shutdown(wait=False)
        self._jobs.append(self._worker.submit(self._cut_ready, ready))

    def _cut_ready(self, ready: list[tuple[Batch, Future]]) -> None:
        """On the removal thread: the batches _plan_ahead planned."""
        for batch, planned in ready:
            self._cut(batch, planned)

    def _cut(self, batch: Batch, planned: Future | None = None) -> None:
        """On the removal thread."""
        t0 = time.perf_counter()
        self._cut_cpu_s += cut(self._zmap(), batch, self.counts, self._cut_threads, planned)
        self._cut_wall_s += time.perf_counter() - t0

    def _cut_threads(self) -> int:
        """While the run goes on the removal cuts on one core (the run has another), then on every core."""
        return self.threads if self._finishing else 1

    def _drain(self) -> None:
        """Wait for the removal thread to cut every batch handed to it (its errors are raised here)."""
        t0 = time.perf_counter()
        try:
            for job in self._jobs:
                job.result()
        finally:
            self._jobs = []
            if self._worker is not None:
                self._worker.shutdown()
                self._worker = None
            self.wait_s += time.perf_counter() - t0

    def _cut_teeth(self, pos: np.ndarray, lines: np.ndarray, spindle: np.ndarray) -> None:
        path = np.concatenate((self._last, pos))
        angles = np.concatenate((self._spindle, spindle))
        c = self.cutter
        sweep_teeth(self._zmap(), Batch(path, lines, float(c.core_mm), float(c.corner_mm), not self._stamped),
                    self.counts, angles, int(c.flutes))
        self._stamped = True
        self._last, self._spindle = path[-1:].copy(), angles[-1:].copy()

    @property
    def nodes_evaluated(self) -> int:
        """Envelopes evaluated (bounds and exact ones) so far."""
        return int(self.counts[2])

    @property
    def nodes_lowered(self) -> int:
        return int(self.counts[3])

    def event(self, event) -> None:
        """A tool change (anything with a `tool` number) cuts what is kept with the old cutter, then
        switches to the new one from the tool table (its tip now `length_mm` below the gauge line)."""
        number = getattr(event, "tool", None)
        if number is not None and number != self.cutter.number:
            with self._timed():
                self._hand_off()
            gauge = self._last + np.array([0.0, 0.0, self.cutter.length_mm])
            self.cutter = cutter_from_table(self.tools, number)
            self._last = gauge - np.array([0.0, 0.0, self.cutter.length_mm])

    def warm_up(self) -> None:
        """Load the compiled kernels now, outside the timed removal."""
        zmap = ZMap(np.zeros((1, 1), np.float32), np.zeros((1, 1), np.int32), np.zeros((1, 1)), 0.0, 0.0, 1.0, 0.0)
        batch = Batch(np.zeros((2, 3)), np.zeros(1, np.int32), 0.0, 1.0, False)
        cut(zmap, batch, np.zeros(COUNTS, np.int64))
        if self.teeth:
            sweep_teeth(zmap, batch, np.zeros(COUNTS, np.int64), np.zeros(2), 2)

    def surface(self) -> Surface:
        self._finishing = True
        with self._timed():
            self._hand_off()
            self._plan_ahead()
        self._drain()
        meta = {"grid_mm": self.grid.grid_mm, "stock_min_mm": list(self.stock.min_mm),
                "stock_max_mm": list(self.stock.max_mm), "tool": self.cutter.describe(),
                "tool_shape": self.cutter.shape, "tool_core_mm": self.cutter.core_mm,
                "tool_corner_mm": self.cutter.corner_mm, "tool_length_mm": self.cutter.length_mm,
                "flutes": self.cutter.flutes, "pick_mm": self.pick_mm}
        return Surface(self.grid.x_mm, self.grid.y_mm, self.z.astype(np.float64), self.line.copy(), meta)
