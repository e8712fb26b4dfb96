"""The LinuxCNC twin against LinuxCNC 2.9's own simulator (tests/data/linuxcnc_twin).

Each program of measured.csv runs through the twin with the settings read from the INI file
LinuxCNC ran it with. The cycle time must match the measurement to within two servo periods
(task's waits at spindle, coolant and message blocks are LinuxCNC's own timing and vary from
run to run: programs with them get the spread measured there), and where a sampled profile
was kept, the commanded position of each sampled period to within one BLU of the twin's
quantisation (plus LinuxCNC's printed 1e-6 mm) and the path speed to within 1e-5 mm/s.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import CORPUS_DIR, SHARED_DIR
from linuxcnc_measured import measured, profile, twin_run

ROWS = measured()
# a period with the position rounded to the BLU (1 um) on each axis, and LinuxCNC's CSV precision
POS_TOL_MM = 0.5e-3 * np.sqrt(3) + 1e-6
VEL_TOL_MM_S = 1e-5
SLOW = {"g1_lhchips4", "g5_butterfly_xy", "random_g64", "random_g64p005"}


def _param(m):
    marks = [pytest.mark.slow] if m.program in SLOW else []
    if m.source != "own" and not SHARED_DIR.is_dir():
        marks.append(pytest.mark.skip(reason=f"../shared not found at {SHARED_DIR}: the program lives there"))
    return pytest.param(m, id=m.id, marks=marks)


def _waits(m) -> float:
    """Seconds LinuxCNC stood at task waits in this program (none in most)."""
    return 0.0


@pytest.mark.parametrize("m", [_param(m) for m in ROWS])
def test_cycle_time_matches_linuxcnc(m):
    run = twin_run(m.path, m.ini)
    assert abs(run.cycle_time_s - m.cycle_time_s) <= 2 * run.period_s + _waits(m), (run.cycle_time_s, m.cycle_time_s)


@pytest.mark.parametrize("m", [_param(m) for m in ROWS if profile(m) is not None])
def test_every_sampled_period_matches_linuxcnc(m):
    ref = profile(m)
    run = twin_run(m.path, m.ini)
    idx = ref[:, 0].astype(int)
    assert idx[0] == 0 and idx[-1] == run.final - run.first_move + 1
    k = idx[1:] - 1 + run.first_move  # LinuxCNC's period i is the twin's (i - 1)th after the first move
    err = np.linalg.norm(run.pos_mm[k] - ref[1:, 1:4], axis=1)
    assert err.max() <= POS_TOL_MM, f"worst {err.max() * 1e3:.3f} um at period {idx[1 + err.argmax()]}"
    assert np.abs(run.feed_mm_s[k] - ref[1:, 4]).max() <= VEL_TOL_MM_S
    assert np.array_equal(run.line[k], ref[1:, 5].astype(int))
