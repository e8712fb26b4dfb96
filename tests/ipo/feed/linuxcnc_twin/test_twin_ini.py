"""Reading LinuxCNC INI files: the files LinuxCNC 2.9 ran the measurements with, and bad ones."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from ipo.config import ConfigError, load_config
from ipo.linuxcnc_ini import IniError, load_ini
from linuxcnc_measured import DATA

MACHINE = (Path(__file__).resolve().parents[4] / "ipo" / "machine.toml").read_text()


def test_the_measurement_machines_read_as_linuxcnc_ran_them():
    d = load_ini(DATA / "ini" / "default.ini")
    assert d.servo_period_s == pytest.approx(1e-3, abs=1e-15)
    assert d.axis_velocity_mm_s == (100.0, 100.0, 100.0) and d.axis_accel_mm_s2 == (1000.0, 1000.0, 1000.0)
    assert d.max_linear_velocity_mm_s == 100.0 and d.max_feed_override == 1.0
    assert (d.arc_blend_enable, d.optimization_depth, d.gap_cycles, d.ramp_freq_hz) == (True, 50, 4, 100.0)
    assert d.kink_ratio == 0.1  # not in the file: LinuxCNC's default (initraj.cc)
    a = load_ini(DATA / "ini" / "axes.ini")
    assert a.axis_velocity_mm_s == (80.0, 60.0, 30.0) and a.axis_accel_mm_s2 == (800.0, 500.0, 300.0)
    assert a.max_linear_velocity_mm_s == 90.0
    assert load_ini(DATA / "ini" / "servo05.ini").servo_period_s == pytest.approx(5e-4, abs=1e-15)
    assert load_ini(DATA / "ini" / "noblend.ini").arc_blend_enable is False
    assert load_ini(DATA / "ini" / "maxfo15.ini").max_feed_override == 1.5
    assert load_ini(DATA / "ini" / "depth10.ini").optimization_depth == 10


MINIMAL = """\
[EMCMOT]
SERVO_PERIOD = 1000000
[TRAJ]
{traj}
[AXIS_X]
MAX_VELOCITY = 50
MAX_ACCELERATION = 500
[AXIS_Y]
MAX_VELOCITY = 50
MAX_ACCELERATION = 500
[AXIS_Z]
MAX_VELOCITY = 20
MAX_ACCELERATION = {z_acc}
"""


def _ini(tmp_path, traj="", z_acc="200"):
    p = tmp_path / "m.ini"
    p.write_text(MINIMAL.format(traj=traj, z_acc=z_acc))
    return p


def test_defaults_units_comments_and_first_key_wins(tmp_path):
    s = load_ini(_ini(tmp_path))
    assert s.max_linear_velocity_mm_s == math.inf and s.arc_blend_enable and s.optimization_depth == 50
    s = load_ini(_ini(tmp_path, "LINEAR_UNITS = inch\nMAX_LINEAR_VELOCITY = 2 # in/s\n# a comment\n"
                                "ARC_BLEND_ENABLE = 0\nARC_BLEND_ENABLE = 1"))
    assert s.axis_velocity_mm_s == (50 * 25.4, 50 * 25.4, 20 * 25.4) and s.axis_accel_mm_s2[2] == 200 * 25.4
    assert s.max_linear_velocity_mm_s == 2 * 25.4 and s.arc_blend_enable is False
    s = load_ini(_ini(tmp_path, "ARC_BLEND_KINK_RATIO = \\\n 0.25"))  # a backslash continues the line
    assert s.kink_ratio == 0.25


@pytest.mark.parametrize("traj, z_acc, key, words", [
    ("", "fast", "[AXIS_Z]MAX_ACCELERATION", "'fast' is not a number"),
    ("", "-3", "[AXIS_Z]MAX_ACCELERATION", "must be a finite number > 0"),
    ("LINEAR_UNITS = furlong", "200", "[TRAJ]LINEAR_UNITS", "furlong"),
    ("ARC_BLEND_ENABLE = maybe", "200", "[TRAJ]ARC_BLEND_ENABLE", "not 0/1"),
    ("COORDINATES = X Y", "200", "[TRAJ]COORDINATES", "lacks Z"),
    ("MAX_LINEAR_VELOCITY = 100mm", "200", "[TRAJ]MAX_LINEAR_VELOCITY", "not a number"),
])
def test_a_bad_value_is_refused_naming_its_key_file_and_line(tmp_path, traj, z_acc, key, words):
    with pytest.raises(IniError) as err:
        load_ini(_ini(tmp_path, traj, z_acc))
    assert err.value.key == key and words in str(err.value) and str(tmp_path / "m.ini") + ":" in str(err.value)


def test_a_missing_key_or_file_is_refused_naming_it(tmp_path):
    p = _ini(tmp_path)
    p.write_text(p.read_text().replace("[AXIS_Y]\nMAX_VELOCITY = 50\n", "[AXIS_Y]\n"))
    with pytest.raises(IniError, match=r"\[AXIS_Y\]MAX_VELOCITY: missing"):
        load_ini(p)
    with pytest.raises(IniError, match="absent.ini: cannot read this LinuxCNC INI file"):
        load_ini(tmp_path / "absent.ini")


def test_the_machine_file_names_the_ini_and_the_ini_describes_the_machine(tmp_path):
    p = _ini(tmp_path, "MAX_LINEAR_VELOCITY = 45")
    p.write_text(p.read_text().replace("[AXIS_Z]\n", "[AXIS_Z]\nMIN_LIMIT = -50\nMAX_LIMIT = 0\n")
                 .replace("SERVO_PERIOD = 1000000", "SERVO_PERIOD = 250000"))
    m = tmp_path / "m.toml"
    m.write_text(MACHINE + '\n[linuxcnc]\nini = "m.ini"\n')
    c = load_config(m)
    assert c.period_s == 2.5e-4 and c.linuxcnc_ini.max_linear_velocity_mm_s == 45.0
    assert [(a.max_velocity_mm_s, a.max_accel_mm_s2) for a in c.axes] == [(50, 500), (50, 500), (20, 200)]
    assert (c.axes[2].min_mm, c.axes[2].max_mm) == (-50.0, 0.0) and c.axes[0].max_mm == 1000.0  # X: the file's
    m.write_text(MACHINE + '\n[linuxcnc]\nini = "absent.ini"\n')
    with pytest.raises(ConfigError, match="linuxcnc.ini: .*absent.ini: cannot read this LinuxCNC INI file"):
        load_config(m)
