"""grbl `$$` printouts: read as grbl prints them, refused naming the line otherwise; the
machine file's `planner` and [grbl] keys."""
from __future__ import annotations

from pathlib import Path

import pytest

from ipo.config import ConfigError, load_config
from ipo.grbl_settings import GrblSettingsError, from_machine, parse_dump, read_dump

MACHINE = Path(__file__).resolve().parents[2] / "programs" / "machine.toml"
# what grbl 1.1h answers to $$ (grbl-sim, settings written with $100=250 ... $12=0.002)
DUMP = """$0=10
$1=25
$2=0
$3=0
$4=0
$5=0
$6=0
$10=1
$11=0.010
$12=0.002
$13=0
$20=0
$21=0
$22=0
$23=0
$24=25.000
$25=500.000
$26=250
$27=1.000
$30=1000
$31=0
$32=0
$100=250.000
$101=250.000
$102=250.000
$110=6000.000
$111=6000.000
$112=3000.000
$120=500.000
$121=500.000
$122=250.000
$130=200.000
$131=200.000
$132=200.000
ok
"""


def dump(s) -> str:
    """The settings as `$$` prints them (the ones the twin reads)."""
    vals = {1: float(s.idle_lock_ms), 11: s.junction_deviation_mm, 12: s.arc_tolerance_mm, 32: float(s.laser_mode)}
    for i in range(3):
        vals[100 + i], vals[110 + i], vals[120 + i] = s.steps_per_mm[i], s.max_rate_mm_min[i], s.accel_mm_s2[i]
    return "".join(f"${k}={int(v)}\n" if k in (1, 32) else f"${k}={v:.3f}\n" for k, v in sorted(vals.items()))


def test_a_dump_is_read_as_grbl_prints_it():
    s = parse_dump(DUMP, "board.txt")
    assert s.steps_per_mm == (250.0, 250.0, 250.0)
    assert s.max_rate_mm_min == (6000.0, 6000.0, 3000.0)
    assert s.accel_mm_s2 == (500.0, 500.0, 250.0)
    assert (s.junction_deviation_mm, s.arc_tolerance_mm, s.laser_mode) == (0.01, 0.002, False)
    assert parse_dump(dump(s), "again").accel_mm_s2 == s.accel_mm_s2


def test_grbl_10_comments_and_crlf_are_read():
    text = DUMP.replace("$110=6000.000", "$110=6000.000 (x max rate, mm/min)").replace("\n", "\r\n")
    assert parse_dump(text, "old.txt").max_rate_mm_min[0] == 6000.0


def test_a_line_that_is_not_a_setting_is_refused_with_its_line():
    with pytest.raises(GrblSettingsError, match=r"board.txt:3: not a grbl setting line"):
        parse_dump("$0=10\n$1=25\nGrbl 1.1h ['$' for help]\n", "board.txt")


def test_a_dump_without_the_axis_settings_is_refused():
    with pytest.raises(GrblSettingsError, match=r"lacks \$120, \$121, \$122"):
        parse_dump("\n".join(l for l in DUMP.splitlines() if not l.startswith("$12") or l.startswith("$12=")),
                   "short.txt")


def test_a_zero_rate_is_refused():
    with pytest.raises(GrblSettingsError, match=r"\$111=0 must be > 0"):
        parse_dump(DUMP.replace("$111=6000.000", "$111=0"), "zero.txt")


def test_the_machine_file_names_its_planner_and_dump(tmp_path):
    (tmp_path / "board.txt").write_text(DUMP)
    text = MACHINE.read_text()
    (tmp_path / "m.toml").write_text(text.replace('planner = "vcnc"', 'planner = "grbl"')
                                     + '\n[grbl]\nsettings = "board.txt"\nbaud = 250000\n')
    cfg = load_config(tmp_path / "m.toml")
    assert cfg.planner == "grbl" and cfg.grbl_baud == 250000
    assert cfg.grbl_settings == read_dump(tmp_path / "board.txt")


@pytest.mark.parametrize("extra,key", [('planner = "mach3"\n', "planner"),
                                       ('[grbl]\nsettings = "missing.txt"\n', "grbl.settings"),
                                       ('[grbl]\nbaud = 115200.5\n', "grbl.baud"),
                                       ('[grbl]\nstop_bits = 2\n', "grbl.stop_bits")])
def test_bad_planner_keys_are_refused_naming_the_key(tmp_path, extra, key):
    text = MACHINE.read_text().replace('planner = "vcnc"', "")
    (tmp_path / "m.toml").write_text(extra + text if extra.startswith("planner") else text + "\n" + extra)
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "m.toml")
    assert info.value.key == key


def test_without_a_dump_the_twin_takes_the_axes():
    cfg = load_config(MACHINE)
    s = from_machine(cfg.axes, cfg.blu_mm)
    assert s.max_rate_mm_min == (6000.0, 6000.0, 6000.0) and s.accel_mm_s2 == (1000.0, 1000.0, 1000.0)
    assert s.steps_per_mm == (1000.0, 1000.0, 1000.0) and (s.junction_deviation_mm, s.arc_tolerance_mm) == (0.01, 0.002)
