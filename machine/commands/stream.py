"""`vcnc stream FILE --port URL`: send a program to a grbl 1.1 board (G-code lines,
NURBS through vcnc's IPO) or to a drive speaking vcnc's increment protocol."""
from __future__ import annotations

import sys

import click

from ipo.config import PLANNERS
from machine.commands import INPUT_FILE, load_machine

def _load_program(path):
    from ipr import parse_file
    from ipr.entities import GCodeError

    try:
        return parse_file(path)
    except GCodeError as err:
        raise click.ClickException(str(err)) from None


def _stdout_is_terminal() -> bool:
    return sys.stdout.isatty()


def _dry_run(protocol, file, program, config, resume_from, estimate, planner, baud) -> None:
    out = sys.stdout.buffer
    if protocol == "increments":
        import numpy as np

        from ipo.feed.planner import plan_periods
        from machine.increments import frames as F
        from machine.increments.link import frame_chunks

        out.write(F.hello_frame())
        batches = (b for b in plan_periods(program.entities, config) if hasattr(b, "inc_blu"))
        for seq, inc in enumerate(frame_chunks(batches, F.MAX_PERIODS)):
            out.write(F.data_frame(seq, np.asarray(inc)))
        return
    from machine.commands.stream_grbl import grbl_job
    from machine.grbl.job import machine_at_zero

    job = grbl_job(file, config, machine_at_zero())
    lines = job.lines
    if resume_from is not None:
        if resume_from > len(lines):
            raise click.ClickException(f"--resume-from {resume_from}: the stream has {len(lines)} lines")
        lines = lines[resume_from - 1:]
        out.write("".join(t + "\n" for t in lines[0].restore).encode("ascii"))
    for line in lines:
        out.write(line.text.encode("ascii") + b"\n")
    click.echo("notice: --dry-run assumes grbl just reset at machine zero with every offset zero; a stream "
               "starts from the machine's real position and offsets", err=True)
    for n in job.warnings + job.notices:
        click.echo(f"notice: {n}", err=True)
    if estimate:
        from machine.commands.stream_grbl import estimate_config
        from machine.grbl.estimate import JobEstimate
        from machine.planners import describe

        est_config = estimate_config(config, planner, None, baud)
        est = JobEstimate.plan(job.groups, est_config, (0.0, 0.0, 0.0))
        click.echo(f"job time ({describe(est_config)}): {est.total_s:.1f} s", err=True)


def _stream_increments(port, baud, program, config) -> None:
    from rich.console import Console

    from ipo.feed.planner import plan_periods
    from machine.increments.link import IncrementLink, IncrementLinkError

    console = Console(stderr=True)
    batches = (b for b in plan_periods(program.entities, config) if hasattr(b, "inc_blu"))
    link = IncrementLink(port, baud=baud)
    try:
        free = link.hello()
        console.print(f"drive buffer {free} periods")
        res = link.send(batches)
    except IncrementLinkError as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()
    console.print(f"done: {res.periods} periods in {res.frames} frames ({res.resent_frames} resent, "
                  f"{res.naks} NAKs); increments sum to {res.sum_blu.tolist()} BLU")


@click.command()
@click.argument("file", type=INPUT_FILE)
@click.option("--port", help="device path, socket://host:port, rfc2217://host:port or loop://")
@click.option("--protocol", type=click.Choice(["grbl", "increments"]), default="grbl", show_default=True)
@click.option("--baud", type=int, default=115200, show_default=True)
@click.option("--machine", "machine_file", type=INPUT_FILE,
              help="machine TOML the IPO plans with (default: the built-in machine)")
@click.option("--resume-from", type=click.IntRange(min=1), default=None,
              help="stream line to continue from (a stopped stream prints it); vcnc checks the machine "
                   "position and skips lines the machine already ran")
@click.option("--dry-run", is_flag=True, help="write the exact bytes that would be sent to stdout")
@click.option("--unlock", is_flag=True, help="clear a grbl alarm with $X before streaming")
@click.option("--resume", is_flag=True, help="continue a stopped or killed stream from its ledger")
@click.option("--ledger", "ledger_file", type=click.Path(dir_okay=False), default=None,
              help="the stream's ledger of lines sent and acknowledged [default: FILE.vcnc-ledger]")
@click.option("--estimate/--no-estimate", default=True, show_default=True,
              help="plan the job first (the grbl twin with the board's $$): job time, and time remaining while "
                   "streaming")
@click.option("--planner", type=click.Choice(list(PLANNERS)), default=None,
              help="whose planning the grbl estimate uses [default: grbl, the twin of the board]")
@click.option("--poll-hz", type=click.FloatRange(min=0.5, max=20.0), default=5.0, show_default=True,
              help="grbl status polls per second")
def command(file, port, protocol, baud, machine_file, resume_from, dry_run, unlock, resume, ledger_file, estimate,
            poll_hz, planner):
    """Stream FILE to a grbl 1.1 board or an increment-protocol drive."""
    if dry_run and protocol == "increments" and _stdout_is_terminal():
        raise click.UsageError("--dry-run with --protocol increments writes binary frames: "
                               "redirect stdout to a file or a pipe")
    config = load_machine(machine_file)
    program = _load_program(file)
    if (resume_from is not None or resume) and protocol == "increments":
        raise click.UsageError("--resume-from and --resume apply to grbl streams only")
    if dry_run:
        _dry_run(protocol, file, program, config, resume_from, estimate, planner, baud)
        return
    if not port:
        raise click.UsageError("--port is required (or use --dry-run)")
    if protocol == "grbl":
        from machine.commands.stream_grbl import stream_grbl

        stream_grbl(port, baud, file, config, resume_from=resume_from, resume=resume, ledger_path=ledger_file,
                    unlock=unlock, poll_hz=poll_hz, estimate_time=estimate, planner=planner)
    else:
        _stream_increments(port, baud, program, config)
