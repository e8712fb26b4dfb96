"""`vcnc grbl ...`: what a sender does besides streaming -- status, homing, unlocking,
jogging, check mode, settings and a small MDI console -- on a grbl 1.1 board.

Every subcommand opens the port, wakes grbl without resetting it where it may be
moving (`status`, `jog` keep whatever runs; the others soft-reset only at standstill
as `vcnc stream` does) and closes it again. Ctrl-C during a jog sends jog cancel
(0x85); during `mdi` it sends feed hold.
"""
from __future__ import annotations

import signal
import sys
import time

import click

from machine.commands import OutputPath, load_machine

PORT = click.option("--port", required=True, help="device path, socket://host:port, rfc2217://host:port or loop://")
BAUD = click.option("--baud", type=int, default=115200, show_default=True)
JOG_KEYS = {"x": (0, -1), "X": (0, 1), "y": (1, -1), "Y": (1, 1), "z": (2, -1), "Z": (2, 1)}


def _open(port, baud, *, reset=True, unlock=False):
    from machine.grbl.link import GrblLink, LinkError

    try:
        link = GrblLink(port, baud=baud, poll_interval_s=0.1, idle_timeout_s=600.0)
    except Exception as err:  # pyserial raises several types for a bad URL or device
        raise click.ClickException(f"cannot open {port}: {err}") from None
    try:
        if reset:
            link.connect(None, unlock=unlock)
        else:
            link.query_status()
    except LinkError as err:
        link.close()
        raise click.ClickException(str(err)) from None
    return link


def _status_line(st) -> str:
    from machine.commands.stream_grbl import status_text

    return status_text(st, 0, 0).split("lines  ", 1)[1]


@click.group("grbl")
def command():
    """Sender features for a grbl 1.1 board (streaming is `vcnc stream`)."""


@command.command()
@PORT
@BAUD
@click.option("--every", "every_s", type=click.FloatRange(min=0.05), default=1.0, show_default=True,
              help="seconds between status lines")
@click.option("--count", type=click.IntRange(min=0), default=1, show_default=True, help="lines to print; 0 = until Ctrl-C")
def status(port, baud, every_s, count):
    """Print grbl's status: one line per poll (plain lines, also when not a terminal)."""
    link = _open(port, baud, reset=False)
    link.read_state()  # the WCO, which status reports carry only now and then
    n = 0
    try:
        while count == 0 or n < count:
            click.echo(_status_line(link.query_status()))
            n += 1
            if count == 0 or n < count:
                time.sleep(every_s)
    except KeyboardInterrupt:
        pass
    finally:
        link.close()


def _simple(port, baud, text: str, timeout_s: float, unlock=False):
    from machine.grbl.link import LinkError

    link = _open(port, baud, unlock=unlock)
    try:
        for msg in link.command(text, timeout_s=timeout_s):
            click.echo(msg)
        click.echo(_status_line(link.query_status()))
    except LinkError as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()


@command.command()
@PORT
@BAUD
def home(port, baud):
    """Run grbl's homing cycle ($H; needs $22=1 and limit switches)."""
    _simple(port, baud, "$H", timeout_s=300.0)


@command.command()
@PORT
@BAUD
def unlock(port, baud):
    """Clear an alarm lock ($X). Re-home if the alarm said the position may be lost."""
    _simple(port, baud, "$X", timeout_s=5.0)


def jog_line(axis: int, distance_mm: float, feed_mm_min: float) -> str:
    from machine.grbl.words import fmt

    return f"$J=G21G91{'XYZ'[axis]}{fmt(distance_mm, 1e-4)}F{fmt(feed_mm_min, 0.05)}"


@command.command()
@PORT
@BAUD
@click.option("--x", "dx", type=float, default=0.0, help="mm to jog in X (relative)")
@click.option("--y", "dy", type=float, default=0.0)
@click.option("--z", "dz", type=float, default=0.0)
@click.option("--feed", type=click.FloatRange(min=0.001), default=500.0, show_default=True, help="mm/min")
@click.option("--keys", is_flag=True, help="keyboard jogging: x/X y/Y z/Z jog -/+ one --step, space cancels, q quits")
@click.option("--step", type=click.FloatRange(min=0.001), default=1.0, show_default=True, help="mm per key")
def jog(port, baud, dx, dy, dz, feed, keys, step):
    """Jog with $J= (grbl checks soft limits); Ctrl-C or space cancels the jog (0x85)."""
    from machine.grbl import protocol as P
    from machine.grbl.link import LinkError
    from machine.realtime import Keyboard

    link = _open(port, baud, reset=False)
    old = signal.signal(signal.SIGINT, lambda *_: link.realtime(P.JOG_CANCEL))
    try:
        if not keys:
            words = "".join(f"{a}{v:g}" for a, v in zip("XYZ", (dx, dy, dz)) if v)
            if not words:
                raise click.UsageError("give --x, --y or --z (or --keys)")
            link.command(f"$J=G21G91{words}F{feed:g}")
            while True:
                link._flush_realtime()
                st = link.query_status()
                if st.state != "Jog":
                    break
                time.sleep(0.05)
            click.echo(_status_line(st))
            return
        click.echo("jogging: x/X y/Y z/Z move one step, space cancels, q quits", err=True)
        with Keyboard() as kb:
            while True:
                for k in kb.keys():
                    if k == "q":
                        return
                    if k == " ":
                        link.realtime(P.JOG_CANCEL)
                    elif k in JOG_KEYS:
                        axis, sign = JOG_KEYS[k]
                        link.command(jog_line(axis, sign * step, feed))
                link._flush_realtime()
                click.echo("\r" + _status_line(link.query_status()), nl=False, err=True)
                time.sleep(0.05)
    except LinkError as err:
        raise click.ClickException(str(err)) from None
    finally:
        signal.signal(signal.SIGINT, old)
        link.close()


