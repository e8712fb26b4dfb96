"""`vcnc run` and `vcnc plot` end to end: summaries, traces, plots, refusals."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from machine.cli import main
from machine.trace import load_trace

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "programs" / "demo.nc"
MACHINE = (ROOT / "ipo" / "machine.toml").read_text()


def vcnc(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    if result.exception and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def summary(result) -> dict:
    return json.loads(result.stdout.strip().splitlines()[-1])


def machine_file(tmp_path, old: str, new: str) -> Path:
    assert old in MACHINE
    path = tmp_path / "m.toml"
    path.write_text(MACHINE.replace(old, new, 1))
    return path


def test_demo_runs_along_the_programmed_path(tmp_path):
    r = vcnc("run", DEMO, "--json")
    assert r.exit_code == 0, r.stderr
    s = summary(r)
    assert s["state"] == "completed" and s["motions"] == 8
    # rapid up 5, plunge 5, line 20, quarter arc r10, line 10, NURBS quarter circle r10, line 20, rapid 5;
    # G64 P0.01 may cut each corner by at most 0.01 mm
    length = 5 + 5 + 20 + 5 * math.pi + 10 + 5 * math.pi + 20 + 5
    assert s["path_length_mm"] == pytest.approx(length, abs=0.1)
    assert s["position_mm"] == pytest.approx([0, 30, 5])
    assert s["cycle_time_s"] == pytest.approx(s["periods"] * 1e-3)
    assert s["cycle_time_s"] > length / 100  # no faster than the axis limits allow
    assert all(v <= 100 + 1 for v in s["max_axis_velocity_mm_s"])
    assert s["limit_violations"] == 0
    assert 0 < s["max_chord_error_um"] < 1.5  # chord tolerance 1 µm, estimate within a third of a BLU
    assert s["max_contour_error_um"] is None and s["deadline_misses"] is None
    assert s["realtime_factor"] > 0


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
@pytest.mark.slow
def test_trace_and_plot(tmp_path, suffix):
    trace_path, png = tmp_path / f"t{suffix}", tmp_path / "run.png"
    r = vcnc("run", DEMO, "--json", "--trace", trace_path, "--plot", png)
    assert r.exit_code == 0, r.stderr
    s = summary(r)
    tr = load_trace(trace_path)
    assert len(tr) == s["periods"]
    assert tr["t_s"][-1] == pytest.approx(s["cycle_time_s"])
    end_blu = np.rint(np.array([0, 30, 5]) / 1e-3).astype(np.int64)
    start_blu = np.rint(tr["pos_mm"][0] / 1e-3).astype(np.int64) - tr["inc_blu"][0]
    assert np.array_equal(start_blu + tr["inc_blu"].sum(axis=0), end_blu)
    assert set(np.unique(tr["line"])) <= set(range(3, 18))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = tmp_path / "again.png"
    r = vcnc("plot", trace_path, "--out", out)
    assert r.exit_code == 0 and out.stat().st_size > 10_000


def test_feed_override_and_period_change_the_run():
    base = summary(vcnc("run", DEMO, "--json"))
    slow = summary(vcnc("run", DEMO, "--json", "--feed-override", "50"))
    coarse = summary(vcnc("run", DEMO, "--json", "--period-ms", "2"))
    assert slow["cycle_time_s"] > 1.3 * base["cycle_time_s"]
    assert coarse["periods"] == pytest.approx(base["periods"] / 2, rel=0.05)
    assert coarse["cycle_time_s"] == pytest.approx(base["cycle_time_s"], rel=0.05)


def test_program_errors_refuse_the_run_with_every_reason(tmp_path):
    bad = tmp_path / "bad.nc"
    bad.write_text("G21 G90\nG1 X10 F600\nG1 G2 X5\nG1 X20 Y10\nG33 X3 K1\nM2\n")
    trace_path = tmp_path / "t.npz"
    r = vcnc("run", bad, "--trace", trace_path)
    assert r.exit_code == 1
    errors = [line for line in r.stderr.splitlines() if "error" in line]
    assert any(":3:" in e for e in errors) and any(":5:" in e for e in errors)
    assert "no axis moved" in r.stderr and not trace_path.exists()


def test_travel_limits_refuse_the_run_naming_each_line(tmp_path):
    m = machine_file(tmp_path, "max_mm = 1000.0", "max_mm = 25.0")  # the X axis only
    r = vcnc("run", DEMO, "--machine", m, "--json")
    assert r.exit_code == 1 and r.stdout == ""
    reasons = [line for line in r.stderr.splitlines() if "E-TRAVEL" in line]
    lines = sorted(int(x.split(":")[1]) for x in reasons)
    assert lines == [6, 7, 9]  # the arc to X30, the line at X30, the NURBS through X30
    assert all("above the travel limit 25.0000 mm" in x and "X reaches 30.0000" in x for x in reasons)


def test_machine_file_errors_name_the_key(tmp_path):
    r = vcnc("run", DEMO, "--machine", tmp_path / "missing.toml")
    assert r.exit_code != 0 and "missing.toml" in r.stderr
    m = machine_file(tmp_path, "max_accel_mm_s2 = 1000.0", "max_accel_mm_s2 = -3")
    r = vcnc("run", DEMO, "--machine", m)
    assert r.exit_code != 0 and "axes.x.max_accel_mm_s2" in r.stderr


def test_servo_model_reports_contour_error(tmp_path):
    m = machine_file(tmp_path, 'model = "none"', 'model = "lag"').read_text()
    m = m.replace("time_constant_s = 0.0", "time_constant_s = 0.01")
    path = tmp_path / "servo.toml"
    path.write_text(m)
    s = summary(vcnc("run", DEMO, "--machine", path, "--json"))
    # on the r = 10 arcs at v <= 50 mm/s a 10 ms lag stays inside by at most R(1 - 1/sqrt(1 + (v·tau/R)²))
    # plus what corners add; it must be well above the BLU and below the following error v·tau
    assert 1.0 < s["max_contour_error_um"] < 50 * 0.01 * 1e3


def test_m0_without_a_terminal_resumes_and_realtime_counts_deadlines(tmp_path):
    prog = tmp_path / "m0.nc"
    prog.write_text("G21 G90 G64\nG1 X5 F3000\nM0\nG1 X10\nM1\nG1 X12\nM2\n")
    r = vcnc("run", prog, "--json")
    s = summary(r)
    assert s["program_stops"] == [3] and s["position_mm"] == pytest.approx([12, 0, 0])
    assert "M0 program stop at line 3" in r.stderr
    r = vcnc("run", prog, "--json", "--realtime", "--optional-stop")
    s = summary(r)
    assert r.exit_code == 0 and s["program_stops"] == [3, 5]
    assert s["position_mm"] == pytest.approx([12, 0, 0])
    assert isinstance(s["deadline_misses"], int)
    assert s["realtime_factor"] < 1.5  # paced at the period, not as fast as possible
