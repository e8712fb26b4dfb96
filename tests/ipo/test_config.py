"""Machine configuration: the documented default and clear errors naming the key."""
from pathlib import Path

import pytest

from ipo.config import ConfigError, Finishing, default_config, load_config

REPO = Path(__file__).resolve().parents[2]
DEFAULT_TOML = (REPO / "programs" / "machine.toml").read_text()


def test_default_equals_documented_file():
    cfg = load_config(REPO / "programs" / "machine.toml")
    assert cfg == default_config()
    assert cfg.period_s == 0.001 and cfg.blu_mm == 0.001 and cfg.chord_tol_mm == 0.001
    assert [a.max_velocity_mm_s for a in cfg.axes] == [100.0] * 3
    assert [a.max_accel_mm_s2 for a in cfg.axes] == [1000.0] * 3
    assert cfg.finishing is None and cfg.accel_mode == "trapezoid"
    assert cfg.tools[1].ball_radius_mm == 3.0 and cfg.tools[1].flutes == 2


def _load(tmp_path, text):
    p = tmp_path / "m.toml"
    p.write_text(text)
    return load_config(p)


def test_finishing_section(tmp_path):
    cfg = _load(tmp_path, DEFAULT_TOML + "\n[finishing]\ntool = 1\npick_feed_mm = 0.2\n"
                                          "roughness_target_um = 3.3\n")
    assert cfg.finishing == Finishing(1, 0.2, 3.3)
    cfg = _load(tmp_path, DEFAULT_TOML + "\n[finishing]\ntool = 1\npick_feed_mm = 0.2\n")
    assert cfg.finishing.roughness_target_um == "isotropic"


@pytest.mark.parametrize("old,new,key", [
    ("period_s = 0.001", "period_s = -1", "period_s"),
    ("blu_mm = 0.001", "blu_mm = \"x\"", "blu_mm"),
    ("method = \"recursive\"", "method = \"fast\"", "method"),
    ("accel_mode = \"trapezoid\"", "accel_mode = \"jerky\"", "accel_mode"),
    ("max_accel_mm_s2 = 1000.0", "max_accel_mm_s2 = 0", "axes.x.max_accel_mm_s2"),
    ("min_mm = -1000.0", "min_mm = 2000.0", "axes.x.max_mm"),
    ("flutes = 2", "flutes = 0", "tools.1.flutes"),
    ("G54 = [0.0, 0.0, 0.0]", "G60 = [0.0, 0.0, 0.0]", "work_offsets_mm.G60"),
    ("model = \"none\"", "model = \"lag\"", "servo.time_constant_s"),
    ("period_s = 0.001", "period_ms = 1", "period_ms"),
])
def test_bad_values_name_the_key(tmp_path, old, new, key):
    assert old in DEFAULT_TOML
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, DEFAULT_TOML.replace(old, new, 1))
    assert info.value.key == key and str(info.value).startswith(key + ":")


@pytest.mark.parametrize("extra,key", [
    ("[finishing]\ntool = 7\npick_feed_mm = 0.2\n", "finishing.tool"),
    ("[finishing]\ntool = 1\npick_feed_mm = -0.2\n", "finishing.pick_feed_mm"),
    ("[finishing]\ntool = 1\npick_feed_mm = 0.2\nroughness_target_um = 0\n", "finishing.roughness_target_um"),
    ("[finishing]\npick_feed_mm = 0.2\n", "finishing.tool"),
])
def test_bad_finishing(tmp_path, extra, key):
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, DEFAULT_TOML + "\n" + extra)
    assert info.value.key == key


def test_missing_axis_and_bad_toml(tmp_path):
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, DEFAULT_TOML.replace("[axes.z]", "[axes.w]"))
    assert info.value.key == "axes.w"
    with pytest.raises(ConfigError):
        _load(tmp_path, "period_s = = 1")
