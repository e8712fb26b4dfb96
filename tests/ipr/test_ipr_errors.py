"""Every error code of ipr/errors.py, with its line and column; --all-errors; atomicity."""
from __future__ import annotations

import pytest

import ipr
from ipr.entities import GCodeError, Line, Rapid
from ipr.errors import CODES

# (program, code, line, column): the column is that of the offending word
CASES = [
    ("G1 X1 $", "E-SYNTAX", 1, 7),
    ("G0 X1\nG1 X[1+] F100", "E-SYNTAX", 2, 8),
    ("G0 X1\nG1 X2 Y", "E-SYNTAX", 2, 8),
    ("G1 E1", "E-WORD-UNUSED", 1, 4),
    ("G1 A1", "E-AXIS-ABSENT", 1, 4),
    ("G0 X1\nM3 S100 G1 W2 F10", "E-AXIS-ABSENT", 2, 12),
    ("G0 X1\n  G18 G41 X2", "E-COMP", 2, 7),
    ("G0 X1 G33 X2 K1", "E-GCODE-UNSUPPORTED", 1, 7),
    ("G0 X1\nG38.2 Z-5 F10", "E-GCODE-UNSUPPORTED", 2, 1),
    ("G0 X1\nG76 P1 Z-5 I1 J1 K1", "E-GCODE-UNSUPPORTED", 2, 1),
    ("G0 Z5\nG81 X1 Z-1 F100", "E-CYCLE", 2, 1),
    ("G0 Z5\nG0 Z5 F10\nG83 X1 Z-2 R1 Q0", "E-CYCLE", 3, 15),
    ("G0 Z5\nG86 X1 Z-2 R1 P1 F100", "E-SPINDLE", 2, 1),
    ("G10 L2 X1", "E-OFFSET", 1, 1),
    ("G10 L3 P1 X1", "E-OFFSET", 1, 5),
    ("G0 X1\nG28.1 X2", "E-OFFSET", 2, 7),
    ("G93 G1 X1 F10\nG1 X2", "E-FEED-MODE", 2, 1),
    ("G95 G1 X1 F0.1", "E-FEED-MODE", 1, 5),
    ("G0 X1\nM101", "E-MCODE-USER", 2, 1),
    ("G21\n  $H", "E-DIALECT", 2, 3),
    ("G0 X1 M77", "E-MCODE-UNSUPPORTED", 1, 7),
    ("G0 X1 X2", "E-WORD-REPEATED", 1, 7),
    ("G0 G1 X1", "E-MODAL-GROUP", 1, 4),
    ("G17 G18", "E-MODAL-GROUP", 1, 5),
    ("M3 M5 S100", "E-MODAL-GROUP", 1, 4),
    ("G0 X0\nG1 G92 X0", "E-AXIS-CONFLICT", 2, 1),
    ("G0 X10\nG1 X1 @3 F10", "E-POLAR", 2, 4),
    ("G0 X1 I2", "E-WORD-UNUSED", 1, 7),
    ("G0 X1 H2", "E-WORD-UNUSED", 1, 7),
    ("G0 X1\nG1 X2 F10 L3", "E-WORD-UNUSED", 2, 11),
    ("G4", "E-WORD-MISSING", 1, 1),
    ("G0 X0\nG92", "E-WORD-MISSING", 2, 1),
    ("G0 X0\nM6", "E-WORD-MISSING", 2, 1),
    ("F100\nG5.2 X1 P1", "E-WORD-MISSING", 2, 6),
    ("G0 X1 F-5", "E-VALUE", 1, 7),
    ("G4 P-1", "E-VALUE", 1, 4),
    ("T1.5", "E-VALUE", 1, 1),
    ("F100 G2 X0 Y0 I1 P1.5", "E-VALUE", 1, 18),
    ("X1", "E-NO-MOTION-MODE", 1, 1),
    ("G0 X1\nG80\n Y2", "E-NO-MOTION-MODE", 3, 2),
    ("G1 X1", "E-FEED-ZERO", 1, 1),
    ("G1 F0 X1", "E-FEED-ZERO", 1, 1),
    ("G1 X0 F10\nF0\n  Y1", "E-FEED-ZERO", 3, 3),
    ("G91 G53 G0 X1", "E-G53", 1, 5),
    ("G53 G2 X1 I1 F10", "E-G53", 1, 1),
    ("G0 X#<nope>", "E-PARAM", 1, 4),
    ("G0 X#6000", "E-PARAM", 1, 4),
    ("G0 X[1/0]", "E-EXPR", 1, 4),
    ("G0 X0 Y[SQRT[-1]]", "E-EXPR", 1, 7),
    ("G0 X[" + "-" * 196 + "#1]", "E-EXPR-TOO-DEEP", 1, 4),
    ("G0 X1\nG0 X[" + "+".join(["1"] * 196) + "]", "E-EXPR-TOO-DEEP", 2, 4),
    ("G0 X" + "[" * 1000 + "1" + "]" * 1000, "E-EXPR-TOO-DEEP", 1, 105),
    ("G0 X1\no1 if [" + "[" * 200 + "1" + "]" * 200 + "]", "E-EXPR-TOO-DEEP", 2, 107),
    ("G0 X1\no100 endsub", "E-OWORD", 2, 1),
    ("o1 if [1]\nG0 X1\no1 endwhile", "E-OWORD", 3, 1),
    ("o1 while [0]\nG0 X1", "E-OWORD", 1, 1),
    ("G0 X1\no1 frob", "E-OWORD", 2, 4),
    ("G0 X1\nM99", "E-OWORD", 2, 1),
    ("G0 X1\n  o<nowhere> call [1]", "E-SUB-NOT-FOUND", 2, 1),
    ("M98 P77", "E-SUB-NOT-FOUND", 1, 1),
    ("G0 X0\no1 repeat [20000000]\nG0 X1\no1 endrepeat", "E-LOOP-LIMIT", 2, 1),
    ("o<r> sub\nG0 X1\no<r> call\no<r> endsub\no<r> call", "E-CALL-DEPTH", 3, 1),
    ("F100 G2 X1 Y1 R1 I1", "E-ARC-FORMAT", 1, 15),
    ("F100 G2 X1 Y1", "E-ARC-FORMAT", 1, 6),
    ("F100 G2 X1 Y1 K1", "E-ARC-FORMAT", 1, 15),
    ("F100 G2 X2 Y0 I1.1", "E-ARC-RADIUS", 1, 15),
    ("F100 G2 X0 Y0 R1", "E-ARC-R-FULL", 1, 15),
    ("F100 G2 X4 Y0 R1", "E-ARC-R-SMALL", 1, 15),
    ("F100 G6.2 P7 K0", "E-NURBS-ORDER", 1, 11),
    ("F100 G5.2 X1 Y1 P1 L1", "E-NURBS-ORDER", 1, 20),
    ("F100 G6.2 P2 K0 R0", "E-NURBS-WEIGHT", 1, 17),
    ("F100\nG5.2 X1 Y1 P1\nX2 Y0 P-1", "E-NURBS-WEIGHT", 3, 7),
    ("F100 G6.2 P2 K0 X5", "E-NURBS-START", 1, 17),
    ("F100 G6.2 P2 K0\nX1 K0\nX2\nK1\nK1", "E-NURBS-KNOT-COUNT", 5, 1),
    ("F100 G6.2 P2 K1\nX1 K0", "E-NURBS-KNOT-ORDER", 2, 4),
    ("F100 G6.2 P2 K0\nX1 K1\nK1\nK1", "E-NURBS-KNOT-CLAMP", 4, 1),
    # an end knot value repeated more than `order` times leaves an end control point without influence
    ("F100 G6.2 P2 K0\nX1 K0\nX2 K0\nK1\nK1", "E-NURBS-KNOT-CLAMP", 5, 1),
    ("F100 G6.2 P2 K0\nX1 K0\nX2 K1\nK1\nK1", "E-NURBS-KNOT-CLAMP", 5, 1),
    ("F100 G6.2 P2 K0\nX1 K0\nX2 K1\nX3 K1\nK2\nK2", "E-NURBS-KNOT-MULT", 6, 1),
    ("F100 G6.2 P3 K0\nX1 K0\nK0\nK1\nK1", "E-NURBS-POINTS", 5, 1),
    ("F100\nG5.2 X1 Y1 P1 L4\nG5.3", "E-NURBS-POINTS", 3, 1),
    ("F100 G6.2 P2 K0\n  M3", "E-NURBS-BLOCK", 2, 3),
    ("F100 G6.2 P2 K0\nX1 K0 S5", "E-NURBS-BLOCK", 2, 7),
    ("F100 G17 G5.2 X1 Y1 P1\nX2 Y2 Z1 P1", "E-NURBS-BLOCK", 2, 7),
    ("F100 G6.2 P2 K0\nX1 K0\nG1 X3", "E-NURBS-INCOMPLETE", 1, 1),
    ("G0 X0\n\nF100 G5.2 X1 Y1 P1 L3\nX2 Y0 P1", "E-NURBS-INCOMPLETE", 3, 1),
]