def machine_settings(config) -> dict[int, float]:
    """grbl's $110-$112 (mm/min), $120-$122 (mm/s^2) and $130-$132 (travel, mm) from a machine file."""
    out = {}
    for i, a in enumerate(config.axes):
        out[110 + i] = round(a.max_velocity_mm_s * 60.0, 3)
        out[120 + i] = round(a.max_accel_mm_s2, 3)
        out[130 + i] = round(a.max_mm - a.min_mm, 3)
    return out


@command.command()
@PORT
@BAUD
@click.option("--machine", "machine_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="machine TOML (default: the built-in machine)")
@click.option("--apply-machine", is_flag=True, help="write the machine file's rates, accelerations and travel")
@click.option("--yes", is_flag=True, help="do not ask before writing")
@click.option("--save", "save_file", type=OutputPath((".txt",)), default=None,
              help="write the $$ printout as grbl printed it, for --grbl-settings and [grbl] settings (the grbl twin)")
def settings(port, baud, machine_file, apply_machine, yes, save_file):
    """Show grbl's $$ settings; with --apply-machine, write the machine file's values after a confirmation."""
    from machine.grbl import protocol as P
    from machine.grbl.link import LinkError

    link = _open(port, baud)
    try:
        printout = link.command("$$")
        have = P.parse_settings(printout)
        for k in sorted(have):
            click.echo(f"${k}={have[k]:g}")
        if save_file:
            with open(save_file, "w") as fh:
                fh.write("".join(line.strip() + "\n" for line in printout if line.strip().startswith("$")))
            click.echo(f"settings written to {save_file} (vcnc run --planner grbl --grbl-settings {save_file})")
        if not apply_machine:
            return
        want = machine_settings(load_machine(machine_file))
        changes = {k: v for k, v in want.items() if abs(have.get(k, float("nan")) - v) > 1e-9 or k not in have}
        if not changes:
            click.echo("grbl already has the machine file's values")
            return
        for k, v in changes.items():
            click.echo(f"${k}: {have.get(k, 'unset')} -> {v:g}")
        if not yes and not click.confirm("write these to grbl's EEPROM?", default=False):
            raise click.ClickException("nothing written")
        for k, v in changes.items():
            link.command(f"${k}={v:g}")
        click.echo(f"wrote {len(changes)} settings")
    except LinkError as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()


@command.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@PORT
@BAUD
@click.option("--machine", "machine_file", type=click.Path(exists=True, dir_okay=False), default=None)
def check(file, port, baud, machine_file):
    """Stream FILE through grbl's check mode ($C): grbl parses every line, nothing moves."""
    from machine.commands.stream_grbl import grbl_job
    from machine.grbl.ledger import Ledger
    from machine.grbl.link import LinkError

    config = load_machine(machine_file)
    link = _open(port, baud)
    try:
        state = link.read_state()
        job = grbl_job(file, config, state, link.line_numbers)
        link.command("$C")
        result = link.stream(job.lines, Ledger(1))
        if result.completed:
            link.command("$C")  # leaves check mode; grbl soft-resets itself
    except LinkError as err:
        raise click.ClickException(str(err)) from None
    finally:
        link.close()
    if result.fault is not None:
        raise click.ClickException(f"check mode: {result.fault.message.split('; machine stopped')[0]}")
    click.echo(f"check mode: grbl accepted all {len(job.lines)} lines")


@command.command()
@PORT
@BAUD
def mdi(port, baud):
    """A line console: G-code and $ commands go to grbl, its answers come back. `?` status,
    `!` hold, `~` resume, `reset` soft reset, `exit` (or end of input) quits."""
    from machine.grbl import protocol as P
    from machine.grbl.link import LinkError

    link = _open(port, baud, reset=False)
    old = signal.signal(signal.SIGINT, lambda *_: link.realtime(P.FEED_HOLD))
    tty = sys.stdin.isatty()
    try:
        while True:
            line = input("grbl> ") if tty else sys.stdin.readline()
            if not tty and not line:
                break
            line = line.strip()
            if line in ("exit", "quit"):
                break
            try:
                if line == "?":
                    click.echo(_status_line(link.query_status()))
                elif line in ("!", "~"):
                    link.realtime(line.encode())
                    link._flush_realtime()
                elif line == "reset":
                    click.echo(link.soft_reset())
                elif line:
                    for msg in link.command(line, timeout_s=60.0):
                        click.echo(msg)
                    click.echo("ok")
            except LinkError as err:
                click.echo(f"error: {err}")
    except EOFError:
        pass
    finally:
        signal.signal(signal.SIGINT, old)
        link.close()
