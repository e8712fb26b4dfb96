"""`vcnc run FILE`: check a program, run it in the virtual controller, print the summary."""
from __future__ import annotations

import json
import sys

import click

from ipo.config import METHODS
from machine.commands import INPUT_FILE, OutputPath, apply_planner, load_machine, planner_options
from machine.commands.compiling import Compiling



def _print_summary(result, as_json: bool) -> None:
    summary = result.summary()
    if as_json:
        click.echo(json.dumps(summary))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"vcnc run {summary['file']}: {summary['state']}", show_header=False)
    table.add_column("figure", style="bold")
    table.add_column("value", justify="right")
    for key, value in summary.items():
        if key in ("file", "state") or value in ([], None) and key in ("program_stops", "messages", "fault"):
            continue
        if isinstance(value, list) and value and isinstance(value[0], float):
            value = "  ".join(f"{v:g}" for v in value)
        elif isinstance(value, list):
            value = "; ".join(str(v) for v in value)
        elif isinstance(value, dict):
            value = ", ".join(f"{k} {v}" for k, v in value.items())
        elif isinstance(value, float):
            value = f"{value:.6g}"
        table.add_row(key, "-" if value is None else str(value))
    Console().print(table)


def _fast_stop_answer(stop) -> bool:
    """M0/M1 in the as-fast-as-possible mode: ask at a terminal, else resume and say so."""
    what = "M1 optional stop" if stop.optional else "M0 program stop"
    if sys.stdin is not None and sys.stdin.isatty():
        answer = click.prompt(f"{what} at line {stop.line}: Enter to resume, s to stop", default="",
                              show_default=False, err=True)
        return answer.strip().lower() not in ("s", "q", "stop")
    click.echo(f"{what} at line {stop.line}: no terminal to wait at, resuming", err=True)
    return True


def _status_line(player) -> str:
    d = player.drive
    x, y, z = d.position_mm
    state = {"run": "RUN", "hold": "HOLD", "stopping": "STOPPING", "paused": "M0 PAUSE",
             "stopped": "STOPPED"}[player.state]
    return (f"N{d.line:<6}X{x:8.3f} Y{y:8.3f} Z{z:8.3f} F{d.feed_mm_s:6.1f} {player.override * 100:3.0f}% "
            f"{state:<8} t{d.t_s:7.1f}s miss {player.deadline_misses}")


def _run_realtime(controller, program):
    from rich.console import Console
    from rich.live import Live
    from rich.text import Text

    from machine.realtime import Keyboard, Player

    click.echo("keys: space hold/resume (and resume after M0/M1), + / - live override, s stop; Ctrl-C aborts",
               err=True)
    with Keyboard() as kb, Live(Text(""), console=Console(stderr=True), refresh_per_second=10,
                                transient=False) as live:
        player = Player(keys=kb.keys, status=lambda p: live.update(Text(_status_line(p))))
        controller.on_program_stop = lambda stop: player.pause(lambda: kb.wait_key(" \nsq") in " \n")
        return controller.run(program, player=player)