def _first_error(text: str):
    with pytest.raises(GCodeError) as info:
        ipr.parse_text(text, "part.nc")
    return info.value.diagnostics[0]


@pytest.mark.parametrize("text,code,line,col", CASES, ids=[f"{c[1]}-{i}" for i, c in enumerate(CASES)])
def test_error_code_line_and_column(text, code, line, col):
    d = _first_error(text)
    assert (d.code, d.line, d.col) == (code, line, col), str(d)
    assert str(d).startswith(f"part.nc:{line}:{col}: error[{code}]: ")
    assert d.message


def test_every_error_code_is_exercised():
    tested = {c[1] for c in CASES}
    assert {c for c in CODES if c.startswith("E-")} == tested


def test_error_table_is_documented():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "gcode-errors.md").read_text()
    for code in CODES:
        assert f"`{code}`" in doc, code


def test_messages_name_the_code_or_the_number():
    assert "G76" in _first_error("G0 X1\nG76 P1 Z-5 I1 J1 K1").message
    assert "G33" in _first_error("G0 X1 G33 X2 K1").message
    assert "0.200 mm off the circle" in _first_error("F100 G2 X2 Y0 I1.1").message
    assert "line 2" in _first_error("F100\nG6.2 P3 K0\nX1 K0\nK0\nK1\nK1\nK1").message


