"""`vcnc warmup`: compile the numba kernels of a run once, right after an install.

Why an explicit step: numba compiles a kernel on its first call and caches the machine code
(`cache=True`) in a directory keyed by the kernels' source (ipo/kernel_cache.py), the numba
version and the CPU. The cache is therefore made on the machine that runs vcnc, once per install
(and again after a kernel changes); it cannot ship in the repository. The warm-up also deletes
the caches of other source versions unused for a week (an upgrade leaves the old one behind).
Compiling the kernels a run uses takes 8-12 s of CPU time (numba's LLVM passes, mostly the
look-ahead's `backward` and the steppers' `_walk`, which inline their callees). Done by
`vcnc warmup` in the install command, a user's first `vcnc run` loads cached kernels instead
of compiling them (measured figures: bench/run.py).

The warm-up runs a short built-in program through the same check → plan → interpolate → drive
path as `vcnc run` (a G0, G1, a G2 and a G3 arc and a rational NURBS, each interpolator method,
then once on each controller twin),
with the digest that --plot and --report draw from and nothing written, so it compiles exactly the kernel signatures that path uses;
then it interprets a few hundred plain moves, for the interpreter's own kernels (ipr.plain_runs).
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import click

from ipo.kernel_cache import prune_other_versions
from machine.commands import load_machine

OLD_CACHE_S = 7 * 86400.0

# The demo's shapes: a rapid, feeds, both arc directions and a rational quadratic NURBS (quarter circle),
# and a corner between an arc and a line (its blend is checked by other kernels than a line corner's).
WARMUP_PROGRAM = """\
G21 G17 G90 G94 G64 P0.01
G0 X0 Y0 Z5
G1 Z0 F600
G1 X20 Y0 F3000
G3 X30 Y10 I0 J10
G2 X40 Y20 I10 J0
G1 X40 Y25
G1 X30 Y20
G06.2 P3 K0 X30 Y20 Z0 R1 F3000
K0 X30 Y30 R0.70710678
K0 X20 Y30 R1
K1
K1
K1
G1 X0 Y30
G0 Z5
M2
"""


@click.command("warmup")
@click.option("--machine", "machine_file", type=click.Path(exists=True, dir_okay=False),
              help="Machine TOML (default: built in).")
def command(machine_file):
    """Compile the numba kernels of a run now (once per install), so the first run does not wait."""
    from numba.core import event

    import dataclasses

    from ipo.config import METHODS, PLANNERS
    from ipr import parse_text
    from ipr.interpreter import SCAN_LINES
    from machine.controller import Controller
    from machine.report.digest import DigestSink

    config = load_machine(machine_file)
    compiled = []
    listener = type("L", (event.Listener,), {"on_start": lambda _, ev: None,
                                             "on_end": lambda _, ev: compiled.append(ev)})()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch, event.install_listener("numba:compile", listener):
        path = Path(scratch) / "warmup.nc"
        path.write_text(WARMUP_PROGRAM)
        # each interpolator on the machine file's planner, then once on each other planner (the twins)
        runs = [(config, m) for m in METHODS] + [(dataclasses.replace(config, planner=p), METHODS[0])
                                                  for p in PLANNERS if p != config.planner]
        for cfg, method in runs:
            controller = Controller(cfg, method=method)
            digest = DigestSink(controller.limits.meta(), servo=config.servo.model != "none")
            controller.sinks = [digest]  # what `vcnc run --plot/--report` adds
            result = controller.run(controller.check(path))
            digest.finish()
            if result.state != "completed":
                raise click.ClickException(f"warm-up run {cfg.planner} {method}: {result.state}: {result.fault}")
        # the interpreter's kernels for long stretches of plain moves (ipr.plain_runs), which a
        # program as short as the one above does not reach
        parse_text("G21 G90 G0 X0 Y0\nG1 X1 F100\n" + " X2 Y1\n X1 Y2\n" * SCAN_LINES + "M2\n")
    removed, freed = prune_other_versions(Path(os.environ["NUMBA_CACHE_DIR"]), OLD_CACHE_S)
    if removed:
        click.echo(f"vcnc warmup: removed {removed} cache(s) of other vcnc versions ({freed / 1e6:.1f} MB)")
    click.echo(f"vcnc warmup: {len(compiled)} kernel signature(s) compiled in {time.perf_counter() - t0:.1f} s"
               if compiled else "vcnc warmup: every kernel was already compiled (cached)")
