"""`vcnc fit IN.nc -o OUT.nc --tol-mm T [--degree 3] [--corner-deg 30] [--jobs N]`: G01 runs -> G06.2.

Fits every run of consecutive G01 moves with 001's rational B-spline approximation
(the fewest control points within T of the polyline, both ways) and writes the
program with each fitted run as a Fanuc G06.2 group; everything else is copied.
Prints runs, blocks and bytes before/after, the largest deviation and the fit time.
"""
from __future__ import annotations

import sys

import click

from machine.commands import INPUT_FILE, OutputPath


def format_report(rep, tol_mm: float) -> str:
    ratio_blocks = rep.blocks_before / max(rep.blocks_after, 1)
    ratio_bytes = rep.bytes_before / max(rep.bytes_after, 1)
    lines = [
        f"tolerance        {tol_mm * 1e3:.3f} um",
        f"G01 runs         {rep.runs} ({rep.short_runs} too short to fit, kept as G01)",
        f"G06.2 groups     {rep.groups} replacing {rep.moves_replaced} G01 moves",
        f"kept as G01      {len(rep.kept_g01)} pieces (no fit within tolerance that saves blocks)",
        f"blocks           {rep.blocks_before} -> {rep.blocks_after}  ({ratio_blocks:.2f}x fewer;"
        f" no conversion of these runs can go below {rep.blocks_bound}:"
        f" {rep.blocks_before / max(rep.blocks_bound, 1):.2f}x)",
        f"bytes            {rep.bytes_before} -> {rep.bytes_after}  ({ratio_bytes:.2f}x fewer)",
        f"max deviation    {rep.max_deviation_mm * 1e3:.3f} um (checked on the curves as written)",
        f"fit time         {rep.fit_time_s:.2f} s",
    ]
    for line, why in rep.kept_g01[:10]:
        lines.append(f"  kept G01 from line {line}: {why}")
    if len(rep.kept_g01) > 10:
        lines.append(f"  ... and {len(rep.kept_g01) - 10} more")
    return "\n".join(lines)


@click.command("fit")
@click.argument("src", type=INPUT_FILE)
@click.option("-o", "--output", "out", required=True, type=OutputPath(),
              help="Where to write the converted program.")
@click.option("--tol-mm", "tol_mm", required=True, type=float,
              help="Largest distance allowed between the curve and the G01 path, mm.")
@click.option("--degree", default=3, show_default=True, type=int, help="Curve degree (G06.2 P = degree + 1).")
@click.option("--corner-deg", default=30.0, show_default=True, type=float,
              help="A turn sharper than this between two moves ends a run.")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="Worker processes for the fits  [default: one per core].")
def command(src: str, out: str, tol_mm: float, degree: int, corner_deg: float, jobs: int | None) -> None:
    """Replace G01 runs by rational B-spline G06.2 groups within a tolerance."""
    from ipr.entities import GCodeError
    from ipo.fit.convert import convert_text

    if not tol_mm > 0:
        raise click.BadParameter(f"must be > 0, got {tol_mm}", param_hint="--tol-mm")
    if not 1 <= degree <= 5:
        raise click.BadParameter(f"must be 1..5 (G06.2 order 2..6), got {degree}", param_hint="--degree")
    if not 0 <= corner_deg <= 180:
        raise click.BadParameter(f"must be 0..180, got {corner_deg}", param_hint="--corner-deg")
    with open(src, "rb") as f:
        text = f.read().decode("utf-8", "replace")
    try:
        result, report = convert_text(text, tol_mm, degree=degree, corner_deg=corner_deg, file=src, jobs=jobs)
    except GCodeError as err:
        click.echo(f"{src}: the program has errors; fix them before fitting:\n{err}", err=True)
        sys.exit(1)
    with open(out, "w", encoding="utf-8", newline="") as f:
        f.write(result)
    click.echo(f"{src} -> {out}")
    click.echo(format_report(report, tol_mm))
