"""`vcnc compare A.nc B.nc [--machine M.toml] [--planner P [--planner Q]] [--plot OUT.png] [--json]`:
G01 against NURBS, or one program on two controllers.

Runs both programs through the virtual controller and prints them side by side (002
Table 1); one --planner runs both on that planner, two run A on the first and B on the
second (`vcnc compare A.nc A.nc --planner grbl --planner vcnc`: the same program as a grbl
board and as vcnc would run it). The table shows: blocks, bytes, machining time, mean and minimum feed, feed
fluctuation, slow-downs below 50 % of F, the largest distance between the two
paths both ways, the largest realised chord error, and, where the machine file has
a finishing section, 002's feed-direction roughness R_max (max, mean) of the cut.

Feed figures cover the cutting periods (feed moves, not rapids, not standing still);
the minimum leaves out the first and last millimetre of cutting (the start-up and
the final stop). The path distance is measured from the commanded position of every
period to the other path's polyline through its periods, exactly (machine.path_distance).
"""
from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path

import click
import numpy as np

from ipo.config import PLANNERS
from machine.commands import INPUT_FILE, OutputPath, apply_planner, linuxcnc_ini_option, load_machine

ROWS = [("planner", "planner", "{}"), ("blocks", "blocks", "{:d}"), ("bytes", "bytes", "{:d}"), ("machining time", "time_s", "{:.2f} s"),
        ("mean feed", "mean_feed_mm_min", "{:.0f} mm/min"), ("min feed", "min_feed_mm_min", "{:.0f} mm/min"),
        ("feed fluctuation (std/mean)", "feed_fluctuation_pct", "{:.2f} %"),
        ("slow-downs below 50 % of F", "slowdowns", "{:d}"),
        ("largest distance to the other path", "path_distance_um", "{:.3f} um"),
        ("max realised chord error", "max_chord_error_um", "{:.3f} um"),
        ("roughness R_max max", "rmax_max_um", "{:.3f} um"), ("roughness R_max mean", "rmax_mean_um", "{:.3f} um")]
SLOW_FRACTION = 0.5
MIN_FEED_SKIP_MM = 1.0
DETAIL_MM = 250.0  # the zoomed part of the plot
_NOT_FIGURES = ("trace", "feed_lines", "rpm", "program", "summary", "deviation_mm", "surface")  # a run's non-figures
TANGENT_PERIODS = 5  # either side of a period, for the slope of the roughness model


def _run(path: Path, config, cut: dict | None = None):
    from ipr.entities import Arc, Line, Nurbs, Spindle
    from machine.controller import Controller
    from ipo.fit.convert import count_blocks
    from machine.trace import MemoryTrace

    ctl = Controller(config)
    sink = MemoryTrace(ctl.limits.meta())
    ctl.sinks = [sink]
    program = ctl.check(path)
    workpiece = None
    if cut is not None:
        from machine.controller import start_position
        from machine.workpiece.build import build_workpiece

        workpiece, text = build_workpiece(program, config, start_position(program), **cut)
        warning = text.partition("\n")[2]  # the tip starting inside the stock, as `vcnc run` says it
        if warning:
            click.echo(f"{path}: {warning}", err=True)
        ctl.sinks.append(workpiece)
        ctl.on_event = workpiece.event
    result = ctl.run(program)
    if result.state != "completed":
        raise click.ClickException(f"{path}: the run ended {result.state}: {result.fault or ''}")
    if result.periods == 0:
        raise click.ClickException(f"{path}: the program commands no motion; nothing moved, nothing to compare")
    trace = sink.close()
    feed_lines = {e.line: e.feed_mm_s for e in program.entities if isinstance(e, (Line, Arc, Nurbs))}
    rpm = max((e.rpm for e in program.entities if isinstance(e, Spindle) and e.direction), default=0.0)
    text = path.read_bytes()
    return {"planner": config.planner, "blocks": count_blocks(text.decode("utf-8", "replace")), "bytes": len(text),
            "time_s": float(result.cycle_time_s), "max_chord_error_um": float(result.max_chord_error_um),
            "trace": trace, "feed_lines": feed_lines, "rpm": rpm, "program": program, "summary": result.summary(),
            "surface": None if workpiece is None else workpiece.surface()}


