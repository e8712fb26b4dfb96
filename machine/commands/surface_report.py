"""`vcnc surface-report SURFACE.npz [--reference S.igs] [--plot OUT.png] [--json]`: a saved surface's figures."""
from __future__ import annotations

import json

import click

from machine.commands import INPUT_FILE, OutputPath, refusal


@click.command("surface-report")
@click.argument("surface_file", type=INPUT_FILE)
@click.option("--reference", type=INPUT_FILE, help="IGES surface (from `vcnc surface`) to measure the deviation from.")
@click.option("--feed-axis", type=click.Choice(["x", "y"]), default="x", show_default=True,
              help="The axis the passes run along.")
@click.option("--pick-mm", type=float, help="Step-over for the classical scallop (default: the measured one).")
@click.option("--gouge-tol-um", type=float, default=1.0, show_default=True,
              help="Material removed deeper than this below the reference is a gouge.")
@click.option("--plot", "plot_file", type=OutputPath((".png",)), help="Shaded height, deviation map and profiles.")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as one JSON object.")
def command(surface_file, reference, feed_axis, pick_mm, gouge_tol_um, plot_file, as_json):
    """Measure a machined surface saved by `vcnc run --surface OUT.npz`."""
    from machine.workpiece.figures import format_rows, surface_figures
    from machine.workpiece.measure import iges_reference
    from machine.workpiece.surface_file import load_npz

    try:
        surface, _ = load_npz(surface_file)
    except (ValueError, OSError) as err:
        raise click.ClickException(str(err)) from None
    ref = None
    if reference is not None:
        from ipo.errors import IpoError

        try:
            ref = iges_reference(surface, reference)
        except IpoError as err:
            raise refusal(err, reference) from None
        except OSError as err:
            raise click.ClickException(f"{reference}: {err}") from None
    figs = surface_figures(surface, reference=ref, feed_axis=feed_axis, pick_mm=pick_mm,
                           gouge_tol_mm=gouge_tol_um / 1000.0)
    figs.pop("_gouge_line", None)
    if as_json:
        click.echo(json.dumps(figs))
    else:
        click.echo(format_rows({surface_file: figs}))
    if plot_file:
        from machine.workpiece.plot import plot_surface

        plot_surface(surface, plot_file, title=f"vcnc surface-report {surface_file}", reference=ref,
                     feed_axis=feed_axis)
        click.echo(f"plot written to {plot_file}", err=True)
