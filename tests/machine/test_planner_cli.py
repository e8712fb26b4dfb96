"""--planner and --grbl-settings end to end: `vcnc run`, `vcnc compare` and `vcnc stream`'s
estimate run the program on the chosen planner and say which ran."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.machine.test_run_cli import vcnc

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "grbl_sim"
PROGRAM = DATA / "line_arc.nc"
DUMP = DATA / "settings_a.txt"
MACHINE = (ROOT / "ipo" / "machine.toml").read_text()


def test_run_on_the_grbl_twin_says_so_and_ends_where_the_program_does(tmp_path):
    r = vcnc("run", PROGRAM, "--planner", "grbl", "--grbl-settings", DUMP, "--json", "--trace", tmp_path / "t.npz")
    assert r.exit_code == 0, r.stderr
    s = json.loads(r.stdout.strip().splitlines()[-1])
    assert s["planner"] == f"grbl 1.1 twin: $$ of {DUMP}, 115200 baud"
    assert s["state"] == "completed" and s["position_mm"] == [0.0, 0.0, 0.0]
    # the lines and the 3/4 circle (50 + 30 + 1.5 pi 20 + 30 + 50 mm), the circle as grbl's chords: shorter
    assert 160.0 + 30 * np.pi - 0.05 < s["path_length_mm"] < 160.0 + 30 * np.pi
    trace = np.load(tmp_path / "t.npz")
    # grbl caps a feed move at the axes' max rate and a G0 runs at it: Y's $111 = 6000 mm/min
    assert trace["feed_mm_s"].max() <= 100.0 + 1e-6


def test_the_machine_file_chooses_the_planner(tmp_path):
    (tmp_path / "board.txt").write_text(DUMP.read_text())
    m = tmp_path / "m.toml"
    m.write_text(MACHINE.replace('planner = "vcnc"', 'planner = "grbl"') + '\n[grbl]\nsettings = "board.txt"\n')
    by_file = json.loads(vcnc("run", PROGRAM, "--machine", m, "--json").stdout.strip().splitlines()[-1])
    by_option = json.loads(vcnc("run", PROGRAM, "--planner", "grbl", "--grbl-settings", DUMP,
                                "--json").stdout.strip().splitlines()[-1])
    assert by_file["planner"].startswith("grbl 1.1 twin") and by_file["cycle_time_s"] == by_option["cycle_time_s"]
    back = json.loads(vcnc("run", PROGRAM, "--machine", m, "--planner", "vcnc", "--json").stdout.strip().splitlines()[-1])
    assert back["planner"] == "vcnc" and back["cycle_time_s"] != by_file["cycle_time_s"]


def test_a_bad_settings_file_is_a_usage_error(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("$110=6000\nhello\n")
    r = vcnc("run", PROGRAM, "--planner", "grbl", "--grbl-settings", bad)
    assert r.exit_code == 2 and f"{bad}:2: not a grbl setting line" in r.stderr


@pytest.mark.slow
def test_compare_runs_one_program_on_two_controllers():
    r = vcnc("compare", PROGRAM, PROGRAM, "--planner", "grbl", "--planner", "vcnc", "--grbl-settings", DUMP, "--json")
    assert r.exit_code == 0, r.stderr
    res = json.loads(r.stdout)
    assert (res["a"]["planner"], res["b"]["planner"]) == ("grbl", "vcnc")
    assert res["a"]["time_s"] != res["b"]["time_s"]
    table = vcnc("compare", PROGRAM, PROGRAM, "--planner", "grbl", "--planner", "vcnc", "--grbl-settings", DUMP)
    assert table.stdout.splitlines()[1].split() == ["planner", "grbl", "vcnc"]
    assert vcnc("compare", PROGRAM, PROGRAM, "--planner", "grbl", "--planner", "vcnc", "--planner", "grbl").exit_code == 2


def test_the_dry_run_prints_the_twins_job_time():
    r = vcnc("stream", PROGRAM, "--dry-run")
    assert r.exit_code == 0, r.stderr
    line = next(l for l in r.stderr.splitlines() if l.startswith("job time"))
    assert line.startswith("job time (grbl 1.1 twin: $$ of the machine file's axes, 115200 baud): ")
    run = json.loads(vcnc("run", PROGRAM, "--planner", "grbl", "--json").stdout.strip().splitlines()[-1])
    assert float(line.rsplit(" ", 2)[-2]) == round(run["cycle_time_s"], 1)
