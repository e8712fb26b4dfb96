"""The workpiece: a Z-map over the stock, lowered by the tool swept between consecutive period positions.

It is a receiver of the drive's rows (Drive(sinks=[...]).write): it owns the heights and the line that
cut each node, and hands back a Surface. Positions arrive in machine coordinates, the drive's controlled
point: the work offset (G54) is taken off, and so is the cutting tool's length (tools.N.length_mm, its
tip below the gauge line the machine positions), so that the stock is cut where the tip actually is,
whatever length offset (G43, G43.1) the program applied. Tool changes (T… M6) reach it through `event`,
in program order.

The rows are kept and cut in batches of up to BATCH_PERIODS (removal.py answers for a whole batch at
once, so the larger the batch, the fewer times a node is revisited); a tool change and `surface` cut
what is kept first. With `teeth` each write is cut at once, period by period (teeth.py).
"""
from __future__ import annotations

import os
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from machine.workpiece.removal import cut
from machine.workpiece.stock import Grid, Stock
from machine.workpiece.teeth import sweep_teeth
from machine.workpiece.tiles import COUNTS, TILE
from machine.workpiece.tool import Cutter, cutter_from_table

BATCH_PERIODS = 1 << 20  # 24 MB of positions


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
        self.wall_s = 0.0
        self.cpu_s = 0.0
        self.counts = np.zeros(COUNTS, np.int64)  # see removal.cut
        self.periods = 0

    def tip(self, pos_mm: np.ndarray) -> np.ndarray:
        """The cutting tip in work coordinates for the drive's positions (machine coordinates, gauge line)."""
        return pos_mm - self.offset_mm - np.array([0.0, 0.0, self.cutter.length_mm])

    @contextmanager
    def _timed(self):
        """Adds the time inside to the removal's own (wall_s, cpu_s)."""
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.wall_s += time.perf_counter() - t0
            self.cpu_s += time.process_time() - c0

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
            if self._kept_periods >= BATCH_PERIODS:
                self._cut_kept()

    def _geo(self) -> tuple[float, float, float, float]:
        return self.grid.origin_x, self.grid.origin_y, self.grid.grid_mm, float(self.stock.min_mm[2])

    def _cut_kept(self) -> None:
        if not self._kept:
            return
        pos = np.concatenate([self._last] + [p for p, _ in self._kept])
        lines = np.concatenate([n for _, n in self._kept])
        self._kept, self._kept_periods = [], 0
        cut(self.z, self.line, self._tile_max, self._geo(), pos, lines, (self.cutter.core_mm, self.cutter.corner_mm),
            not self._stamped, self.counts, self.threads)
        self._stamped = True
        self._last = pos[-1:].copy()

    def _cut_teeth(self, pos: np.ndarray, lines: np.ndarray, spindle: np.ndarray) -> None:
        path = np.concatenate((self._last, pos))
        angles = np.concatenate((self._spindle, spindle))
        c = self.cutter
        sweep_teeth(self.z, self.line, self._tile_max, *self._geo(), path, lines, c.core_mm, c.corner_mm,
                    not self._stamped, self.counts, angles, c.flutes)
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
                self._cut_kept()
            gauge = self._last + np.array([0.0, 0.0, self.cutter.length_mm])
            self.cutter = cutter_from_table(self.tools, number)
            self._last = gauge - np.array([0.0, 0.0, self.cutter.length_mm])

    def warm_up(self) -> None:
        """Load the compiled kernels now, outside the timed removal."""
        cut(np.zeros((1, 1), np.float32), np.zeros((1, 1), np.int32), np.zeros((1, 1)), (0.0, 0.0, 1.0, 0.0),
            np.zeros((2, 3)), np.zeros(1, np.int32), (0.0, 1.0), False, np.zeros(COUNTS, np.int64))
        if self.teeth:
            sweep_teeth(np.zeros((1, 1), np.float32), np.zeros((1, 1), np.int32), np.zeros((1, 1)), 0.0, 0.0, 1.0,
                        0.0, np.zeros((2, 3)), np.zeros(1, np.int32), 0.0, 1.0, False, np.zeros(COUNTS, np.int64),
                        np.zeros(2), 2)

    def surface(self) -> Surface:
        with self._timed():
            self._cut_kept()
        meta = {"grid_mm": self.grid.grid_mm, "stock_min_mm": list(self.stock.min_mm),
                "stock_max_mm": list(self.stock.max_mm), "tool": self.cutter.describe(),
                "tool_shape": self.cutter.shape, "tool_core_mm": self.cutter.core_mm,
                "tool_corner_mm": self.cutter.corner_mm, "tool_length_mm": self.cutter.length_mm,
                "flutes": self.cutter.flutes, "pick_mm": self.pick_mm}
        return Surface(self.grid.x_mm, self.grid.y_mm, self.z.astype(np.float64), self.line.copy(), meta)
