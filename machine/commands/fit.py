"""`vcnc fit IN.nc -o OUT.nc --tol-mm T [--degree 3] [--corner-deg 30] [--jobs N] [--no-arcs] [--compare]`.

Fits every chain of G1/G2/G3 moves (ipo.fit.chains: corners do not end a chain; sharp
ones stay sharp inside the curve) with 001's rational B-spline approximation, the
fewest written blocks within T of the path both ways, and writes the program with
Fanuc G06.2 groups, and runs of G1 moves that lie within T of one line or one arc in a
principal plane as one G1 or G2/G3 block (ipo.fit.arcs) where that costs fewer blocks;
everything else is copied. Each group is tabled as the controller's
check tables it (controller_check); one it would refuse stays as the moves it replaces.
Prints chains, corners, blocks and bytes before/after, the largest deviation and the fit
time; with --compare also what the user gains: both programs run on the machine file's
planner (the table of `vcnc compare IN OUT`), then the machining time and feed fluctuation on
each planner, vcnc's and the grbl and LinuxCNC twins (`vcnc compare --planner P`; a twin that
cannot run a program says why: LinuxCNC 2.9 runs only planar G5.2 curves); with --stock also
both machined surfaces and their difference (`vcnc compare --stock`).
"""
from __future__ import annotations

import math
import sys
from functools import partial

import click

from machine.commands import INPUT_FILE, OutputPath, refusal
from machine.commands.compiling import Compiling


def controller_check(config):
    """The controller's own test of a group (the arc-length tables its check and planner build first,
    ipo.feed.split.planning_problem): None, or why it cannot follow it. convert_text keeps a group it
    refuses as the moves it replaces, so that `vcnc fit` never writes what `vcnc run` would refuse."""
    from ipo.feed.planner import nurbs_end_gap_mm
    from ipo.feed.split import planning_problem

    return partial(planning_problem, end_gap_mm=nurbs_end_gap_mm(config))


def fit_text(text: str, tol_mm: float, config, **options):
    """convert_text with the machine's limits (the sharp-corner test) and the controller's check."""
    from ipo.fit.convert import convert_text

    return convert_text(text, tol_mm, accel_mm_s2=min(a.max_accel_mm_s2 for a in config.axes),
                        max_feed_mm_s=min(a.max_velocity_mm_s for a in config.axes),
                        reach_mm_s=math.sqrt(sum(a.max_velocity_mm_s**2 for a in config.axes)),
                        walkable=controller_check(config), **options)


def _say_compiling(compiling: Compiling, on: bool) -> None:
    """The fit's first compile, said once: a cold cache adds 1.5-2 minutes of CPU before anything is fitted."""
    if on and compiling.total_s == 0:
        click.echo(f"vcnc fit: {Compiling.COMPILING}; {Compiling.AHEAD}", err=True)


