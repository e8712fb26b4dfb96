"""`vcnc grbl ...` sender features against the grbl test double: what reaches grbl and
what it does, checked against grbl 1.1's documented behaviour."""
from __future__ import annotations

from pathlib import Path

import pytest

from click.testing import CliRunner

from grbl_emulator import DEFAULT_SETTINGS, GrblDouble, PtyServer
from ipo.config import default_config
from machine.cli import main

DEMO = Path(__file__).resolve().parents[3] / "programs" / "demo.nc"


def _grbl(args, port, stdin=None):
    return CliRunner().invoke(main, ["grbl", *args, "--port", port], input=stdin)


def test_home_unlock_and_status():
    d = GrblDouble(mpos=(3.0, 4.0, 5.0), settings={**DEFAULT_SETTINGS, 22: 1})
    d.alarm_lock, d.state = True, "Alarm"
    with PtyServer(d).start() as srv:
        res = _grbl(["unlock"], srv.port)
        assert res.exit_code == 0, res.output
        assert "Caution: Unlocked" in res.output and d.state == "Idle"
        res = _grbl(["home"], srv.port)
        assert res.exit_code == 0, res.output
        assert d.pos == [0.0, 0.0, 0.0] and "$H" in d.received
        res = _grbl(["status", "--count", "2", "--every", "0.05"], srv.port)
    assert res.exit_code == 0 and res.output.count("Idle") == 2
    assert "X    -5.000 Y     3.000 Z    -1.000" in res.output  # work = machine 0 - WCO (5, -3, 1)


def test_home_without_homing_enabled_is_refused():
    d = GrblDouble()
    with PtyServer(d).start() as srv:
        res = _grbl(["home"], srv.port)
    assert res.exit_code == 1 and "error:5" in res.output


def test_jog_moves_relative_and_leaves_the_modes_alone():
    d = GrblDouble(mpos=(1.0, 1.0, 1.0))
    with PtyServer(d).start() as srv:
        res = _grbl(["jog", "--x", "2.5", "--z", "-1", "--feed", "300"], srv.port)
    assert res.exit_code == 0, res.output
    assert "$J=G21G91X2.5Z-1F300" in d.received
    assert d.pos == [3.5, 1.0, 0.0] and not d.gc.incremental and d.gc.feed == 0.0


def test_check_mode_runs_every_line_and_moves_nothing():
    d = GrblDouble()
    with PtyServer(d).start() as srv:
        res = _grbl(["check", str(DEMO)], srv.port)
    assert res.exit_code == 0, res.output
    assert "accepted all" in res.output
    assert d.executed == [] and d.received.count("$C") == 2 and d.state == "Idle"


def test_settings_saved_from_the_board_run_the_grbl_twin(tmp_path):
    """`--save` keeps the $$ printout as grbl printed it; the twin reads it (rates from the board)."""
    from ipo.grbl_settings import read_dump

    d = GrblDouble(settings={**DEFAULT_SETTINGS, 110: 1234.5, 120: 77.0})
    with PtyServer(d).start() as srv:
        res = _grbl(["settings", "--save", str(tmp_path / "board.txt")], srv.port)
    assert res.exit_code == 0, res.output
    saved = read_dump(tmp_path / "board.txt")
    assert saved.max_rate_mm_min[0] == 1234.5 and saved.accel_mm_s2[0] == 77.0
    assert all(line.startswith("$") for line in (tmp_path / "board.txt").read_text().splitlines())


def test_settings_apply_machine_writes_the_machine_files_values_after_confirming():
    cfg = default_config()
    settings = {**DEFAULT_SETTINGS, 110: 500.0, 121: 10.0}
    d = GrblDouble(settings=settings)
    with PtyServer(d).start() as srv:
        res = _grbl(["settings", "--apply-machine"], srv.port, stdin="n\n")
        assert res.exit_code == 1 and "nothing written" in res.output and d.settings[110] == 500.0
        res = _grbl(["settings", "--apply-machine", "--yes"], srv.port)
    assert res.exit_code == 0, res.output
    assert d.settings[110] == cfg.axes[0].max_velocity_mm_s * 60
    assert d.settings[121] == cfg.axes[1].max_accel_mm_s2
    assert d.settings[132] == cfg.axes[2].max_mm - cfg.axes[2].min_mm


def test_mdi_console_sends_lines_and_reports_answers():
    d = GrblDouble(wco=(0.0, 0.0, 0.0))
    with PtyServer(d).start() as srv:
        res = _grbl(["mdi"], srv.port, stdin="G0 X5 Y-2\n$G\nG5.2\n?\nexit\n")
    assert res.exit_code == 0, res.output
    assert "[GC:G0 G54" in res.output and "error:20" in res.output
    assert d.pos == [5.0, -2.0, 0.0]


def test_job_time_of_one_line_is_the_trapezoid_time():
    """100 mm at 10 mm/s from standstill to standstill: L/v + v/a (trapezoid, no jerk limit)."""
    import dataclasses

    from ipr.entities import Line
    from machine.grbl.estimate import JobEstimate
    from machine.grbl.program import stream_groups

    cfg = dataclasses.replace(default_config(), accel_mode="trapezoid")
    ents = [Line(1, (0.0, 0.0, 0.0), (100.0, 0.0, 0.0), 10.0)]
    est = JobEstimate.plan(stream_groups(ents, cfg), cfg, (0.0, 0.0, 0.0))
    a = min(ax.max_accel_mm_s2 for ax in cfg.axes)
    assert est.total_s == pytest.approx(100.0 / 10.0 + 10.0 / a, abs=3 * cfg.period_s)
    assert est.remaining_s(1) == est.total_s and est.remaining_s(2) == 0.0
