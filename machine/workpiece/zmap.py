"""The workpiece: a Z-map over the stock, lowered by the tool swept between consecutive period positions.

It is a receiver of the drive's rows (Drive(sinks=[...]).write): it owns the heights and the line
that last cut each node, and hands back a Surface. Positions arrive in machine coordinates; the stock
is in work coordinates (G54), so the rows are shifted by that offset once here. Tool changes (T… M6)
reach it through `event`, in program order.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from machine.workpiece.kernels import TILE, sweep
from machine.workpiece.stock import Grid, Stock
from machine.workpiece.tool import Cutter, cutter_from_table


@dataclass(slots=True)
class Surface:
    """The machined heights z_mm[j, i] over x_mm[i], y_mm[j]; line[j, i] the source line whose motion
    last lowered the node (0: never cut)."""

    x_mm: np.ndarray
    y_mm: np.ndarray
    z_mm: np.ndarray
    line: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def grid_mm(self) -> float:
        return float(self.x_mm[1] - self.x_mm[0]) if len(self.x_mm) > 1 else float(self.meta.get("grid_mm", 0.0))


class Workpiece:
    """Stock, grid, cutter and the height field; `write(rows)` cuts one batch of periods."""

    def __init__(self, stock: Stock, grid: Grid, cutter: Cutter, *, start_mm, offset_mm=(0.0, 0.0, 0.0),
                 tools: dict | None = None, teeth: bool = False):
        self.stock, self.grid, self.cutter = stock, grid, cutter
        self.tools = tools or {}
        self.offset_mm = np.asarray(offset_mm, dtype=float)
        top = float(stock.max_mm[2])
        self.z = np.full((grid.ny, grid.nx), top, dtype=np.float32)
        self.line = np.zeros((grid.ny, grid.nx), dtype=np.int32)
        self._tile_max = np.full((-(-grid.ny // TILE), -(-grid.nx // TILE)), top)
        self._last = (np.asarray(start_mm, dtype=float) - self.offset_mm)[None, :]
        self._stamped = False
        self.teeth = teeth  # cut with the flutes' edges at the rows' spindle angles (tooth-pass marks)
        self._spindle = np.zeros(1)
        self.wall_s = 0.0
        self.cpu_s = 0.0
        self.counts = np.zeros(3, np.int64)  # tiles looked at, tiles evaluated, nodes evaluated
        self.periods = 0

    def write(self, rows: dict) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        pos = np.asarray(rows["pos_mm"], dtype=float) - self.offset_mm
        if len(pos):
            path = np.concatenate((self._last, pos))
            spindle = np.concatenate((self._spindle, rows["spindle_rad"])) if self.teeth else self._spindle
            c = self.cutter
            sweep(self.z, self.line, self._tile_max, self.grid.origin_x, self.grid.origin_y,
                                          self.grid.grid_mm, float(self.stock.min_mm[2]), path,
                                          np.asarray(rows["line"], dtype=np.int32), c.core_mm, c.corner_mm,
                                          not self._stamped, self.counts, spindle,
                                          c.flutes if self.teeth else 0)
            self._stamped = True
            self._last = pos[-1:].copy()
            self._spindle = spindle[-1:].copy()
            self.periods += len(pos)
        self.wall_s += time.perf_counter() - t0
        self.cpu_s += time.process_time() - c0

    @property
    def nodes_evaluated(self) -> int:
        return int(self.counts[2])

    def event(self, event) -> None:
        """A tool change (anything with a `tool` number) switches the cutter from the tool table."""
        number = getattr(event, "tool", None)
        if number is not None and number != self.cutter.number:
            self.cutter = cutter_from_table(self.tools, number)

    def warm_up(self) -> None:
        """Load the compiled kernel now, outside the timed removal."""
        sweep(np.zeros((1, 1), np.float32), np.zeros((1, 1), np.int32), np.zeros((1, 1)), 0.0, 0.0, 1.0, 0.0,
              np.zeros((2, 3)), np.zeros(1, np.int32), 0.0, 1.0, False, np.zeros(3, np.int64), np.zeros(2), 0)

    def surface(self) -> Surface:
        meta = {"grid_mm": self.grid.grid_mm, "stock_min_mm": list(self.stock.min_mm),
                "stock_max_mm": list(self.stock.max_mm), "tool": self.cutter.describe(),
                "tool_shape": self.cutter.shape, "tool_core_mm": self.cutter.core_mm,
                "tool_corner_mm": self.cutter.corner_mm, "flutes": self.cutter.flutes}
        return Surface(self.grid.x_mm, self.grid.y_mm, self.z.astype(np.float64), self.line.copy(), meta)
