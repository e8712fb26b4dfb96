"""G28/G30, G10, G92, G43 and the modal fixes CAM posts need, against LinuxCNC's rs274.

Each program runs through both interpreters; every move's kind, end point (machine mm),
feed and path control must agree (tests/rs274.py converts rs274's output, G92 offsets,
tool lengths and the G10 L2 R rotation included). rs274 reads its tool table in inches.
"""
from __future__ import annotations

import pytest
from rs274 import INCH_MM, canon_moves, require_rs274, run_rs274
from test_ipr_rs274 import mismatches

import ipr
from ipr.entities import Auxiliary, GCodeError, Rapid

TOOLS_MM = {1: (12.5, 3.0), 2: (40.0, 1.5), 7: (0.0, 5.0)}   # tool -> (length, radius)

PROGRAMS = {
    "stored_positions": """G21 G90 G0 X5 Y5 Z5
G28 X1
G28.1
G0 X7 Y8 Z9
G28 Y3
G30.1
G0 X1
G30
G91 G28 Z2
G90 G30 X4 Y4
M2
""",
    "g92_family": """G21 G0 X5 Y5 Z5
G92 X0 Y0
G0 X1 Y2
G92.2
G0 X1
G92.3
G0 X1 Z1
G92 Z0
G1 Z-1 F100
G92.1
G0 X1 Y1 Z1
G52 X10 Y-3
G0 X0 Y0
G52 X0 Y0
G0 X0 Y0
M2
""",
    "g10_coordinate_systems": """G21 G0 X5 Y5 Z5
G10 L2 P1 X10 Y20 Z30
G0 X1
G10 L20 P2 X0 Y0
G55 G0 X1
G10 L2 P0 X1 R30
G0 X1 Y0
G1 X5 Y5 F200
G2 X7 Y3 I1 J-1
G91 G0 X1 Y1
G90 G59.1 G0 X0 Y0
G10 L2 P7 X-4 Y-4 Z-4
G0 X0 Y0 Z0
G54 G0 X0 Y0 Z0
M2
""",
    "tool_lengths": """G21 G0 X1 Y1 Z1
T1 M6
G43 H1
G0 Z10
G43.1 Z2
G0 X2
G43.2 H2
G0 X3
G49 G0 Z3
G10 L1 P2 Z3 R1
G43 H2
G0 X4
G10 L10 P7 Z5
G43 H7
G0 X5 Z5
G10 L11 P1 Z1
G43 H1 G0 X6
M2
""",
    "safe_start_and_modes": """%
G00 G17 G21 G40 G49 G80 G90
G0 X10 Y10 G80
G80 G1 X12 F300
G91.1 G94 G61.1 F300
G1 X13
G64 P0.02
G98 G81 X5 Y5 Z-3 R2 F100
G80
G93 G1 X20 F2
G2 X30 R5 F3
G94 F150
S1200 M3
G95 G1 X35 F0.1
G94 F200
G96 S200 D3000
G97 S500
M19 R90
M62 P1
M64 P2
M65 P2
M66 P0 L0
M67 E0 Q5
M68 E1 Q2
M48
M49
M50 P0
M51 P0
M70
G91 G20
M72
G1 X40
M61 Q2
G8
G1 X41
%
""",
}


def _tool_table(path):
    path.write_text("".join(f"T{t} P{t} Z{length / INCH_MM:.6f} D{2 * radius / INCH_MM:.6f}\n"
                            for t, (length, radius) in TOOLS_MM.items()))
    return path


SETUP = ipr.Setup(tool_lengths_mm={t: v[0] for t, v in TOOLS_MM.items()},
                  tool_radii_mm={t: v[1] for t, v in TOOLS_MM.items()})


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_matches_rs274(tmp_path, name: str) -> None:
    require_rs274()
    path = tmp_path / f"{name}.ngc"
    path.write_text(PROGRAMS[name])
    moves = canon_moves(run_rs274(path, tool_table=_tool_table(tmp_path / "tools.tbl")))
    entities = ipr.parse_text(PROGRAMS[name], setup=SETUP).entities
    assert len(moves) >= 8
    # rs274 prints a zero-length move for a bare G0/G1 (vcnc makes none: docs/gcode-notes.md)
    ends = [(0.0, 0.0, 0.0)] + [m.end_mm for m in moves]
    moves = [m for before, m in zip(ends, moves) if m.end_mm != before]
    entities = [e for e in entities if getattr(e, "start", None) != getattr(e, "end", 0)]
    problems = mismatches(moves, entities)
    assert not problems, "\n".join(problems)


def test_g10_l2_rotation_turns_moves_about_the_origin() -> None:
    """G10 L2 R90 with a zero offset: program +X is machine +Y (independent of rs274)."""
    out = [e for e in ipr.parse_text("G10 L2 P1 R90\nG0 X10 Y0\nG91 G0 X0 Y5\n").entities if isinstance(e, Rapid)]
    assert out[0].end == pytest.approx((0.0, 10.0, 0.0), abs=1e-12)
    assert out[1].end == pytest.approx((-5.0, 10.0, 0.0), abs=1e-12)


def test_m_codes_become_events() -> None:
    ents = ipr.parse_text("M62 P3\nM19 R45\nM50 P0\nG96 S100 D2000\nM61 Q4\n").entities
    codes = [e.code for e in ents if isinstance(e, Auxiliary)]
    assert codes == ["M62", "M19", "M50", "G96", "M61"]


def test_user_m_codes_need_the_machine_file() -> None:
    with pytest.raises(GCodeError) as err:
        ipr.parse_text("M101 P1\n")
    assert err.value.diagnostics[0].code == "E-MCODE-USER" and "M101" in err.value.diagnostics[0].message
    ents = ipr.parse_text("M101 P1\n", setup=ipr.Setup(user_mcodes={101: "clamp the vise"})).entities
    assert ents == [Auxiliary(1, "M101", "clamp the vise P1")]


def test_knock_on_errors_are_reported_once() -> None:
    """A refused motion block (A axis) leaves no motion mode: the bare moves after it are not
    reported again, a later error of its own is, and a notice counts what was left out."""
    from ipr.interpreter import Interpreter

    text = "G21 G90\nG1 X1 A5 F100\nX2 Y2\nX3\nG0 X5\nX6 Y[1/0]\nG80\nX1\n"
    interp = Interpreter("k.nc", all_errors=True)
    interp.finish(interp.run(text.split("\n")))
    assert [(d.line, d.code) for d in interp.diagnostics] == [(2, "E-AXIS-ABSENT"), (6, "E-EXPR"),
                                                             (8, "E-NO-MOTION-MODE")]
    assert [(d.line, d.code) for d in interp.warnings] == [(2, "N-KNOCK-ON")]
    assert "2 later errors" in interp.warnings[0].message