def _cut_periods(run: dict):
    """Indices of cutting periods, the planned path speed (mm/s: the commanded positions move in
    whole BLU, too coarse to differentiate per period), the programmed F and each period's step."""
    tr = run["trace"]
    pos = tr["pos_mm"]
    step = np.linalg.norm(np.diff(np.vstack([pos[:1], pos]), axis=0), axis=1)
    feed_of_line = run["feed_lines"]
    lines, per_period = np.unique(tr["line"], return_inverse=True)
    prog = np.array([feed_of_line.get(int(n), np.nan) for n in lines])[per_period]
    speed = np.asarray(tr["feed_mm_s"], dtype=float)
    cut = np.isfinite(prog) & (speed > 0)
    return np.flatnonzero(cut), speed, prog, step


def _feed_figures(run: dict) -> dict:
    idx, speed, prog, step = _cut_periods(run)
    if len(idx) == 0:
        raise click.ClickException("the program has no feed moves to compare")
    s_cut = np.cumsum(step[idx])
    inner = idx[(s_cut > MIN_FEED_SKIP_MM) & (s_cut < s_cut[-1] - MIN_FEED_SKIP_MM)]
    v = speed[idx]
    slow = speed[idx] < SLOW_FRACTION * prog[idx]
    contiguous = np.diff(idx) == 1
    episodes = int(slow[0]) + int(np.sum(slow[1:] & ~(slow[:-1] & contiguous)))
    return {"mean_feed_mm_min": float(v.mean() * 60), "feed_fluctuation_pct": float(v.std() / v.mean() * 100),
            "min_feed_mm_min": float(speed[inner].min() * 60) if len(inner) else float(v.min() * 60),
            "slowdowns": episodes}


def _roughness(run: dict, config) -> dict:
    from ipo.roughness import inclination_rad, rmax_mm

    fin = config.finishing
    if fin is None:
        return {"rmax_max_um": None, "rmax_mean_um": None}
    tool = config.tools[fin.tool]
    r_mm, flutes = tool.ball_radius_mm, tool.flutes
    if not run["rpm"] > 0:
        raise click.ClickException("roughness needs the spindle speed: the program sets no S with M3/M4")
    idx, speed, _, _ = _cut_periods(run)
    pos = run["trace"]["pos_mm"]
    # a chord over a few periods: one period's step is a few BLU in Z, too coarse for the slope
    chord = pos[np.minimum(idx + TANGENT_PERIODS, len(pos) - 1)] - pos[np.maximum(idx - TANGENT_PERIODS, 0)]
    length = np.linalg.norm(chord, axis=1)
    moved = np.flatnonzero(length > 0)
    if len(moved) == 0:
        raise click.ClickException("the cut moves less than a BLU: no slope to evaluate the roughness at")
    # a crawl can stay within one BLU over the chord's periods: its slope is its nearest measured one
    near = moved[np.clip(np.searchsorted(moved, np.arange(len(length))), 0, len(moved) - 1)]
    tangent = chord[near] / length[near][:, None]
    f_i = speed[idx] * 60.0 / (flutes * run["rpm"])  # feed per tooth, mm
    r = rmax_mm(r_mm, f_i, fin.pick_feed_mm, inclination_rad(tangent))
    return {"rmax_max_um": float(r.max() * 1e3), "rmax_mean_um": float(r.mean() * 1e3)}


