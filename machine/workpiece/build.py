"""A Workpiece for a checked program: stock from --stock or the machine file, the tool from --tool, the
program's first T… M6 or the finishing section, the grid from --grid-um or the documented rule."""
from __future__ import annotations

import numpy as np

from ipr.entities import MOTION_TYPES, PLANE_AXES, Arc, Line, Nurbs, ToolChange
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


ARC_SAMPLES = 64  # points per arc for its extent (the arc's own extremes lie between them by < 0.12 % of r)


def feed_extent_mm(entities) -> tuple[np.ndarray, np.ndarray] | None:
    """(lowest, highest) corner of the box the feed moves (G1, G2/G3, NURBS) take the controlled point over,
    machine coordinates; None without feed moves. A NURBS curve lies in the hull of its control points, so
    its box is theirs (it may be a little larger than the curve's)."""
    points = []
    for e in entities:
        if isinstance(e, Line):
            points += [e.start, e.end]
        elif isinstance(e, Nurbs):
            points += list(map(tuple, e.points))
        elif isinstance(e, Arc):
            a, b, n = PLANE_AXES[e.plane]
            c, start, end = np.asarray(e.center), np.asarray(e.start), np.asarray(e.end)
            t = np.linspace(0.0, 1.0, ARC_SAMPLES + 1)
            angle = np.arctan2(start[b] - c[b], start[a] - c[a]) + t * e.sweep_rad
            arc = np.empty((len(t), 3))
            arc[:, a], arc[:, b] = c[a] + e.radius_mm * np.cos(angle), c[b] + e.radius_mm * np.sin(angle)
            arc[:, n] = start[n] + t * (end[n] - start[n])
            points += list(map(tuple, arc))
    if not points:
        return None
    pts = np.asarray(points, dtype=float)
    return pts.min(axis=0), pts.max(axis=0)


def stock_hint(program, config, tool: int | None) -> str:
    """Where the program cuts, for the user choosing a stock: the feed moves' tip box in work coordinates
    (G54, the tool's length) and a stock the tool's radius wider, from 1 mm under the lowest tip; its top
    is left to the user (where the material starts: a feed move's highest point may be a plunge's start)."""
    extent = feed_extent_mm(program.entities)
    if extent is None:
        return ""
    try:
        cutter = cutter_from_table(config.tools, initial_tool(program, config, tool)[0])
        radius, length = cutter.radius_mm, cutter.length_mm
    except ToolError:
        radius, length = 0.0, 0.0
    shift = np.asarray(config.work_offsets_mm.get("G54", (0.0, 0.0, 0.0))) + np.array([0.0, 0.0, length])
    lo, hi = extent[0] - shift, extent[1] - shift
    box = (lo[0] - radius, lo[1] - radius, lo[2] - 1.0, hi[0] + radius, hi[1] + radius)
    return (f"; the feed moves take the tool's tip over X{lo[0]:.3f}..{hi[0]:.3f} Y{lo[1]:.3f}..{hi[1]:.3f} "
            f"Z{lo[2]:.3f}..{hi[2]:.3f} (work): a stock the tool's radius ({radius:g} mm) around that is --stock="
            + ",".join(f"{v:.3f}" for v in box) + ",ZMAX with ZMAX the material's top")


def build_workpiece(program, config, start_mm, *, stock_text: str | None = None, tool: int | None = None,
                    grid_um: float | None = None, teeth: bool = False) -> tuple[Workpiece, str]:
    """The workpiece and a one-line description of it; StockError / ToolError name what is wrong."""
    if stock_text is not None:
        stock = Stock.parse(stock_text)
    elif config.stock_mm is not None:
        stock = Stock(*config.stock_mm)
    else:
        raise StockError("no stock: give --stock XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX or a [stock] table in the machine file"
                         + stock_hint(program, config, tool))
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
