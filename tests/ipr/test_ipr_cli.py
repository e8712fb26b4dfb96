"""`vcnc parse FILE [--json] [--all-errors]`: exit codes, JSON entities, summary, stderr."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from machine.commands.parse import command

PROGRAM = """G21 G90 G17 F600
G0 X10 Y0
G1 Y10
G3 X0 Y20 I-10 J0
G4 P0.5
G0 Z5
G06.2 P2 K0 R1
X10 Z5 K0
K1
K1
M2
"""


def _run(tmp_path, text: str, *args: str):
    path = tmp_path / "part.nc"
    path.write_text(text)
    return CliRunner().invoke(command, [str(path), *args]), str(path)


def test_json_lists_every_motion_and_dwell(tmp_path):
    result, _ = _run(tmp_path, PROGRAM, "--json")
    assert result.exit_code == 0, result.output
    items = json.loads(result.stdout)
    assert [i["kind"] for i in items] == ["rapid", "line", "arc", "dwell", "rapid", "nurbs"]
    rapid, line, arc, dwell, _, nurbs = items
    assert rapid == {"line": 2, "kind": "rapid", "start": [0, 0, 0], "end": [10, 0, 0], "feed_mm_min": None}
    assert line["feed_mm_min"] == pytest.approx(600.0) and line["end"] == [10, 10, 0]
    assert arc["center"] == [0, 10, 0] and arc["plane"] == "XY" and arc["ccw"] is True
    assert dwell["start"] == dwell["end"] == [0, 20, 0]
    assert nurbs["degree"] == 1 and nurbs["knots"] == [0, 0, 1, 1]
    assert nurbs["weights"] == [1, 1] and nurbs["points"] == [[0, 20, 5], [10, 20, 5]]


def test_summary_counts_length_and_box(tmp_path):
    result, _ = _run(tmp_path, PROGRAM)
    assert result.exit_code == 0
    rows = {}
    for row in result.stdout.splitlines():
        cells = [c.strip() for c in row.split("│") if c.strip()]
        if len(cells) == 2:
            rows[cells[0]] = cells[1]
    assert {k: rows[f"{k} entities"] for k in ("rapid", "line", "arc", "nurbs", "dwell")} == {
        "rapid": "2", "line": "1", "arc": "1", "nurbs": "1", "dwell": "1"}
    length = 10 + 10 + math.pi * 10 / 2 + 5 + 10     # rapid, line, quarter arc r=10, Z5, straight NURBS
    assert rows["path length"] == f"{length:.3f} mm"
    assert rows["bounding box min"] == "0.000  0.000  0.000 mm"
    assert rows["bounding box max"] == "10.000  20.000  5.000 mm"


def test_errors_go_to_stderr_with_exit_1(tmp_path):
    result, path = _run(tmp_path, "G0 X1\nG33 X2 K1\nG1 X3\n", "--all-errors")
    assert result.exit_code == 1
    assert result.stderr.splitlines() == [
        f"{path}:2:1: error[E-GCODE-UNSUPPORTED]: unsupported G-code G33 (spindle-synchronised motion "
        "(threading))",
        f"{path}:3:1: error[E-FEED-ZERO]: feed move with feed rate zero (program an F word)",
    ]
    assert result.stdout == ""
    result, _ = _run(tmp_path, "G0 X1\nG33 X2 K1\nG1 X3\n")
    assert result.exit_code == 1 and len(result.stderr.splitlines()) == 1


def test_warnings_go_to_stderr_and_do_not_fail(tmp_path):
    result, path = _run(tmp_path, "G43 H3 G0 Z1\n", "--json")
    assert result.exit_code == 0
    assert result.stderr.startswith(f"{path}:1:5: warning[W-TOOL-UNKNOWN]")
    assert json.loads(result.stdout)[0]["end"] == [0, 0, 1]


def test_machine_file_gives_offsets_and_tools(tmp_path):
    machine = tmp_path / "m.toml"
    text = (Path(__file__).resolve().parents[2] / "programs" / "machine.toml").read_text()
    machine.write_text(text.replace("G54 = [0.0, 0.0, 0.0]", "G54 = [0.0, 0.0, 0.0]\nG55 = [100.0, 0.0, -5.0]")
                       .replace("length_mm = 0.0", "length_mm = 40.0", 1))
    result, _ = _run(tmp_path, "G55 G0 X1\nG43 H1 G0 Z0\n", "--json", "--machine", str(machine))
    assert result.exit_code == 0, result.output
    assert [i["end"] for i in json.loads(result.stdout)] == [[101, 0, 0], [101, 0, 35]]
    result, _ = _run(tmp_path, "G0 X1\n", "--machine", str(tmp_path / "missing.toml"))
    assert result.exit_code != 0 and "missing.toml" in result.output