def compare_programs(path_a, path_b, machine=None, cut: dict | None = None, configs=None) -> dict:
    """Both programs' figures, keyed "a" and "b" (plus "files"); with `cut` (build_workpiece's stock_text,
    tool, grid_um) both cut a workpiece and "surfaces" holds the machined surfaces' figures. `configs`:
    the machine configuration of each run (default: the machine file's, for both)."""
    from ipo.config import default_config, load_config
    from machine.path_distance import polyline_distances_mm

    if configs is None:
        config = default_config() if machine is None else load_config(machine)
        configs = (config, config)
    out = {"files": [str(path_a), str(path_b)], "machine": str(machine) if machine else "(default)"}
    runs = {}
    for key, path, config in (("a", Path(path_a), configs[0]), ("b", Path(path_b), configs[1])):
        run = _run(path, config, cut)
        runs[key] = run
        figs = {k: v for k, v in run.items() if k not in _NOT_FIGURES}
        figs.update(_feed_figures(run))
        figs.update(_roughness(run, config))
        out[key] = figs
    pa, pb = runs["a"]["trace"]["pos_mm"], runs["b"]["trace"]["pos_mm"]
    runs["a"]["deviation_mm"] = polyline_distances_mm(pa, pb)
    out["a"]["path_distance_um"] = float(runs["a"]["deviation_mm"].max() * 1e3)
    out["b"]["path_distance_um"] = float(polyline_distances_mm(pb, pa).max() * 1e3)
    if cut is not None:
        from machine.workpiece.pair import compare_surfaces

        out["surfaces"] = compare_surfaces(runs["a"]["surface"], runs["b"]["surface"])
    out["_runs"] = runs
    return out


@contextmanager
def reported(machine):
    """A comparison's errors that the user can fix (a program refused, a bad stock, tool or machine
    file) as click errors, said without a traceback."""
    from ipo.config import ConfigError
    from machine.controller import ProgramRejected
    from machine.workpiece.stock import StockError
    from machine.workpiece.tool import ToolError

    try:
        yield
    except (StockError, ToolError) as err:
        raise click.ClickException(str(err)) from None
    except ProgramRejected as err:
        raise click.ClickException(f"program rejected:\n{err}") from None
    except ConfigError as err:
        raise click.ClickException(f"machine file {machine}: {err}") from None


def format_table(res: dict) -> str:
    a, b = res["a"], res["b"]
    name_a, name_b = (Path(f).name for f in res["files"])
    w = max(len(name_a), len(name_b), 16)
    lines = [f"{'':36s} {name_a:>{w}s} {name_b:>{w}s}"]
    for label, key, fmt in ROWS:
        cells = ["-" if x[key] is None else fmt.format(x[key]) for x in (a, b)]
        lines.append(f"{label:36s} {cells[0]:>{w}s} {cells[1]:>{w}s}")
    return "\n".join(lines)


