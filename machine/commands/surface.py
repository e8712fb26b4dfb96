"""`vcnc surface POINTS.csv -o SURFACE.igs [--tol-mm T] [--order K] [--ctrl N]`: 001's chain.

Digitised cross-sections -> compatible rational B-spline sections (one control-point
count, the fewest within T, or N) -> skinned surface (optionally patches merged C0/C1)
-> IGES 5.3 (entity 128 surface, entity 126 per section curve). Prints each
section's fit error and the surface's largest deviation from all input points.
"""
from __future__ import annotations

import os
import time

import click

from machine.commands import INPUT_FILE, OutputPath, refusal


@click.command("surface")
@click.argument("points", type=INPUT_FILE)
@click.option("-o", "--output", "out", required=True, type=OutputPath((".igs", ".iges")), help="IGES file to write.")
@click.option("--tol-mm", "tol_mm", default=0.05, show_default=True, type=float,
              help="Largest point error allowed per section; sets the control-point count.")
@click.option("--order", default=4, show_default=True, type=int, help="B-spline order k (degree k - 1).")
@click.option("--ctrl", "n_ctrl", type=int, help="Control points per section (overrides the tolerance search).")
@click.option("--patch-sections", type=int,
              help="Skin patches of this many sections and merge them (001 eq. 17-18).")
@click.option("--continuity", type=click.Choice(["C0", "C1"]), default="C0", show_default=True,
              help="Continuity across merged patches.")
def command(points, out, tol_mm, order, n_ctrl, patch_sections, continuity) -> None:
    """Fit digitised cross-sections, skin them into a rational surface and write IGES."""
    import numpy as np

    from ipo.errors import IpoError
    from ipo.surface.iges import RationalCurve, write_iges
    from ipo.surface.section_fit import fit_sections
    from ipo.surface.sections import orient_like_first, read_sections
    from ipo.surface.skinning import deviation_from_points, skin_patches

    if not tol_mm > 0:
        raise click.BadParameter(f"must be > 0, got {tol_mm}", param_hint="--tol-mm")
    if not 2 <= order <= 6:
        raise click.BadParameter(f"must be 2..6, got {order}", param_hint="--order")
    try:
        secs, flipped = orient_like_first(read_sections(points, min_points=order))
        t0 = time.perf_counter()
        fits = fit_sections(secs.points, degree=order - 1, tol_mm=tol_mm, n_ctrl=n_ctrl)
        t1 = time.perf_counter()
        skinned = skin_patches(fits.fits, patch_sections, continuity)
        t2 = time.perf_counter()
        dev = deviation_from_points(skinned.surface, fits.fits, secs.points, skinned.section_v)
        curves = [RationalCurve(f.degree, f.knots, f.weights, f.points) for f in fits.fits]
        write_iges(out, [skinned.surface], curves, description=f"vcnc surface from {os.path.basename(points)}")
    except IpoError as err:
        raise refusal(err, points) from None
    surf = skinned.surface
    n_pts = sum(len(q) for q in secs.points)
    kind = "shared rational weights" if fits.rational else "weights 1 (a polynomial fit met the tolerance)"
    click.echo(f"{points}: {len(secs)} sections, {n_pts} points")
    if flipped:
        click.echo("reversed to run like the first section (zig-zag digitising): sections "
                   + ", ".join(secs.labels[h] for h in flipped))
    click.echo(f"sections: order {order}, {fits.n_ctrl} control points each, uniform knots "
               f"0..{fits.fits[0].knots[-1]:g}, {kind}; {len(fits.rms_history)} iterations")
    click.echo(f"{'section':>10} {'line':>6} {'points':>7} {'max err um':>11} {'rms um':>9}")
    for label, line, q, e, r in zip(secs.labels, secs.first_lines, secs.points, fits.max_error_mm, fits.rms_mm):
        flag = "" if e <= tol_mm else "  over tolerance"
        click.echo(f"{label:>10} {line:>6} {len(q):>7} {e * 1e3:>11.3f} {r * 1e3:>9.3f}{flag}")
    patches = "" if len(skinned.patches) == 1 else f", {len(skinned.patches)} patches merged {continuity}"
    click.echo(f"surface: {surf.weights.shape[0]} x {surf.weights.shape[1]} control points, "
               f"degree {surf.degree_u} x {surf.degree_v}{patches}")
    click.echo(f"deviation from all input points: max {dev.max() * 1e3:.3f} um, "
               f"rms {np.sqrt(np.mean(dev**2)) * 1e3:.3f} um")
    click.echo(f"fit {t1 - t0:.2f} s, skinning {t2 - t1:.3f} s")
    click.echo(f"wrote {out} (1 surface entity 128, {len(curves)} section curves entity 126)")
