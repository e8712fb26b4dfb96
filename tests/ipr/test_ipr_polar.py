"""Polar coordinates (`@` radius, `^` angle) against LinuxCNC's rs274 (tests/rs274.py).

A hole circle (G91 canned cycle with L repeats, G90 cycles, an offset origin, G20), a spiral
of G91 increments in an O-word loop, arcs and lines with polar end points: every move's end
point and feed compared with rs274's. Each misuse rs274 refuses is refused by vcnc with
E-POLAR (or E-NO-MOTION-MODE) at the offending word's line and column.
"""
from __future__ import annotations

import math

import pytest
from rs274 import canon_moves, require_rs274, run_rs274
from test_ipr_rs274 import mismatches

import ipr
from ipr.entities import GCodeError, Line

HOLE_CIRCLE = """G21 G17 G90 G94 G64 P0.01
G10 L2 P1 X20 Y10
F120 S800 M3
G0 X30 Y0 Z5
G91 G99 G81 R-4 Z-3 ^60 L6
G90 G98 G81 @15 ^45 R1 Z-3
^135
@7.5 Z-2
G80 G0 Z5
G91 G81 @5 R-4 Z-3 L3
G80 G90 G0 X2 Y0
G91 G81 ^[360/17] R-4 Z-3 L17
G80 G90 G0 Z5
M2
"""

SPIRAL = """G20 G17 G90 G94 G64 P0.001
G92 X0 Y0 Z0
G0 X2 Y0 Z1
G1 Z-.1 F24
o100 repeat [80]
G91 G1 @-.0125 ^4.5
o100 endrepeat
G90 G1 @1.5 ^200 Z-.2
G91 G1 ^-30 Z.05
G90 G2 @1.5 ^90 R1.6
G3 ^120 I[-1.5*COS[90]] J[-1.5*SIN[90]] F30
G0 @0.5 ^0 Z1
M2
"""


def _compare(tmp_path, text: str) -> int:
    require_rs274()
    path = tmp_path / "polar.ngc"
    path.write_text(text)
    moves = canon_moves(run_rs274(path))
    problems = mismatches(moves, ipr.parse_text(text).entities)
    assert not problems, "\n".join(problems)
    return len(moves)


def test_hole_circle_matches_rs274(tmp_path) -> None:
    assert _compare(tmp_path, HOLE_CIRCLE) > 100


def test_spiral_of_increments_matches_rs274(tmp_path) -> None:
    assert _compare(tmp_path, SPIRAL) > 80


def test_g91_angle_turns_about_the_origin() -> None:
    """From (10, 0): G91 @2 ^90 adds to radius and angle, so the end is (0, 12) (by hand)."""
    text = "G21 G0 X10 Y0\nG91 G1 @2 ^90 F60\nM2\n"
    line = [e for e in ipr.parse_text(text).entities if isinstance(e, Line)][0]
    assert line.end == pytest.approx((0.0, 12.0, 0.0), abs=1e-12)
    text = "G21 G0 X3 Y4\nG90 G1 ^[ATAN[4]/[3] + 90] F60\nM2\n"
    line = [e for e in ipr.parse_text(text).entities if isinstance(e, Line)][0]
    assert line.end == pytest.approx((-4.0, 3.0, 0.0), abs=1e-12)
    assert math.hypot(*line.end[:2]) == pytest.approx(5.0)


# (program, code, line, column): each is refused by rs274 too
REFUSED = [
    ("G21 G0 X10 Y0\nG1 F100 X1 @3\n", "E-POLAR", 2, 9),
    ("G21 G0 X10 Y0\nG1 F100 ^3 Y1\n", "E-POLAR", 2, 12),
    ("G21 G18 G0 X10 Y0\nG1 F100 @3\n", "E-POLAR", 2, 9),
    ("G21 G0 X10 Y0\nG92 @1\n", "E-POLAR", 2, 5),
    ("G21 G0 X10 Y0\nG10 L20 P1 ^1\n", "E-POLAR", 2, 12),
    ("G21 G0 X10 Y0\nG53 G0 @1\n", "E-POLAR", 2, 8),
    ("G21 G0 X10 Y0\nG80 ^1\n", "E-NO-MOTION-MODE", 2, 5),
    ("G21 G90 G0 @1\n", "E-POLAR", 1, 12),
    ("G21 G91 G0 ^1\n", "E-POLAR", 1, 12),
    ("G21 S800 M3 G0 X10 Y0\nG19 G91 G81 R1 X-1 ^30 F100\n", "E-POLAR", 2, 16),
]


@pytest.mark.parametrize("text, code, line, col", REFUSED)
def test_misuse_is_refused_like_rs274(tmp_path, text: str, code: str, line: int, col: int) -> None:
    require_rs274()
    path = tmp_path / "bad.ngc"
    path.write_text(text + "M2\n")
    with pytest.raises(Exception):   # rs274 refuses the program (run_rs274 raises with its message)
        run_rs274(path)
    with pytest.raises(GCodeError) as info:
        ipr.parse_text(text + "M2\n")
    d = info.value.diagnostics[0]
    assert (d.code, d.line, d.col) == (code, line, col)


def test_nurbs_with_polar_is_refused() -> None:
    """rs274 would take G5.2 with @ silently as a control point; vcnc refuses rather than guess."""
    with pytest.raises(GCodeError) as info:
        ipr.parse_text("G21 G0 X1\nG5.2 @1 P1 F10\n")
    assert info.value.diagnostics[0].code == "E-POLAR"
