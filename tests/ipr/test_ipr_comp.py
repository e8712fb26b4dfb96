"""Cutter radius compensation against rs274, and the compensated contour checked on its own.

Programs: a square with a rounded corner and a circle, cut outside and inside (G41/G42,
G41.1/G42.1 and D from the tool table), with entry and exit moves. rs274 reads the tool
table in inches (tests/rs274.py). The contour check samples every compensated move between
the entry and the exit and measures, by brute force, its distance to a dense sampling of the
programmed contour: it must be the tool radius.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from rs274 import INCH_MM, canon_moves, require_rs274, run_rs274
from test_ipr_rs274 import mismatches

import ipr
from ipr.entities import Arc, GCodeError, Line

RADIUS = 3.0
SETUP = ipr.Setup(tool_radii_mm={1: RADIUS})

# a 50 x 40 square whose corner at X50 Y0 is rounded with R10, clockwise or counter-clockwise
SQUARE_CCW = ["G1 X0 Y0", "G1 X40", "G3 X50 Y10 I0 J10", "G1 Y40", "X0", "Y0"]
SQUARE_CW = ["G1 X0 Y0", "G1 Y40", "X50", "Y10", "G2 X40 Y0 I-10 J0", "G1 X0"]
CIRCLE_CCW = ["G1 X30 Y20", "G3 X30 Y20 I-10 J0"]
CIRCLE_CW = ["G1 X30 Y20", "G2 X30 Y20 I-10 J0"]

CASES = {
    # name: (comp code, contour, entry point, which side of the contour the tool is on)
    "square_outside_g41_ccw": ("G41 D1", SQUARE_CW, (-10, -10)),
    "square_outside_g42_ccw": ("G42 D1", SQUARE_CCW, (-10, -10)),
    "square_inside_g41": ("G41.1 D6", SQUARE_CCW, (20, 20)),
    "square_inside_g42": ("G42.1 D6", SQUARE_CW, (20, 20)),
    "circle_pocket_g41": ("G41 D1", CIRCLE_CCW, (20, 20)),
    "circle_outside_g42": ("G42 D1", CIRCLE_CCW, (45, 20)),
    "circle_outside_g41": ("G41 D1", CIRCLE_CW, (45, 20)),
    "circle_pocket_g42": ("G42.1 D6", CIRCLE_CW, (20, 20)),
}


def program(name: str) -> str:
    comp, contour, (x0, y0) = CASES[name]
    lines = ["G21 G17 G90 G94", f"G0 X{x0} Y{y0} Z5", "M3 S1000", "G1 Z-1 F600", comp, *contour, "G40",
             f"G1 X{x0} Y{y0}", "G0 Z5", "M2"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name", sorted(CASES))
def test_compensation_matches_rs274(tmp_path, name: str) -> None:
    require_rs274()
    path = tmp_path / f"{name}.ngc"
    path.write_text(program(name))
    table = tmp_path / "tools.tbl"
    table.write_text(f"T1 P1 Z0 D{2 * RADIUS / INCH_MM:.9f}\n")
    moves = canon_moves(run_rs274(path, tool_table=table))
    entities = ipr.parse_text(program(name), setup=SETUP).entities
    problems = mismatches(moves, entities)
    assert not problems, "\n".join(problems)


def _samples(e, n: int = 100) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)
    if isinstance(e, Line):
        return np.outer(1 - t, e.start[:2]) + np.outer(t, e.end[:2])
    a0 = math.atan2(e.start[1] - e.center[1], e.start[0] - e.center[0])
    ang = a0 + t * e.sweep_rad
    return np.column_stack([e.center[0] + e.radius_mm * np.cos(ang), e.center[1] + e.radius_mm * np.sin(ang)])


@pytest.mark.parametrize("name", sorted(CASES))
def test_compensated_contour_is_one_radius_away(name: str) -> None:
    text = program(name)
    cut = [e for e in ipr.parse_text(text, setup=SETUP).motions() if isinstance(e, (Line, Arc)) and e.end[2] == -1.0]
    plain = text.replace(CASES[name][0], "")
    nominal = [e for e in ipr.parse_text(plain).motions() if isinstance(e, (Line, Arc)) and e.end[2] == -1.0]
    contour = np.vstack([_samples(e, 4000) for e in nominal[2:-1]])   # without the plunge, entry, exit
    # the compensated moves after the entry (index 1) and before the exit; the last of them only
    # over its first half: LinuxCNC ends it at the offset of its programmed end, which inside a
    # corner reaches into the corner (the exit does not trim it)
    moves = cut[2:-1]
    assert len(moves) >= 1 and all(e.line > 5 for e in moves)
    for e in moves:
        pts = _samples(e)[:50] if e is moves[-1] else _samples(e)
        d = np.sqrt(((pts[:, None, :] - contour[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
        assert d == pytest.approx(RADIUS, abs=2e-3), (name, e)


@pytest.mark.parametrize("text, message", [
    ("G0 X0 Y0\nG41 D1\nG1 X1 Y0 F100\n", "entry move"),                       # entry shorter than r
    ("G0 X-10 Y0\nG41 D1\nG1 X0 Y0 F100\nG3 X4 Y0 I2 J0\n", "not smaller"),    # tool bigger than the arc
    ("G0 X-10 Y0\nG41 D1\nG1 X0 Y0 F100\nG41 D1\n", "already on"),
    ("G18 G41 D1\n", "XY plane"),
    ("G0 X-10 Y0\nG41 D1\nG1 X0 Y0 F100\nG28\n", "G40 first"),
    ("G0 X-10 Y-10\nG41 D1\nG1 X0 Y0 F100\nX20\nG40\nG2 X30 Y0 R5\n", "after G40"),
    # a 2 mm wide slot is too narrow for a 6 mm tool: the offset path would run backwards (rs274 too)
    ("G0 X-10 Y-10\nG42 D1\nG1 X0 Y0 F100\nY20\nX2\nY0\nX10\n", "gouging"),
])
def test_compensation_errors(text: str, message: str) -> None:
    with pytest.raises(GCodeError) as err:
        ipr.parse_text(text, setup=SETUP)
    d = err.value.diagnostics[0]
    assert d.code == "E-COMP" and message in d.message, d