def _plot(res: dict, out: str) -> None:
    """The paths and the feeds, whole (top) and over the first DETAIL_MM of cut (bottom): a raster
    program of a few hundred passes is a filled rectangle at full scale."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from machine.plot import envelope_line

    fig, ((ax_path, ax_feed), (ax_near, ax_near_feed)) = plt.subplots(2, 2, figsize=(14, 10))
    for key, style in (("a", "-"), ("b", "--")):
        run = res["_runs"][key]
        name = Path(res["files"][key == "b"]).name
        pos = run["trace"]["pos_mm"]
        # the true XY view: X across, Y up, one scale (a circle is a circle, not its mirror image)
        ax_path.plot(pos[:, 0], pos[:, 1], style, lw=0.6, label=name)
        idx, speed, _, step = _cut_periods(run)
        s = np.cumsum(step)
        ax_feed.plot(*envelope_line(s[idx], speed[idx] * 60), style, lw=0.6, label=name)
        near = idx[s[idx] <= s[idx[0]] + DETAIL_MM]
        side = 2 if np.ptp(pos[near, 2]) > 0 else 1
        ax_near.plot(pos[near, 0], pos[near, side], style, lw=0.8, label=name)
        ax_near.set_ylabel("XYZ"[side] + " mm")
        ax_near_feed.plot(*envelope_line(s[near], speed[near] * 60), style, lw=0.8, label=name)
    ax_path.set_xlabel("X mm")
    ax_path.set_ylabel("Y mm")
    ax_near.set_xlabel("X mm")
    ax_path.set_title("paths (commanded positions)")
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_near.set_aspect("equal", adjustable="datalim")
    ax_feed.set_title("feed against distance (cutting periods; min and max per column)")
    ax_near.set_title(f"the first {DETAIL_MM:g} mm of cut")
    ax_near_feed.set_title(f"feed over the first {DETAIL_MM:g} mm of cut")
    for ax in (ax_feed, ax_near_feed):
        ax.set_xlabel("distance along the path, mm")
        ax.set_ylabel("feed, mm/min")
    for ax in (ax_path, ax_feed, ax_near, ax_near_feed):
        ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


@click.command("compare")
@click.argument("a", type=INPUT_FILE)
@click.argument("b", type=INPUT_FILE)
@click.option("--machine", type=INPUT_FILE, default=None,
              help="Machine file (TOML); the built-in default if omitted.")
@click.option("--plot", "plot_out", type=OutputPath((".png",)), default=None,
              help="Write a PNG: the two paths overlaid and their feed against distance.")
@click.option("--report", "report_out", type=OutputPath((".html", ".htm")), default=None,
              help="Write an interactive one-file HTML report: both runs aligned by distance, their differences.")
@click.option("--stock", "stock_text", help="Cut a virtual workpiece with both: XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm).")
@click.option("--tool", type=int, help="The workpiece's tool (default: the program's T… M6, else [finishing]).")
@click.option("--grid-um", type=float, help="Z-map spacing in um (default: from the tool and the chord tolerance).")
@click.option("--surface-plot", "surface_plot", type=OutputPath((".png",)), default=None,
              help="With --stock: both machined surfaces side by side and their difference.")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as JSON.")
@click.option("--planner", "planners", multiple=True, type=click.Choice(list(PLANNERS)),
              help="Whose planning runs the programs: once for both, twice for A then B (default: the machine "
                   "file's `planner`).")
@click.option("--grbl-settings", "grbl_settings", type=INPUT_FILE,
              help="grbl's `$$` printout for the grbl twin (default: the machine file's [grbl] settings).")
@linuxcnc_ini_option
def command(a: str, b: str, machine: str | None, plot_out: str | None, report_out: str | None,
            stock_text: str | None, tool: int | None, grid_um: float | None, surface_plot: str | None,
            as_json: bool, planners: tuple[str, ...], grbl_settings: str | None, linuxcnc_ini: str | None) -> None:
    """Run two programs (or one on two controllers) and compare them (002 Table 1)."""
    from machine.workpiece.pair import cut_options

    if len(planners) > 2:
        raise click.BadParameter("give it once (both runs) or twice (A, then B)", param_hint="--planner")
    cut = cut_options(stock_text, tool, grid_um, surface_plot)
    config = load_machine(machine)
    configs = [apply_planner(config, p, grbl_settings, linuxcnc_ini)
               for p in (planners * 2 if len(planners) == 1 else planners or (None, None))]
    with reported(machine):
        res = compare_programs(a, b, machine, cut, configs)
    if plot_out:
        _plot(res, plot_out)
    if report_out:
        from machine.report.build import compare_report, machine_info

        table = [[label] + ["-" if x[key] is None else fmt.format(x[key]) for x in (res["a"], res["b"])]
                 for label, key, fmt in ROWS]
        compare_report(report_out, res["_runs"], res["files"], table, machine_info(machine))
    if surface_plot:
        from machine.workpiece.pair import plot_pair

        plot_pair(res["_runs"]["a"]["surface"], res["_runs"]["b"]["surface"], surface_plot, res["files"])
    if as_json:
        click.echo(json.dumps({k: v for k, v in res.items() if k != "_runs"}, indent=1))
    else:
        click.echo(format_table(res))
        if "surfaces" in res:
            from machine.workpiece.pair import format_surfaces

            click.echo(format_surfaces(res["surfaces"], res["files"]))
        if surface_plot:
            click.echo(f"surface plot: {surface_plot}")
        if plot_out:
            click.echo(f"plot: {plot_out}")
        if report_out:
            click.echo(f"report: {report_out}")
