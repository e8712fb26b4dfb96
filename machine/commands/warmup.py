"""`vcnc warmup`: compile the numba kernels of a run once, right after an install.

Why an explicit step: numba compiles a kernel on its first call and caches the machine code
(`cache=True`) in a directory keyed by the kernels' source (ipo/kernel_cache.py), the numba
version and the CPU. The cache is therefore made on the machine that runs vcnc, once per install
(and again after a kernel changes); it cannot ship in the repository. The warm-up also deletes
the caches of other source versions unused for a week (an upgrade leaves the old one behind).
Compiling the kernels takes 1.5-2 minutes of CPU time (97 s measured; numba's LLVM passes, mostly the
look-ahead's `backward` and the steppers' `_walk`, which inline their callees). Done by
`vcnc warmup` in the install command, a user's first `vcnc run` loads cached kernels instead
of compiling them (measured figures: bench/run.py).

The warm-up runs a short built-in program through the same check → plan → interpolate → drive
path as `vcnc run` (a G0, G1, a G2 and a G3 arc and a rational NURBS, each interpolator method,
then once on each controller twin),
with the digest that --plot and --report draw from and nothing written, so it compiles exactly the kernel signatures that path uses;
then it steps the program at a constant chord as `vcnc interp` does, interprets a few hundred
plain moves, for the interpreter's own kernels (ipr.plain_runs), and fits a short wave of G1 moves
as `vcnc fit` does (its kernels took 20-30 s of CPU on a first fit).
"""
from __future__ import annotations

import math
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


# A wave of 0.5 mm G1 chords turning through a sharp corner: conic spans, a corner kept sharp, a group.
FIT_WARMUP_PROGRAM = "G21 G17 G90 G94\nG0 X0 Y0 Z0\nG1 F3000\n" + "".join(
    f"X{0.5 * i:.4f} Y{(5 * math.sin(0.05 * i) if i < 60 else 5 * math.sin(3) + 0.5 * (i - 60)):.4f} "
    f"Z{math.cos(0.03 * i) - 1:.4f}\n" for i in range(1, 120)) + "M2\n"


@click.command("warmup")
@click.option("--machine", "machine_file", type=click.Path(exists=True, dir_okay=False),
              help="Machine TOML (default: built in).")
def command(machine_file):
    """Compile the numba kernels of a run now (once per install), so the first run does not wait."""
    from numba.core import event

    config = load_machine(machine_file)
    compiled = []
    listener = type("L", (event.Listener,), {"on_start": lambda _, ev: None,
                                             "on_end": lambda _, ev: compiled.append(ev)})()
    t0 = time.perf_counter()
    with event.install_listener("numba:compile", listener):
        exercise(config)
    removed, freed = prune_other_versions(Path(os.environ["NUMBA_CACHE_DIR"]), OLD_CACHE_S)
    if removed:
        click.echo(f"vcnc warmup: removed {removed} cache(s) of other vcnc versions ({freed / 1e6:.1f} MB)")
    click.echo(f"vcnc warmup: {len(compiled)} kernel signature(s) compiled in {time.perf_counter() - t0:.1f} s"
               if compiled else "vcnc warmup: every kernel was already compiled (cached)")


def exercise(config) -> None:
    """Run the warm-up's programs on config (the machine file; the default when None): every
    kernel they call is compiled, or loaded from the cache (`vcnc serve` keeps them loaded)."""
    import dataclasses

    from ipo.config import METHODS, PLANNERS, default_config
    from ipo.interp.chord_study import study
    from ipr import parse_text
    from ipr.interpreter import SCAN_LINES
    from machine.controller import Controller
    from machine.report.digest import DigestSink

    config = config or default_config()
    with tempfile.TemporaryDirectory() as scratch:
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
        # `vcnc interp`'s steppers (one signature serves every method and option: they are values)
        study(parse_text(WARMUP_PROGRAM).entities, 0.5)
        # the interpreter's kernels for long stretches of plain moves (ipr.plain_runs), which a
        # program as short as the one above does not reach
        parse_text("G21 G90 G0 X0 Y0\nG1 X1 F100\n" + " X2 Y1\n X1 Y2\n" * SCAN_LINES + "M2\n")
        load_fit_kernels()


def load_fit_kernels() -> None:
    """`vcnc fit`'s kernels (its spans, deviation bounds and the controller's check of each group), compiled or
    loaded in this process: FIT_WARMUP_PROGRAM fitted here on the default machine (the kernels are the same
    on any). A fit's worker processes, forked after this, share them; on a cold cache each would compile them."""
    from ipo.config import default_config
    from machine.commands.fit import fit_text

    fit_text(FIT_WARMUP_PROGRAM, 0.01, default_config(), jobs=1)
