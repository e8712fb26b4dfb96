"""`vcnc plot TRACE`: draw a trace written by `vcnc run --trace`."""
from __future__ import annotations

from pathlib import Path

import click

from machine.commands import INPUT_FILE, OutputPath


@click.command("plot")
@click.argument("trace_file", type=INPUT_FILE)
@click.option("--out", type=OutputPath((".png",)), help="PNG to write (default: TRACE with .png).")
def command(trace_file, out):
    """Plot the path, the feed with its limiting reason, and the axes against their limits."""
    from machine.plot import plot_trace
    from machine.trace import load_trace

    if out is None:  # the default beside the trace is checked like a given one
        out = OutputPath((".png",)).convert(str(Path(trace_file).with_suffix(".png")), None, None)
    try:
        trace = load_trace(trace_file)
        written = plot_trace(trace, out or Path(trace_file).with_suffix(".png"), title=str(trace_file))
    except (ValueError, OSError) as err:
        raise click.ClickException(str(err)) from None
    click.echo(f"plot written to {written}")
