"""`vcnc run … --stock/--tool/--grid-um/--surface`: the workpiece's part of the run command."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from machine.workpiece.stock import Stock, StockError
from machine.workpiece.tool import ToolError


def check_stock_and_grid(stock_text: str | None, grid_um: float | None) -> None:
    """--stock and --grid-um as click errors, before anything runs."""
    if stock_text is not None:
        try:
            Stock.parse(stock_text)
        except StockError as err:
            raise click.BadParameter(str(err), param_hint="--stock") from None
    if grid_um is not None and not grid_um > 0:
        raise click.BadParameter(f"must be > 0, got {grid_um}", param_hint="--grid-um")


def check_surface_outputs(surface_files, stock_text, tool, grid_um, config, teeth=False) -> bool:
    """Before anything runs (the output paths are checked by their option type): the workpiece options;
    True when the run cuts a workpiece."""
    check_stock_and_grid(stock_text, grid_um)
    wanted = bool(surface_files) or stock_text is not None
    if not wanted and (tool is not None or grid_um is not None or teeth):
        raise click.UsageError("--tool, --grid-um and --teeth set up the workpiece: add --surface (and --stock)")
    return wanted


def start_workpiece(program, config, stock_text, tool, grid_um, teeth=False):
    from machine.controller import start_position
    from machine.workpiece.build import build_workpiece

    try:
        workpiece, text = build_workpiece(program, config, start_position(program), stock_text=stock_text,
                                          tool=tool, grid_um=grid_um, teeth=teeth)
    except (StockError, ToolError) as err:
        click.echo(f"{program.file}: not run: {err}; no axis moved", err=True)
        sys.exit(2)
    click.echo(text, err=True)
    workpiece.warm_up()
    return workpiece


def finish_workpiece(workpiece, result, surface_files):
    """Report the removal's cost, write the surface files; the surface, for the run's report."""
    from machine.workpiece.surface_file import save_npz, save_stl

    surface = workpiece.surface()
    click.echo(f"workpiece: removal {workpiece.wall_s:.3f} s (CPU {workpiece.cpu_s:.3f} s) for a run of "
               f"{result.wall_s:.3f} s ({workpiece.wall_s / max(result.wall_s, 1e-9):.2f}x), ready "
               f"{workpiece.wait_s:.3f} s after the run, {workpiece.nodes_lowered:,} nodes cut "
               f"({workpiece.nodes_lowered / max(workpiece.wall_s, 1e-9):.3g}/s), "
               f"{workpiece.nodes_evaluated:,} envelopes evaluated", err=True)
    for path in surface_files:
        suffix = Path(path).suffix.lower()
        if suffix == ".npz":
            save_npz(surface, path)
        elif suffix == ".stl":
            save_stl(surface, path)
        else:
            from machine.workpiece.plot import plot_surface

            plot_surface(surface, path, title=f"vcnc run {result.file}")
        click.echo(f"surface written to {path}", err=True)
    return surface
