"""`vcnc interp`: step every motion of a program at a constant chord and report how
constant the chords are, how many curve evaluations it took and how fast it ran."""
from __future__ import annotations

import json
import math
from pathlib import Path

import click

from machine.commands import INPUT_FILE, OutputPath, refusal


MAX_STEPS = 20_000_000  # steps (or pulses) of one study: its arrays stay within about a gigabyte


def _check_steps(program, step_um: float, option: str) -> None:
    """Refuse a step that is not a length, or so small that the study would not end in memory."""
    from machine.program_summary import path_length_mm

    if not (math.isfinite(step_um) and step_um > 0):
        raise click.BadParameter(f"must be a length > 0, got {step_um:g}", param_hint=option)
    length_mm = sum(path_length_mm(e) for e in program.entities)
    steps = length_mm / (step_um * 1e-3)
    if steps > MAX_STEPS:
        raise click.BadParameter(f"{step_um:g} um along the program's {length_mm:.6g} mm of path is {steps:.3g} steps; "
                                 f"at most {MAX_STEPS:,} (a step of at least {length_mm * 1e3 / MAX_STEPS:.3g} um)",
                                 param_hint=option)


@click.command()
@click.argument("file", type=INPUT_FILE)
@click.option("--step-um", type=float, default=None,
              help="Chord D in micrometres (default: 1 BLU with --pulse, else 100).")
@click.option("--method", type=click.Choice(["recursive", "taylor1", "taylor2", "constant-du"]),
              default="recursive", show_default=True, help="NURBS parameter update.")
@click.option("--n1", type=int, default=2, show_default=True, help="Increments per period (000 eq. 9).")
@click.option("--m1", type=int, default=3, show_default=True, help="Start-up increments (000 eq. 14).")
@click.option("--start-tol-pct", type=float, default=None,
              help="Start-up search to this chord error in % (000 §2.2.1) instead of m1.")
@click.option("--chord-tol-pct", type=float, default=None,
              help="Adaptive mode: refine every period until the chord is within this % of D.")
@click.option("--max-evals", type=int, default=8, show_default=True,
              help="Cap on curve evaluations per period in the adaptive mode.")
@click.option("--du", type=float, default=0.02, show_default=True, help="Parameter step of constant-du.")
@click.option("--pulse", is_flag=True, help="Also drive reference pulses (000 §2.4) and measure them.")
@click.option("--blu-um", type=float, default=1.0, show_default=True, help="BLU in micrometres for --pulse.")
@click.option("--out", type=OutputPath((".npz", ".csv")), default=None,
              help="Write the points (pos_mm, N x 3) and parameters (u, N) to .npz or .csv.")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as JSON.")
def command(file, step_um, method, n1, m1, start_tol_pct, chord_tol_pct, max_evals, du, pulse, blu_um, out,
            as_json):
    """Interpolate every motion entity of FILE at a constant chord D (no feed planning)."""
    from ipo.errors import IpoError
    from ipo.interp.chord_study import pulse_study, study
    from ipr import parse_file
    from ipr.entities import GCodeError

    if step_um is None:
        step_um = blu_um if pulse else 100.0
    try:
        program = parse_file(file)
    except GCodeError as exc:
        raise click.ClickException(str(exc)) from exc
    _check_steps(program, step_um, "--step-um")
    if pulse:
        _check_steps(program, blu_um, "--blu-um")
    if not 0 < du <= 1:
        raise click.BadParameter(f"must be in (0, 1], got {du:g}", param_hint="--du")
    options = dict(method=method, n1=n1, m1=m1, start_tol_pct=start_tol_pct, chord_tol_pct=chord_tol_pct,
                   max_evals=max_evals, du=du)
    try:
        result = study(program.entities, step_um / 1000.0, **options)
        pulse_dev = pulse_study(program.entities, blu_um / 1000.0, result.pos_mm) if pulse else None
    except IpoError as err:
        raise refusal(err, file) from None
    summary = result.summary()
    if pulse_dev is not None:
        summary["pulse_dev_blu"] = pulse_dev
    if out is not None:
        import numpy as np  # here, not at the top: `vcnc interp --help` does not load numpy

        if Path(out).suffix.lower() == ".npz":
            np.savez(out, pos_mm=result.pos_mm, u=result.u)
        else:
            np.savetxt(out, np.column_stack([result.pos_mm, result.u]), delimiter=",",
                       header="x_mm,y_mm,z_mm,u", comments="")
    if as_json:
        click.echo(json.dumps(summary))
        return
    setting = f"n1={n1} m1={m1}" if method == "recursive" else (f"du={du}" if method == "constant-du" else "")
    if method == "recursive" and start_tol_pct is not None:
        setting += f" start-up e={start_tol_pct}%"
    if method == "recursive" and chord_tol_pct is not None:
        setting = f"adaptive E={chord_tol_pct}% max {max_evals} evals, m1={m1}"
    click.echo(f"{file}: method {method} {setting}, D = {step_um:g} um")
    click.echo(f"steps                 {summary['steps']}")
    click.echo(f"|chord/D - 1|         max {summary['max_dev_pct']:.4f} %   rms {summary['rms_dev_pct']:.4f} %"
               "   (each entity's final clamped partial step excluded)")
    click.echo(f"evaluations per step  mean {summary['evals_mean']:.3f}   max {summary['evals_max']}"
               "   (NURBS periods, output point included)")
    click.echo(f"start-up evaluations  {summary['startup_evals']}   (largest over the NURBS entities)")
    click.echo(f"steps per second      {summary['steps_per_s']:.3g}")
    if pulse_dev is not None:
        click.echo(f"pulse path deviation  {pulse_dev:.3f} BLU   (BLU = {blu_um:g} um, "
                   "largest distance from the curve)")
    if out is not None:
        click.echo(f"wrote {out}")
