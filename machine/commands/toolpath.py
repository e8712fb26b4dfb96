"""`vcnc toolpath SURFACE.igs --ball-mm R --pick-mm P -o FINISH.nc`: ball-end finishing passes.

Reads the rational surface (entity 128) of an IGES file written by `vcnc surface`,
offsets it by the ball radius along the normal, and writes passes at the pick feed
as Fanuc G06.2 groups (tool-centre coordinates), ready for `vcnc run` with 002's
roughness limiter. Across a convex crease (a C0 knot) the ball rolls about the crease on
an exact arc; a concave crease is refused.
"""
from __future__ import annotations

import os
import time

import click

from machine.commands import INPUT_FILE, OutputPath, refusal


@click.command("toolpath")
@click.argument("surface", type=INPUT_FILE)
@click.option("-o", "--output", "out", required=True, type=OutputPath(), help="Program to write.")
@click.option("--ball-mm", required=True, type=float, help="Ball-end tool radius, mm.")
@click.option("--pick-mm", required=True, type=float, help="Pick feed (distance between passes on the surface), mm.")
@click.option("--feed-mm-min", default=1000.0, show_default=True, type=float, help="Cutting feed, mm/min.")
@click.option("--spindle-rpm", default=10000.0, show_default=True, type=float, help="Spindle speed, rpm.")
@click.option("--tol-mm", default=0.005, show_default=True, type=float,
              help="Largest error of the tool-centre curves (distance to the surface minus the radius).")
@click.option("--along", type=click.Choice(["u", "v"]), default="u", show_default=True,
              help="Parameter direction of the passes (u: along the sections).")
def command(surface, out, ball_mm, pick_mm, feed_mm_min, spindle_rpm, tol_mm, along) -> None:
    """Write ball-end finishing passes over an IGES surface as G06.2 groups."""
    from ipo.errors import IpoError
    from ipo.surface.iges import read_surfaces
    from ipo.surface.toolpath import ToolpathSettings, plan_passes, program_text

    settings = ToolpathSettings(ball_mm, pick_mm, tol_mm, feed_mm_min, spindle_rpm, along)
    try:
        surfaces = read_surfaces(surface)
        if len(surfaces) != 1:
            raise click.ClickException(f"{surface} holds {len(surfaces)} surfaces; this command machines one")
        t0 = time.perf_counter()
        passes = plan_passes(surfaces[0], settings)
        elapsed = time.perf_counter() - t0
    except IpoError as err:
        raise refusal(err, surface) from None
    text = program_text(passes, settings, os.path.basename(surface))
    with open(out, "w", encoding="ascii", newline="\n") as f:
        f.write(text)
    groups = sum(len(p.pieces) for p in passes)
    ctrl = sum(len(f.points) for p in passes for f in p.pieces)
    click.echo(f"{surface} -> {out}")
    click.echo(f"passes {len(passes)} along {along}, G06.2 groups {groups}, control points {ctrl}")
    arcs = sum(p.rolling_arcs for p in passes)
    if arcs:
        click.echo(f"rolling arcs {arcs} (the ball centre turning about a convex crease, written exactly)")
    click.echo(f"max tool-centre error {max(p.deviation_mm for p in passes) * 1e3:.3f} um "
               f"(distance to the surface minus r = {ball_mm} mm; tolerance {tol_mm * 1e3:.3f} um)")
    click.echo(f"blocks {text.count(chr(10))}, planning {elapsed:.2f} s")
