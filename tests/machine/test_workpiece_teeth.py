"""Tooth-pass marks: 002 Table 1's finishing case (r = 3 mm, f_p = 0.2 mm, S = 12500 rpm, 2 flutes,
F5000, T = 1 ms here) cut with the flutes' edges at the period stream's spindle angles, with and without
the roughness limiter, against 002's R_max model at the feed per tooth the controller actually made."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from ipo.config import load_config
from ipo.roughness import rmax_mm
from machine.controller import Controller, start_position
from machine.trace import MemoryTrace
from machine.workpiece.analytic import raster_program
from machine.workpiece.build import build_workpiece

ROOT = Path(__file__).resolve().parents[2]
R_MM, PICK_MM, RPM, FLUTES = 3.0, 0.2, 12500.0, 2
WINDOW_X_MM = (3.0, 5.0)


def cut_with_teeth(tmp_path, limiter: bool, grid_um: float = 20.0):
    config = load_config(ROOT / "programs" / "finish_machine.toml")
    if not limiter:
        config = dataclasses.replace(config, finishing=None)
    path = tmp_path / "raster.nc"
    path.write_text(raster_program(PICK_MM, 11, 8.0, 1.0, 5000.0).replace("S10000", f"S{RPM:g}"))
    ctl = Controller(config)
    program = ctl.check(path)
    wp, _ = build_workpiece(program, config, start_position(program), stock_text="0,0,-3,8,4,0",
                            grid_um=grid_um, teeth=True)
    trace = MemoryTrace({})
    ctl.sinks = [trace, wp]
    assert ctl.run(program).state == "completed"
    tr = trace.close()
    surf = wp.surface()
    ix = (surf.x_mm > WINDOW_X_MM[0]) & (surf.x_mm < WINDOW_X_MM[1])
    iy = (surf.y_mm > 1.4) & (surf.y_mm < 2.6)
    measured_um = float(np.max(surf.z_mm[np.ix_(iy, ix)] + 1.0) * 1e3)  # above the plane the tips follow
    x = tr["pos_mm"][:, 0]
    in_window = (x > WINDOW_X_MM[0] - R_MM) & (x < WINDOW_X_MM[1] + R_MM) & (tr["pos_mm"][:, 2] < -0.99)
    f_i = float(tr["feed_mm_s"][in_window].max()) * 60.0 / (FLUTES * RPM)
    return measured_um, float(rmax_mm(R_MM, f_i, PICK_MM, 0.0) * 1e3), f_i


@pytest.mark.parametrize("limiter", [False, True])
def test_tooth_marks_match_002s_rmax(tmp_path, limiter):
    measured_um, model_um, f_i = cut_with_teeth(tmp_path, limiter)
    print(f"limiter {limiter}: f_i {f_i:.4f} mm, R_max measured {measured_um:.3f} um, model {model_um:.3f} um")
    # a tooth mark's crest lies within g/2 of a node, where its slope is about (f_i / 2) / r
    assert measured_um == pytest.approx(model_um, abs=(f_i / 2) / R_MM * 10.0 + 0.3)