def test_incomplete_group_names_its_first_line():
    d = _first_error("G0 X0\nF100\nG6.2 P2 K0\nX1 K0\nK1\n")
    assert (d.code, d.line) == ("E-NURBS-INCOMPLETE", 3)


def test_all_errors_collects_every_error_and_continues():
    text = "G0 X1\nG33 X2 K1\nG1 X3\nG0 Y4 Y5\nF100 G1 X6\nM77\n"
    with pytest.raises(GCodeError) as info:
        ipr.parse_text(text, "p.nc", all_errors=True)
    got = [(d.line, d.code) for d in info.value.diagnostics]
    assert got == [(2, "E-GCODE-UNSUPPORTED"), (3, "E-FEED-ZERO"), (4, "E-WORD-REPEATED"),
                   (6, "E-MCODE-UNSUPPORTED")]


def _entities_with_errors(text: str):
    """Entities of a program run with all_errors, by interpreting it through the library."""
    from ipr.interpreter import Interpreter

    interp = Interpreter("p.nc", all_errors=True)
    for n, line in enumerate(text.split("\n"), 1):
        interp.feed(n, line)
    return interp.out, interp.diagnostics


@pytest.mark.parametrize("bad", [
    "G91 G20 G2 X1 Y1 R0.1 F10",          # arc error after distance, units and feed changes
    "G92 X50 G1 Y2 X3",                    # axis conflict with G92
    "G18 G61 G55 G43 H1 G1 X1 F10 I3",     # unused word after plane, path, coords, tool changes
    "G21 G90 M3 S500 G4 P-1",              # dwell error after spindle start
    "#1=5 G0 X[1/0]",                      # assignment not made when the block fails
])
def test_erroneous_block_changes_no_state(bad):
    prog = f"G21 G90 G17 G54 F600\nG0 X10 Y10 Z10\n{bad}\nG1 X20\nG0 X#1\n"
    ents, diags = _entities_with_errors(prog)
    assert [d.line for d in diags] == [3]
    line, rapid = ents[-2], ents[-1]
    # mm, absolute, XY, G54 zero, F600 mm/min: all as before the bad block
    assert isinstance(line, Line) and line.start == (10.0, 10.0, 10.0) and line.end == (20.0, 10.0, 10.0)
    assert line.feed_mm_s == pytest.approx(10.0)
    assert line.path.exact_stop is False
    assert isinstance(rapid, Rapid) and rapid.end == (0.0, 10.0, 10.0)  # #1 still 0


def test_bad_block_inside_nurbs_group_leaves_group_intact():
    text = "G0 X0 Y0\nF600\nG6.2 P2 K0\nX5 K0 R-1\nX10 K0\nK1\nK1\n"
    ents, diags = _entities_with_errors(text)
    assert [(d.line, d.code) for d in diags] == [(4, "E-NURBS-WEIGHT")]
    nurbs = ents[-1]
    assert nurbs.points.tolist() == [[0, 0, 0], [10, 0, 0]]
    assert nurbs.knots.tolist() == [0, 0, 1, 1]
