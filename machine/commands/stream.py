"""`vcnc stream FILE --port URL`: send a program to a grbl 1.1 board (G-code lines,
NURBS through vcnc's IPO) or to a drive speaking vcnc's increment protocol."""
from __future__ import annotations

import sys

import click

from machine.commands import INPUT_FILE, load_machine

KEYS_HELP = "space hold/resume, + / - feed override 10 %, 0 override 100 %, x reset"


def _load_program(path):
    from ipr import parse_file
    from ipr.entities import GCodeError

    try:
        return parse_file(path)
    except GCodeError as err:
        raise click.ClickException(str(err)) from None


def _grbl_lines(program, config, resume_from):
    """The whole stream, made before a byte goes out, so a program grbl cannot take fails
    here and not halfway through; with resume_from, the lines from there on."""
    from ipr.entities import Nurbs
    from machine.grbl.program import StreamProgramError, stream_lines

    notices: list[str] = []
    has_nurbs = any(isinstance(e, Nurbs) for e in program.entities)
    try:
        lines = list(stream_lines(program.entities, config, notices=notices, ipo_from_start=has_nurbs))
    except (StreamProgramError, ValueError) as err:
        raise click.ClickException(str(err)) from None
    if resume_from is not None and resume_from > len(lines):
        raise click.ClickException(f"--resume-from {resume_from}: the stream has {len(lines)} lines")
    return (lines if resume_from is None else lines[resume_from - 1:]), notices


def _dry_run(protocol, program, config, resume_from) -> None:
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
    lines, notices = _grbl_lines(program, config, resume_from)
    if resume_from is not None:
        out.write("".join(t + "\n" for t in lines[0].restore).encode("ascii"))
    for line in lines:
        out.write(line.text.encode("ascii") + b"\n")
    for n in notices:
        click.echo(f"notice: {n}", err=True)


def _progress(live, total: int):
    from rich.text import Text

    from machine.grbl import protocol as P
    from machine.realtime import Keyboard

    kb = Keyboard()
    keymap = {" ": None, "+": P.FEED_OV_PLUS_10, "-": P.FEED_OV_MINUS_10, "0": P.FEED_OV_RESET, "x": P.SOFT_RESET}

    def update(link, ledger):
        for k in kb.keys():
            if k in keymap:
                held = link.status is not None and link.status.state == "Hold"
                link.realtime(keymap[k] or (P.CYCLE_RESUME if held else P.FEED_HOLD))
        st = link.status
        text = f"acknowledged {ledger.last_acknowledged:>7}/{total} lines"
        if st is not None:
            pos = st.wpos or st.mpos
            state = st.state + (f":{st.substate}" if st.substate is not None else "")
            text += f"  {state:<7} X{pos[0]:10.3f} Y{pos[1]:10.3f} Z{pos[2]:10.3f}"
            if st.planner_free is not None:
                text += f"  planner free {st.planner_free:>2}  rx free {st.rx_free:>3}"
            if st.feed_mm_min is not None:
                text += f"  F {st.feed_mm_min:7.0f}"
            if st.overrides:
                text += f"  Ov {st.overrides[0]}%"
        live.update(Text(text + f"   [{KEYS_HELP}]"))
    return kb, update


def _stream_grbl(port, baud, program, config, resume_from, unlock, poll_hz) -> None:
    from rich.console import Console
    from rich.live import Live
    from rich.text import Text

    from machine.grbl.budget import stream_demand
    from machine.grbl.ledger import Ledger
    from machine.grbl.link import GrblLink, LinkError
    from machine.grbl.resume import ResumeError

    console = Console(stderr=True)
    lines, notices = _grbl_lines(program, config, resume_from)
    try:
        link = GrblLink(port, baud=baud, poll_interval_s=1.0 / poll_hz)
    except Exception as err:  # pyserial raises several types for a bad URL or device
        raise click.ClickException(f"cannot open {port}: {err}") from None
    try:
        info = link.connect(config, unlock=unlock)
        console.print(f"{info.banner}  build {info.build.version}  RX {link.rx_size} bytes, "
                      f"{link.planner_blocks} planner blocks")
        demand = stream_demand(lines, baud=baud, planner_blocks=link.planner_blocks,
                               accel_mm_s2=min(a.max_accel_mm_s2 for a in config.axes))
        for w in info.warnings + demand.warnings + [f"notice: {n}" for n in notices]:
            console.print(f"[yellow]warning:[/yellow] {w}" if not w.startswith("notice") else w)
        resume = None
        if resume_from is not None:
            resume, _ = link.resume_point(lines)
            lines = lines[resume.seq - lines[0].seq:]
            console.print(f"machine at X{resume.at_mm[0]:.3f} Y{resume.at_mm[1]:.3f} Z{resume.at_mm[2]:.3f}: "
                          f"continuing from stream line {resume.seq}"
                          + (" (inside it)" if resume.partial else ""))
        ledger = Ledger(resume.seq if resume else 1)
        with Live(Text(""), console=console, refresh_per_second=5) as live:
            kb, update = _progress(live, lines[-1].seq if lines else 0)
            with kb:
                result = link.stream(lines, ledger, resume=resume, on_progress=update)
    except (LinkError, ResumeError) as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()
    if result.fault is not None:
        raise click.ClickException(result.fault.message)
    ledger.check()
    st = result.status
    console.print(f"done: {ledger.last_acknowledged - ledger.first + 1} lines acknowledged, machine "
                  f"{st.state} at X{st.wpos[0]:.3f} Y{st.wpos[1]:.3f} Z{st.wpos[2]:.3f}"
                  + (f"; {len(link.garbage)} garbage lines ignored" if link.garbage else ""))


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
@click.option("--poll-hz", type=click.FloatRange(min=0.5, max=20.0), default=5.0, show_default=True,
              help="grbl status polls per second")
def command(file, port, protocol, baud, machine_file, resume_from, dry_run, unlock, poll_hz):
    """Stream FILE to a grbl 1.1 board or an increment-protocol drive."""
    if dry_run and protocol == "increments" and sys.stdout.isatty():
        raise click.UsageError("--dry-run with --protocol increments writes binary frames: "
                               "redirect stdout to a file or a pipe")
    config = load_machine(machine_file)
    program = _load_program(file)
    if resume_from is not None and protocol == "increments":
        raise click.UsageError("--resume-from applies to grbl streams only")
    if dry_run:
        _dry_run(protocol, program, config, resume_from)
        return
    if not port:
        raise click.UsageError("--port is required (or use --dry-run)")
    if protocol == "grbl":
        _stream_grbl(port, baud, program, config, resume_from, unlock, poll_hz)
    else:
        _stream_increments(port, baud, program, config)
