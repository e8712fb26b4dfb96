"""A Workpiece for a checked program: stock from --stock or the machine file, the tool from --tool, the
program's first T… M6 or the finishing section, the grid from --grid-um or the documented rule."""
from __future__ import annotations

import numpy as np

from ipr.entities import MOTION_TYPES, ToolChange
from machine.workpiece.stock import Grid, Stock, StockError, default_grid_mm
from machine.workpiece.tool import ToolError, cutter_from_table
from machine.workpiece.zmap import Workpiece


def initial_tool(program, config, tool: int | None) -> tuple[int, str]:
    """The tool cutting at the start and where it comes from (said to the user)."""
    if tool is not None:
        return tool, "--tool"
    for e in program.entities:
        if isinstance(e, ToolChange):
            return e.tool, f"T{e.tool} M6 at line {e.line}"
        if isinstance(e, MOTION_TYPES):
            break
    if config.finishing is not None:
        return config.finishing.tool, "the machine file's [finishing] tool"
    raise ToolError("no tool is selected before the first motion: add T… M6 to the program or give --tool N")


def build_workpiece(program, config, start_mm, *, stock_text: str | None = None, tool: int | None = None,
                    grid_um: float | None = None, teeth: bool = False) -> tuple[Workpiece, str]:
    """The workpiece and a one-line description of it; StockError / ToolError name what is wrong."""
    if stock_text is not None:
        stock = Stock.parse(stock_text)
    elif config.stock_mm is not None:
        stock = Stock(*config.stock_mm)
    else:
        raise StockError("no stock: give --stock XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX or a [stock] table in the machine file")
    number, source = initial_tool(program, config, tool)
    cutter = cutter_from_table(config.tools, number)
    fin = config.finishing
    pick = fin.pick_feed_mm if fin is not None and fin.tool == number else None
    grid_mm = grid_um / 1000.0 if grid_um is not None else default_grid_mm(cutter, config.chord_tol_mm, pick)
    grid = Grid.over(stock, grid_mm)
    offset = config.work_offsets_mm.get("G54", (0.0, 0.0, 0.0))
    wp = Workpiece(stock, grid, cutter, start_mm=start_mm, offset_mm=offset, tools=config.tools, teeth=teeth,
                   pick_mm=pick)
    text = (f"workpiece: {cutter.describe()} ({source}), grid {grid_mm * 1000:g} um, {grid.nx} x {grid.ny} nodes")
    return wp, text + start_inside(wp.tip(np.asarray(start_mm, dtype=float)), stock)


def start_inside(tip_mm, stock: Stock) -> str:
    """A warning when the tool's tip starts inside the stock (the start position and the tool's length put it
    there): the first motion cuts from that point, as it would crash on the machine."""
    inside = all(lo <= v <= hi for v, lo, hi in zip(tip_mm[:2], stock.min_mm[:2], stock.max_mm[:2]))
    if not (inside and tip_mm[2] < stock.max_mm[2]):
        return ""
    return (f"\nwarning: the tool's tip starts {stock.max_mm[2] - tip_mm[2]:.3f} mm below the stock's top, at "
            f"X{tip_mm[0]:.3f} Y{tip_mm[1]:.3f} Z{tip_mm[2]:.3f} (work): the first motion cuts from there; "
            f"check the stock, the work offset and the tool's length")
