"""`vcnc fit` on a cold numba cache says that it compiles and how to avoid the wait (`vcnc warmup`), as `vcnc run`
does; numba's compile events are raised here by hand, no kernel is compiled."""
from __future__ import annotations

import time

from click.testing import CliRunner

from machine.cli import main
from machine.commands.compiling import Compiling

PROGRAM = "G21 G90 G17\nG0 X0 Y0 Z0\nG1 X1 Y0 F600\nX2 Y0.1\nX3 Y0.3\nM2\n"


def _compiles(times: int):
    """A stand-in for loading the fit's kernels: `times` compiles, each with a kernel it calls compiled inside."""
    from numba.core import event

    def load():
        for _ in range(times):
            with event.trigger_event("numba:compile"), event.trigger_event("numba:compile"):
                time.sleep(0.001)
    return load


def test_vcnc_fit_says_once_that_numba_compiles_and_how_long_it_took(tmp_path, monkeypatch):
    monkeypatch.setattr("machine.commands.warmup.load_fit_kernels", _compiles(2))
    src, dst = tmp_path / "in.nc", tmp_path / "out.nc"
    src.write_text(PROGRAM)
    res = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "0.01", "--jobs", "1"])
    assert res.exit_code == 0, res.output
    notice = [line for line in res.stderr.splitlines() if Compiling.COMPILING in line]
    assert len(notice) == 1 and "vcnc warmup" in notice[0]
    assert res.output.index(Compiling.COMPILING) < res.output.index("blocks")  # before the fit's report
    took = [line for line in res.stderr.splitlines() if line.startswith("numba compiled its kernels for")]
    assert len(took) == 1 and "this fit's wall time" in took[0] and "vcnc warmup" in took[0]


def test_compiles_in_a_forked_worker_are_not_the_commands():
    from numba.core import event

    with Compiling() as compiling:
        said = []
        compiling.on_change = said.append
        compiling.pid = -1  # as in a worker forked with the listener registered
        with event.trigger_event("numba:compile"):
            pass
    assert said == [] and compiling.summary("fit") is None