def _run_fast(controller, program, show_progress: bool, compiling: Compiling):
    if not show_progress:
        return controller.run(program)
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    last_line = program.last_line or 1
    with Progress(TextColumn("{task.description}"), BarColumn(),
                  TextColumn("line {task.completed:.0f}/{task.total:.0f}"),
                  TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(Compiling.RUNNING, total=last_line)
        compiling.on_change = lambda on: bar.update(
            task, description=Compiling.COMPILING if on else Compiling.RUNNING)
        return controller.run(program, progress=lambda line: bar.update(task, completed=line))


def _write_pictures(digest, plot_file, report_file, program, result, machine_file, surface) -> None:
    """The PNG and the HTML report, both from the run's digest (the report with the workpiece's surface)."""
    if digest.periods == 0:
        click.echo(f"{program.file}: nothing moved, no plot or report written", err=True)
        return
    if plot_file:
        from machine.plot import plot_digest

        plot_digest(digest, plot_file, title=f"vcnc run {program.file}", rapid_lines=program.rapid_lines)
        click.echo(f"plot written to {plot_file}", err=True)
    if report_file:
        from machine.report.build import machine_info, run_report

        run_report(report_file, digest, program=program, summary=result.summary(), machine=machine_info(machine_file),
                   surface=surface)
        click.echo(f"report written to {report_file}", err=True)


@click.command("run")
@click.argument("file", type=INPUT_FILE)
@click.option("--machine", "machine_file", type=INPUT_FILE, help="Machine TOML (default: built in).")
@click.option("--period-ms", type=float, help="Interpolation period in ms (overrides the machine file).")
@click.option("--method", type=click.Choice(list(METHODS)),
              help="NURBS interpolator (default: the machine file's).")
@click.option("--feed-override", type=float, default=100.0, show_default=True, help="Feed override in percent.")
@click.option("--trace", "trace_file", type=OutputPath((".npz", ".csv")), help="Write the trace (.npz or .csv).")
@click.option("--plot", "plot_file", type=OutputPath((".png",)), help="Plot the run into a PNG.")
@click.option("--report", "report_file", type=OutputPath((".html", ".htm")),
              help="Write an interactive one-file HTML report of the run.")
@click.option("--realtime", is_flag=True, help="Pace at the period; keys: space hold/resume, +/- override, s stop.")
@click.option("--optional-stop", is_flag=True, help="Honour M1 optional stops.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON object.")
@click.option("--stock", "stock_text", help="Cut a virtual workpiece: stock box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm, "
              "work coordinates; default: the machine file's [stock]).")
@click.option("--tool", "tool", type=int, help="The tool cutting the workpiece from the start (default: the "
              "program's first T… M6, else the [finishing] tool).")
@click.option("--grid-um", type=float, help="Z-map spacing in um (default: from the tool and the chord tolerance).")
@click.option("--teeth", is_flag=True, help="Cut with the flutes' edges at the spindle angle (tooth-pass marks; "
              "slower) instead of the tool's solid of revolution.")
@click.option("--surface", "surface_files", multiple=True, type=OutputPath((".npz", ".stl", ".png")),
              help="Write the machined surface: .npz (x_mm, y_mm, z_mm, gouge_line), .stl or .png; repeatable.")
@planner_options
def command(file, machine_file, period_ms, method, feed_override, trace_file, plot_file, report_file, realtime,
            optional_stop, as_json, stock_text, tool, grid_um, teeth, surface_files, planner, grbl_settings,
            linuxcnc_ini):
    """Check FILE, then run it in the virtual controller and print what the machine did."""
    from machine.collector import collector_held, freeze_loaded

    with collector_held():
        from machine.controller import Controller, ProgramRejected
        from machine.report.digest import DigestSink
        from machine.trace import open_writer
        from machine.workpiece.cli_run import check_surface_outputs, finish_workpiece, start_workpiece
        freeze_loaded()

    config = apply_planner(load_machine(machine_file), planner, grbl_settings, linuxcnc_ini)
    cutting = check_surface_outputs(surface_files, stock_text, tool, grid_um, config, teeth)
    if period_ms is not None:
        from ipo.config import ConfigError, with_period

        try:
            config = with_period(config, period_ms / 1000.0)
        except ConfigError as err:
            raise click.BadParameter(str(err), param_hint="--period-ms") from None
    if not feed_override > 0:
        raise click.BadParameter("must be > 0", param_hint="--feed-override")
    controller = Controller(config, method=method, feed_override=feed_override / 100.0,
                            optional_stop=optional_stop, on_program_stop=_fast_stop_answer,
                            on_event=lambda e: click.echo(f"line {e.line}: {e.text}", err=True)
                            if hasattr(e, "text") else None)
    try:
        # the check's entities, kept for the run (machine.check), live as long as it: frozen before
        # the collector, enabled again, would traverse them (~30 ms for stellabee1's)
        with collector_held():
            program = controller.check(file)
            freeze_loaded()
    except KeyboardInterrupt:
        click.echo(f"{file}: interrupted while checking the program; no axis moved", err=True)
        sys.exit(130)
    except ProgramRejected as rejected:
        for reason in rejected.reasons:
            click.echo(reason, err=True)
        click.echo(f"{file}: not run: {len(rejected.reasons)} problem(s); no axis moved", err=True)
        sys.exit(1)
    for warning in program.warnings:
        click.echo(str(warning), err=True)
    workpiece = start_workpiece(program, config, stock_text, tool, grid_um, teeth) if cutting else None
    if workpiece is not None:
        shown = controller.on_event
        controller.on_event = lambda e: (workpiece.event(e), shown(e))

    servo = config.servo.model != "none"
    meta = dict(controller.limits.meta(), file=str(file))
    writer = open_writer(trace_file, meta, servo) if trace_file else None
    digest = DigestSink(meta, servo=servo) if plot_file or report_file else None  # memory bounded, unlike a trace
    controller.sinks = [s for s in (writer, digest, workpiece) if s is not None]
    try:
        with Compiling() as compiling:
            if realtime:
                result = _run_realtime(controller, program)
            else:
                result = _run_fast(controller, program, not as_json and sys.stderr.isatty(), compiling)
    finally:
        if writer is not None:
            writer.close()
    _print_summary(result, as_json)
    if note := compiling.summary("run"):
        click.echo(note, err=True)
    if result.state == "completed" and result.periods == 0:
        click.echo(f"{file}: the program commands no motion; nothing moved", err=True)
    surface = finish_workpiece(workpiece, result, surface_files) if workpiece is not None else None
    if result.state != "completed":
        where = f"line {result.line}" if result.periods else "the start, before the first move"
        click.echo(f"{file}: {result.state} at {where}, position "
                   f"X{result.position_mm[0]:.4f} Y{result.position_mm[1]:.4f} Z{result.position_mm[2]:.4f}"
                   + (f": {result.fault}" if result.fault else ""), err=True)
    if digest is not None:
        _write_pictures(digest.finish(), plot_file, report_file, program, result, machine_file, surface)
    sys.exit({"completed": 0, "stopped": 0, "interrupted": 130}.get(result.state, 1))
