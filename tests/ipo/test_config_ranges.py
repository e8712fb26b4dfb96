"""Machine-file ranges: every numeric key is checked against its documented range at load.

For each key of ipo.config.RANGES, machine files are generated with the value at each edge
(it loads, and a short program with a line, an arc and a rational NURBS runs to its end in
that machine without a fault) and beyond it (hypothesis: any float outside the range,
tiny, huge, infinite; the load fails naming the key). docs/machine-file.md lists the same
ranges as the code.
"""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ipo.config import RANGES, ConfigError, load_config
from machine.controller import Controller, ProgramRejected

REPO = Path(__file__).resolve().parents[2]
DEFAULT = tomllib.loads((REPO / "programs" / "machine.toml").read_text())
FINISHING = {"tool": 1, "pick_feed_mm": 0.2, "roughness_target_um": 3.0}
PROGRAM = """G21 G90 G17 G94 G64
G0 X0 Y0 Z0
M3 S10000
G1 X0.2 F600
G2 X0.4 Y0 I0.1 J0
G6.2 P3 K0 X0.4 Y0 Z0 R1 F600
K0 X0.5 Y0.1 R0.7
K0 X0.4 Y0.2 R1
K1
K1
K1
G0 X0 Y0 Z0.1
M2
"""
END_MM = (0.0, 0.0, 0.1)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "inf" if v == math.inf else "-inf" if v == -math.inf else "nan" if v != v else repr(v)
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(v)


def _dump(data: dict, prefix: str = "") -> str:
    plain = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    out = ([f"[{prefix}]"] if prefix and plain else []) + plain
    for k, v in data.items():
        if isinstance(v, dict):
            out.append(_dump(v, f"{prefix}.{k}" if prefix else k))
    return "\n".join(out) + "\n"


def machine_file(tmp_path: Path, pattern: str, value) -> Path:
    """The default machine with every key matching `pattern` (axis x, tool 1, G54) set to value,
    with the sections the key needs to take effect."""
    data = tomllib.loads(_dump(DEFAULT))
    key = pattern.replace("axes.*", "axes.x").replace("tools.*", "tools.1").replace("work_offsets_mm.*",
                                                                                     "work_offsets_mm.G54")
    if key.startswith("finishing."):
        data["finishing"] = dict(FINISHING)
    if key.startswith("stock."):
        data["stock"] = {}
    if key.startswith("grbl."):
        data["grbl"] = {}
    if key == "servo.time_constant_s" and value > 0:
        data["servo"]["model"] = "lag"
    if key == "servo.kp_1_s" and value > 0:
        data["servo"]["model"] = "pd"
    if key.endswith("max_jerk_mm_s3"):
        data["accel_mode"] = "scurve"
    if key == "tools.*.ball_radius_mm".replace("*", "1") and value == 0:
        data.pop("finishing", None)
    if key in ("tools.1.diameter_mm", "tools.1.corner_radius_mm"):  # a flat or bull tool's sizes
        tool = data["tools"]["1"]
        tool.pop("ball_radius_mm", None)
        corner = key.endswith("corner_radius_mm")
        tool["shape"] = "bull" if corner and value != 0 else "flat"
        tool["diameter_mm"] = (min(2.0 * value, 200.0) if math.isfinite(value) and value > 3.0 else 6.0) if corner \
            else value
    *path, last = key.split(".")
    table = data
    for p in path:
        table = table[p]
    if key.startswith("work_offsets_mm"):
        table[last] = [value, 0.0, 0.0]
    elif key.startswith("stock."):
        table[last] = [value] * 3
        other = "max_mm" if last == "min_mm" else "min_mm"
        table[other] = [value + (1.0 if other == "max_mm" else -1.0)] * 3
    else:
        table[last] = value
    if key == "axes.x.min_mm" and value == value and -1e5 <= value + 1.0 <= 1e5:
        table["max_mm"] = max(table["max_mm"], value + 1.0)  # the travel stays a travel
    if key == "axes.x.max_mm" and value == value and -1e5 <= value - 1.0 <= 1e5:
        table["min_mm"] = min(table["min_mm"], value - 1.0)
    if key == "finishing.pick_feed_mm":  # a pick feed below the ball's diameter, its own cusp
        data["tools"]["1"]["ball_radius_mm"] = 100.0
        data["finishing"]["roughness_target_um"] = "isotropic"
    if key == "finishing.roughness_target_um":  # a pick feed fine enough for the finest target
        data["finishing"]["pick_feed_mm"] = 1e-4
    path_out = tmp_path / "m.toml"
    path_out.write_text(_dump(data))
    return path_out


def _edge_cases():
    for pattern, (low, high, _) in RANGES.items():
        for value in (low, high):
            if (pattern, value) in (("axes.*.min_mm", high), ("axes.*.max_mm", low), ("stock.min_mm", high),
                                    ("stock.max_mm", low)):
                continue  # a travel of no length: refused by max_mm > min_mm (test_config)
            yield pytest.param(pattern, value, id=f"{pattern}={value:g}")


@pytest.mark.parametrize("pattern,value", list(_edge_cases()))
def test_a_machine_at_each_edge_runs_the_program(tmp_path, pattern, value):
    value = int(value) if pattern.endswith("flutes") else float(value)
    config = load_config(machine_file(tmp_path, pattern, value))
    program_file = tmp_path / "p.nc"
    program_file.write_text(PROGRAM)
    controller = Controller(config)
    try:
        program = controller.check(program_file)
    except ProgramRejected as rejected:  # a travel that excludes the program: refused, said why
        assert all("error[E-TRAVEL]" in r for r in rejected.reasons), rejected.reasons
        return
    result = controller.run(program)
    assert result.state == "completed", result.fault
    assert np.allclose(result.position_mm, END_MM, atol=config.blu_mm)


def _beyond(low: float, high: float):
    return st.one_of(st.floats(max_value=low, exclude_max=True), st.floats(min_value=high, exclude_min=True),
                     st.sampled_from([1e-320, 1e308, -1e308, 1e-300, math.inf, -math.inf, math.nan]).filter(
                         lambda v: not low <= v <= high))


@pytest.mark.parametrize("pattern", list(RANGES))
@settings(max_examples=12, deadline=None, derandomize=True)
@given(data=st.data())
def test_a_value_beyond_an_edge_is_refused_naming_the_key(tmp_path_factory, pattern, data):
    low, high, _ = RANGES[pattern]
    value = data.draw(_beyond(low, high))
    if pattern.endswith("flutes"):
        value = data.draw(st.sampled_from([0, -1, 101, 10**30]))
    path = machine_file(tmp_path_factory.mktemp("m"), pattern, value)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value).startswith(info.value.key + ": ")
    want = pattern.replace("axes.*", "axes.x").replace("tools.*", "tools.1").replace("work_offsets_mm.*",
                                                                                      "work_offsets_mm.G54")
    assert info.value.key in (want, want.rsplit(".", 1)[0] + ".max_mm", want.rsplit(".", 1)[0] + ".min_mm",
                              "finishing.pick_feed_mm")


def test_a_machine_file_that_is_not_utf8_names_the_file(tmp_path):
    path = tmp_path / "m.toml"
    path.write_bytes(b"period_s = 0.001\n# \xff\xfe latin-1 comment\n")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(path) in str(info.value) and "UTF-8" in str(info.value)


def test_the_documented_ranges_are_the_checked_ones():
    doc = (REPO / "docs" / "machine-file.md").read_text()
    for pattern, (low, high, why) in RANGES.items():
        assert f"| `{pattern}` | {low:g} | {high:g} | {why} |" in doc, pattern
