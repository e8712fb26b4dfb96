"""--planner linuxcnc and --linuxcnc-ini end to end: `vcnc run` and `vcnc compare` run a program
as LinuxCNC 2.9 would, with the machine its INI file describes, and take as long as LinuxCNC's
own simulator took (tests/data/linuxcnc_twin)."""
from __future__ import annotations

import json
from pathlib import Path

from tests.machine.test_run_cli import vcnc

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "linuxcnc_twin"
PROGRAM = DATA / "programs" / "mix_lines_arcs.ngc"
INI = DATA / "ini" / "axes.ini"  # X 80/800, Y 60/500, Z 30/300 mm/s, mm/s^2; LinuxCNC took 15.028 s
MACHINE = (ROOT / "ipo" / "machine.toml").read_text()


def _summary(*args):
    r = vcnc("run", PROGRAM, "--json", *args)
    assert r.exit_code == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_run_with_the_machines_ini_takes_linuxcncs_time_and_checks_its_limits(tmp_path):
    s = _summary("--planner", "linuxcnc", "--linuxcnc-ini", INI)
    assert s["planner"] == f"LinuxCNC 2.9 twin: {INI}" and s["state"] == "completed"
    # LinuxCNC's 15.028 s and the last segment's closing period (it ends standing)
    assert abs(s["cycle_time_s"] - 15.028) <= 0.002
    # the drive checked the INI's axis limits, not the machine file's 100 mm/s
    assert s["limits_checked"].startswith("80 60 30 mm/s; 800 500 300 mm/s^2") and s["limit_violations"] == 0


def test_the_machine_file_names_the_ini_file(tmp_path):
    (tmp_path / "mill.ini").write_text(INI.read_text())
    m = tmp_path / "m.toml"
    m.write_text(MACHINE.replace('planner = "vcnc"', 'planner = "linuxcnc"') + '\n[linuxcnc]\nini = "mill.ini"\n')
    by_file = _summary("--machine", m)
    assert by_file["planner"] == f"LinuxCNC 2.9 twin: {tmp_path / 'mill.ini'}"
    assert by_file["cycle_time_s"] == _summary("--planner", "linuxcnc", "--linuxcnc-ini", INI)["cycle_time_s"]
    # vcnc's own planner runs on the same (the INI's) machine, and faster than LinuxCNC
    vcnc_own = _summary("--machine", m, "--planner", "vcnc")
    assert vcnc_own["planner"] == "vcnc" and vcnc_own["cycle_time_s"] < by_file["cycle_time_s"]
    assert vcnc_own["limits_checked"].startswith("80 60 30 mm/s")


def test_a_bad_ini_file_is_refused_naming_its_key(tmp_path):
    bad = tmp_path / "bad.ini"
    bad.write_text(INI.read_text().replace("MAX_ACCELERATION = 500", "MAX_ACCELERATION = lots", 1))
    r = vcnc("run", PROGRAM, "--planner", "linuxcnc", "--linuxcnc-ini", bad)
    assert r.exit_code == 2 and "[AXIS_Y]MAX_ACCELERATION: 'lots' is not a number" in r.stderr
    m = tmp_path / "m.toml"
    m.write_text(MACHINE + '\n[linuxcnc]\nini = "bad.ini"\n')
    r = vcnc("run", PROGRAM, "--machine", m)
    assert r.exit_code != 0 and "linuxcnc.ini: [AXIS_Y]MAX_ACCELERATION" in r.stderr


def test_compare_runs_one_program_on_vcnc_and_on_linuxcnc():
    r = vcnc("compare", PROGRAM, PROGRAM, "--planner", "linuxcnc", "--planner", "vcnc", "--linuxcnc-ini", INI,
             "--json")
    assert r.exit_code == 0, r.stderr
    res = json.loads(r.stdout)
    assert (res["a"]["planner"], res["b"]["planner"]) == ("linuxcnc", "vcnc")
    assert abs(res["a"]["time_s"] - 15.028) <= 0.002 and res["b"]["time_s"] < res["a"]["time_s"]
