"""Start-up and first-run throughput contracts of the CLI (issue 22).

`vcnc --help` lists the commands from machine.cli.SHORT_HELP without importing their modules;
these tests check that listing against each command's own docstring, that help loads none of
the heavy libraries, and that `vcnc warmup` compiles every kernel a `vcnc run --plot` and a
`vcnc interp` of the demo and a `vcnc fit` of finish_g01 use, so those compile nothing, and that
interp and run load no library they do not use.
"""
from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import click
import pytest

from machine.cli import COMMANDS, SHORT_HELP

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numpy", "numba", "matplotlib", "lark", "rich")


def _modules_loaded_by(args: list[str], names: tuple[str, ...] = HEAVY) -> list[str]:
    code = ("import sys; from click.testing import CliRunner; from machine.cli import main; "
            f"r = CliRunner().invoke(main, {args!r}); assert r.exit_code == 0, r.output; "
            f"print([m for m in {names!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return json.loads(out.stdout.replace("'", '"'))


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_short_help_is_the_commands_own(name):
    command = importlib.import_module(COMMANDS[name]).command
    assert name in SHORT_HELP, f"machine.cli.SHORT_HELP has no line for {name}"
    for limit in (45, 60, 1000):
        assert click.Command(name, help=SHORT_HELP[name]).get_short_help_str(limit) == command.get_short_help_str(limit)


def test_help_loads_no_heavy_library():
    assert _modules_loaded_by(["--help"]) == []
    for name in ("run", "parse", "plot", "stream", "warmup"):
        assert _modules_loaded_by([name, "--help"]) == [], name


def test_interp_and_run_load_no_library_they_do_not_use():
    # scipy.linalg: numba's BLAS check at its first kernel load (ipo.kernel_cache.spare_scipy_linalg);
    # rich: vcnc parse's table, in the module interp takes path lengths from
    assert _modules_loaded_by(["interp", "programs/demo.nc", "--json"], ("scipy.linalg", "rich", "matplotlib")) == []
    assert _modules_loaded_by(["run", "programs/demo.nc", "--json"], ("scipy.linalg", "matplotlib")) == []


@pytest.mark.slow
def test_warmup_leaves_nothing_to_compile_for_the_demo(tmp_path):
    """From an empty kernel cache, as after an install (the suite's other tests fill the default one)."""
    cli = [sys.executable, "-m", "machine.cli"]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "kernels"))
    warm = subprocess.run(cli + ["warmup"], capture_output=True, text=True, cwd=ROOT, env=env)
    assert warm.returncode == 0, warm.stderr
    assert warm.stdout.startswith("vcnc warmup: ") and "compiled" in warm.stdout
    run = subprocess.run(cli + ["run", "programs/demo.nc", "--json", "--plot", str(tmp_path / "run.png")],
                         capture_output=True, text=True, cwd=ROOT, env=env)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["state"] == "completed"
    assert "numba compiled" not in run.stderr
    # `vcnc interp` compiles nothing either
    assert _kernels_compiled_by(["interp", "programs/demo.nc", "--json"], env) == 0
    # nor does a fit (its kernels took 20-30 s of CPU on the first fit after an install)
    out = str(tmp_path / "fitted.nc")
    fit = ["fit", "programs/finish_g01.nc", "--tol-mm", "0.01", "--jobs", "1", "-o", out]
    assert _kernels_compiled_by(fit, env) == 0


def _kernels_compiled_by(args: list[str], env: dict) -> int:
    code = ("from click.testing import CliRunner; from numba.core import event; from machine.cli import main; n = []; "
            "L = type('L', (event.Listener,), {'on_start': lambda s, e: None, 'on_end': lambda s, e: n.append(e)}); "
            "cm = event.install_listener('numba:compile', L()); cm.__enter__(); "
            f"r = CliRunner().invoke(main, {args!r}); assert r.exit_code == 0, r.output; "
            "print(len(n))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env)
    assert done.returncode == 0, done.stderr
    return int(done.stdout.strip())