def format_report(rep, tol_mm: float, dialect: str = "g06.2") -> str:
    from ipo.fit.convert import NO_SAVING

    ratio_blocks = rep.blocks_before / max(rep.blocks_after, 1)
    ratio_bytes = rep.bytes_before / max(rep.bytes_after, 1)
    lines = [
        f"tolerance        {tol_mm * 1e3:.3f} um (both ways, on the curves as written)",
        f"chains           {rep.chains} (G1/G2/G3 moves without a break; corners do not break them)",
        f"{dialect.upper() + ' groups':16s} {rep.groups}",
        f"G2/G3 arcs       {rep.arcs} and {rep.lines} G1 lines, each written for a run of G1 moves within the"
        " tolerance of it (in a principal plane, with its G17/G18/G19 where that is not the program's, which is"
        " restored after it; never a full circle, over 180 degrees or a helix)",
        f"moves replaced   {rep.moves_replaced} (by the groups, arcs and lines)",
        f"corners          {rep.sharp_vertices} vertices must stay sharp (turns over --corner-deg that no rounding"
        " within the tolerance lets the machine follow at their feed)",
        f"                 {rep.sharp_corners} corners inside the groups (knots of multiplicity = degree),"
        f" {rep.double_knots} more knots of multiplicity 2 where only the weights restart (tangent there)",
        f"kept as written  {len(rep.kept_g01)} pieces",
        f"blocks           {rep.blocks_before} -> {rep.blocks_after}  ({ratio_blocks:.2f}x fewer;"
        " a group counted as written: a block per control point, plus the closing knot blocks of G06.2"
        " or the G5.3 of G5.2)",
        f"bytes            {rep.bytes_before} -> {rep.bytes_after}  ({ratio_bytes:.2f}x fewer)",
        *([f"feeds            {rep.feeds_merged} feed changes inside groups and written lines/arcs: all at or above"
           " what the machine's axes reach together, so alike; each is written with its lowest F"]
          if rep.feeds_merged else []),
        f"max deviation    {rep.max_deviation_mm * 1e3:.3f} um",
        f"fit time         {rep.fit_time_s:.2f} s",
    ]
    plain = sum(why == NO_SAVING for _, why in rep.kept_g01)
    # the pieces a fit could not write first (off after rounding, refused by the controller): they cost blocks
    kept = sorted(rep.kept_g01, key=lambda k: k[1] == NO_SAVING)
    for line, why in kept[:10]:
        lines.append(f"  kept G01 from line {line}: {why}")
    if len(kept) > 10:
        lines.append(f"  ... and {len(kept) - 10} more ({min(plain, len(kept) - 10)} of them: {NO_SAVING})")
    return "\n".join(lines)


@click.command("fit")
@click.argument("src", type=INPUT_FILE)
@click.option("-o", "--output", "out", required=True, type=OutputPath(),
              help="Where to write the converted program.")
@click.option("--tol-mm", "tol_mm", required=True, type=float,
              help="Largest distance allowed between the curve and the G01 path, mm.")
@click.option("--degree", default=None, type=int,
              help="Curve degree (G06.2 P = degree + 1)  [default: 2 with G06.2: rational quadratic spans with "
                   "their own knots; 3 with G5.2]; 3..5 with G06.2 fits 001's curves on uniform knots.")
@click.option("--corner-deg", default=30.0, show_default=True, type=float,
              help="A turn sharper than this between two moves stays a sharp corner where no rounding within "
                   "the tolerance can be followed at the programmed feed; smaller turns are never forced sharp.")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="Worker processes for the fits  [default: one per core].")
@click.option("--dialect", type=click.Choice(["g06.2", "g5.2"]), default="g06.2", show_default=True,
              help="g06.2: Fanuc G06.2 groups (3-D, knots written, through corners); g5.2: LinuxCNC G5.2/G5.3 "
                   "(XY plane at one Z, uniform knots, no knot blocks).")
@click.option("--arcs/--no-arcs", default=True, show_default=True,
              help="Write a run of G1 moves within the tolerance of one line or of one arc in a principal plane as "
                   "one G1 or G2/G3 block where that costs fewer blocks than a group (G06.2 only).")
@click.option("--compare", "gains", is_flag=True,
              help="Also run both programs, on the machine file's planner and on each of vcnc's and the grbl and "
                   "LinuxCNC twins, and print machining time, feed fluctuation and the distance between the paths.")
@click.option("--stock", "stock_text",
              help="With --compare: cut a virtual workpiece with both, XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm), and print "
                   "both machined surfaces and their difference.")
@click.option("--tool", type=int, help="With --stock: the workpiece's tool (default: the program's T… M6, else [finishing]).")
@click.option("--grid-um", type=float, help="With --stock: Z-map spacing in um (default: from the tool).")
@click.option("--machine", type=INPUT_FILE, default=None,
              help="Machine file (TOML) for the sharp-corner test and --compare; the built-in default if omitted.")
