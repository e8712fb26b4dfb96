"""The stock box and the grid of the Z-map over it.

The grid's spacing, unless given, follows from the tool and the machine's chord tolerance delta: a node
sits at most g/2 across a pass from the lowest line of a ball's (or bull's corner) imprint, where the
imprint is (g/2)^2 / (2 r) higher, so g = sqrt(2 r delta) keeps that sampling error at delta / 4;
with a finishing section for the tool the spacing is also at most a quarter of its pick feed, so a scallop
has at least four nodes. A flat end mill's bottom has no curvature: g = D / 50. The heights at the nodes
are exact (each node holds the exact envelope of every segment that passed over it); the spacing only
decides where the surface is looked at.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from machine.workpiece.tool import Cutter

MIN_GRID_MM = 0.001
MAX_NODES = 60_000_000  # 480 MB of heights and lines
FLAT_SAMPLES = 50


class StockError(ValueError):
    """A stock box or grid that cannot be built; the message names the option or key."""


@dataclass(frozen=True, slots=True)
class Stock:
    min_mm: tuple[float, float, float]
    max_mm: tuple[float, float, float]

    @classmethod
    def parse(cls, text: str) -> "Stock":
        """--stock XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm)."""
        parts = text.split(",")
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise StockError(f"--stock: expected six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX, got {text!r}") from None
        if len(values) != 6 or not all(math.isfinite(v) for v in values):
            raise StockError(f"--stock: expected six finite numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX, got {text!r}")
        stock = cls(tuple(values[:3]), tuple(values[3:]))
        if not all(lo < hi for lo, hi in zip(stock.min_mm, stock.max_mm)):
            raise StockError(f"--stock: each maximum must exceed its minimum, got {text!r}")
        return stock


def default_grid_mm(cutter: Cutter, chord_tol_mm: float, pick_mm: float | None = None) -> float:
    """The documented spacing rule (module docstring), rounded down to whole micrometres."""
    if cutter.corner_mm > 0:
        g = math.sqrt(2.0 * cutter.corner_mm * chord_tol_mm)
    else:
        g = cutter.diameter_mm / FLAT_SAMPLES
    if pick_mm:
        g = min(g, pick_mm / 4.0)
    return max(MIN_GRID_MM, math.floor(g * 1000.0) / 1000.0)


@dataclass(frozen=True, slots=True)
class Grid:
    """Nodes x_i = origin_x + i g (nx), y_j = origin_y + j g (ny), over the stock's XY extent."""

    origin_x: float
    origin_y: float
    grid_mm: float
    nx: int
    ny: int

    @classmethod
    def over(cls, stock: Stock, grid_mm: float) -> "Grid":
        if not grid_mm >= MIN_GRID_MM:
            raise StockError(f"--grid-um: must be at least {MIN_GRID_MM * 1000:g} um, got {grid_mm * 1000:g}")
        nx = int(math.floor((stock.max_mm[0] - stock.min_mm[0]) / grid_mm + 1e-9)) + 1
        ny = int(math.floor((stock.max_mm[1] - stock.min_mm[1]) / grid_mm + 1e-9)) + 1
        if nx * ny > MAX_NODES:
            raise StockError(f"a {grid_mm * 1000:g} um grid over the stock has {nx} x {ny} = {nx * ny:,} nodes, "
                             f"more than {MAX_NODES:,}: use a coarser --grid-um or a smaller --stock")
        return cls(stock.min_mm[0], stock.min_mm[1], grid_mm, nx, ny)

    @property
    def x_mm(self) -> np.ndarray:
        return self.origin_x + self.grid_mm * np.arange(self.nx)

    @property
    def y_mm(self) -> np.ndarray:
        return self.origin_y + self.grid_mm * np.arange(self.ny)