def command(src: str, out: str, tol_mm: float, degree: int | None, corner_deg: float, jobs: int | None, dialect: str,
            arcs: bool, gains: bool, stock_text: str | None, tool: int | None, grid_um: float | None,
            machine: str | None) -> None:
    """Replace G01 runs by rational B-spline G06.2 groups within a tolerance."""
    from ipr.entities import GCodeError
    from ipo.config import ConfigError, default_config, load_config
    from ipo.errors import IpoError
    from machine.commands.warmup import load_fit_kernels
    from machine.workpiece.pair import cut_options

    if not tol_mm > 0:
        raise click.BadParameter(f"must be > 0, got {tol_mm}", param_hint="--tol-mm")
    if degree is not None and not 1 <= degree <= 5:
        raise click.BadParameter(f"must be 1..5 (G06.2 order 2..6), got {degree}", param_hint="--degree")
    if not 0 <= corner_deg <= 180:
        raise click.BadParameter(f"must be 0..180, got {corner_deg}", param_hint="--corner-deg")
    if stock_text is not None and not gains:
        raise click.UsageError("--stock cuts both programs for the comparison: add --compare")
    cut = cut_options(stock_text, tool, grid_um, None)
    try:
        config = default_config() if machine is None else load_config(machine)
    except ConfigError as err:
        raise click.ClickException(f"machine file {machine}: {err}") from None
    with open(src, "rb") as f:
        text = f.read().decode("utf-8", "replace")
    with Compiling() as compiling:  # a cold cache: said at the first compile, and its time at the end
        compiling.on_change = partial(_say_compiling, compiling)
        try:
            load_fit_kernels()
            result, report = fit_text(text, tol_mm, config, degree=degree, corner_deg=corner_deg, file=src,
                                      jobs=jobs, dialect=dialect, arcs=arcs)
        except GCodeError as err:
            click.echo(f"{src}: the program has errors; fix them before fitting:\n{err}", err=True)
            sys.exit(1)
        except IpoError as err:
            raise refusal(err, src) from None
        with open(out, "w", encoding="utf-8", newline="") as f:
            f.write(result)
        click.echo(f"{src} -> {out}")
        click.echo(format_report(report, tol_mm, dialect))
        if gains:
            print_gains(src, out, machine, config, cut)
    if note := compiling.summary("fit"):
        click.echo(note, err=True)


def print_gains(src: str, out: str, machine: str | None, config, cut: dict | None) -> None:
    """What the fit changes: `vcnc compare SRC OUT` on the machine file's planner (with the workpieces of
    `cut`), then machining time and feed fluctuation on every planner."""
    from ipo.config import PLANNERS
    from machine.commands.compare import compare_programs, format_table, reported
    from machine.planners import with_planner
    from machine.workpiece.pair import format_surfaces

    click.echo(f"\nwhat the fit changes on the {config.planner} planner (vcnc compare):")
    with reported(machine):
        own = compare_programs(src, out, machine, cut, (config, config))
    click.echo(format_table(own))
    if "surfaces" in own:
        click.echo(format_surfaces(own["surfaces"], own["files"]))
    click.echo("\non each planner (vcnc compare --planner P; the machine file's settings):")
    click.echo(f"{'planner':10s} {'machining time':>30s} {'feed fluctuation':>22s}")
    for name in PLANNERS:
        twin = with_planner(config, name)
        try:
            with reported(machine):
                res = own if name == config.planner else compare_programs(src, out, machine, None, (twin, twin))
        except click.ClickException as err:
            click.echo(f"{name:10s} not run: {err.message}")
            continue
        a, b = res["a"], res["b"]
        change = (b["time_s"] / a["time_s"] - 1) * 100
        click.echo(f"{name:10s} {a['time_s']:10.2f} s -> {b['time_s']:8.2f} s {change:+6.1f}%"
                   f" {a['feed_fluctuation_pct']:8.2f} % -> {b['feed_fluctuation_pct']:6.2f} %")
