"""Every row of ../shared/spec/gcode.md's sections "Lines and words" and "Modal groups and
codes", checked on small programs against hand-computed values."""
from __future__ import annotations

import math

import pytest

import ipr
from ipr.entities import (Arc, Coolant, Dwell, GCodeError, Line, Message, ProgramEnd, Rapid, Spindle,
                          Stop, ToolChange)


def ents(text: str, **kw):
    return ipr.parse_text(text, **kw).entities


def moves(text: str, **kw):
    return [e for e in ents(text, **kw) if isinstance(e, (Rapid, Line, Arc))]


def error(text: str, **kw):
    with pytest.raises(GCodeError) as info:
        ipr.parse_text(text, **kw)
    return info.value.diagnostics[0]


# ---- lines and words -------------------------------------------------------------------------

def test_percent_starts_and_ends_the_program():
    out = moves("%\nG0 X1\n%\nG0 X2\nthis is not G-code\n")
    assert [m.end for m in out] == [(1.0, 0.0, 0.0)]


def test_percent_only_opens_and_closes():
    assert [m.end for m in moves("(title)\n\n%\nG0 X1\n%\n")] == [(1.0, 0.0, 0.0)]
    d = error("G0 X1\n%\n")
    assert (d.code, d.line, d.col) == ("E-SYNTAX", 2, 1)


def test_line_number_only_opens_a_block():
    assert moves("N5 G0 X1\n")[0].end == (1.0, 0.0, 0.0)
    d = error("G1 F100 X1 N5\n")
    assert (d.code, d.line, d.col) == ("E-SYNTAX", 1, 12)


def test_byte_order_mark_is_not_text(tmp_path):
    path = tmp_path / "bom.nc"
    path.write_bytes(b"\xef\xbb\xbfG0 X1\r\nG0 X2\r\n")
    assert [m.end[0] for m in ipr.parse_file(path).entities] == [1.0, 2.0]
    assert [m.end[0] for m in moves("\ufeffG0 X1\n")] == [1.0]


def test_program_number_is_recorded():
    assert ipr.parse_text("O1234\nG0 X1\n").program_number == 1234


def test_block_delete_on_by_default_and_off_by_setup():
    text = "G0 X1\n/G0 X2\nG0 Y1\n"
    assert [m.end for m in moves(text)] == [(1, 0, 0), (1, 1, 0)]
    assert [m.end for m in moves(text, setup=ipr.Setup(block_delete=False))] == [(1, 0, 0), (2, 0, 0), (2, 1, 0)]


def test_line_numbers_comments_and_messages():
    out = ents("N10 G0 X1 (move) Y2 ; trailing comment with G1 X99\n(MSG, insert the 6 mm ball)\nN20 G0 Z3\n")
    assert [type(e) for e in out] == [Rapid, Message, Rapid]
    assert out[0].end == (1.0, 2.0, 0.0)
    assert out[1].text == "insert the 6 mm ball" and out[1].line == 2


def test_case_and_blanks_inside_words_and_numbers():
    """RS274NGC ignores blanks: "x 1 2 . 5" is X12.5, "y - 3" is Y-3."""
    out = moves("g0 x 1 2 . 5 y - 3\nG 0 Z.5\n")
    assert out[0].end == (12.5, -3.0, 0.0) and out[1].end == (12.5, -3.0, 0.5)


def test_fast_path_equals_full_grammar_on_examples():
    for text in ["G1 X12.3456 Y-5.4321 Z0.3 F1200", "/N10G1X1", " X3.2040 Z-0.1539\r", "G1 X1 2",
                 "G0 Z[#3*10.]", "m3 s1000", "G6.2 X54.493 Y52.139 R1 K0 P5 Q1", "",
                 "Y[#2*-56.12] Z[#3*-27.725]", "#1 = .5", "#[1+2]=3 X-[2]", "X--5 (note 5)",
                 "G1 X[1-2-3] F[#4*100]", "X[-2**2] Y[SIN[30]]", "(MSG, part 5)", "#<a>=[1 EQ 1]"]:
        assert ipr.parse_line(text) == ipr.parse_line_full(text), text
    for bad, col in (("X[1.5.5]", 6), ("N-0; ", 2), ("n+3 x1", 2)):   # a line number takes no sign
        errors = []
        for parse in (ipr.parse_line, ipr.parse_line_full):
            with pytest.raises(ipr.LineSyntaxError) as info:
                parse(bad)
            errors.append((info.value.col, info.value.message))
        assert errors[0] == errors[1] and errors[0][0] == col, bad


def test_g_and_m_may_repeat_across_groups():
    out = ents("G21 G90 G17 G0 X1 M3 M8 S100\n")
    assert [type(e) for e in out] == [Spindle, Coolant, Rapid]


def test_parameters_named_numbered_and_assignments_after_the_block():
    """All reads in a block see the values from before it."""
    out = moves("#1=2 #<scale>=3\n#1=5 #2=#1 G0 X#1 Y[#<Scale>*#1]\nG0 Z#2\n")
    assert out[0].end == (2.0, 6.0, 0.0)
    assert out[1].end == (2.0, 6.0, 2.0)


def test_indirect_and_computed_parameter_numbers():
    out = moves("#1=7 #7=3\n#[#1+1]=4\nG0 X##1 Y#8\n")
    assert out[0].end == (3.0, 4.0, 0.0)


@pytest.mark.parametrize("expr,value", [
    ("[1+2*3]", 7.0), ("[[1+2]*3]", 9.0), ("[2**3**2]", 64.0), ("[7 MOD 3]", 1.0), ("[-7 MOD 3]", 2.0),
    ("[10/4]", 2.5), ("[1 AND 0]", 0.0), ("[1 OR 0]", 1.0), ("[1 XOR 1]", 0.0), ("[2 EQ 2]", 1.0),
    ("[2 NE 2]", 0.0), ("[3 GT 2]", 1.0), ("[2 GE 2]", 1.0), ("[1 LT 2]", 1.0), ("[3 LE 2]", 0.0),
    ("[1 + 2 GT 2]", 1.0), ("ABS[-2]", 2.0), ("[ACOS[0.5]]", 60.0), ("[ASIN[0.5]]", 30.0),
    ("ATAN[1]/[1]", 45.0), ("[ATAN[1]/[-1]]", 135.0), ("[COS[60]]", 0.5), ("[EXP[1]]", math.e),
    ("[FIX[-2.5]]", -3.0), ("[FUP[2.1]]", 3.0), ("[LN[EXP[2]]]", 2.0), ("[ROUND[2.5]]", 3.0),
    ("[7 MOD -3]", 1.0), ("[ROUND[-2.5]]", -3.0), ("[ROUND[-0.4]]", 0.0), ("[SIN[30]]", 0.5), ("[SQRT[16]]", 4.0), ("[TAN[45]]", 1.0), ("[-2**2]", 4.0), ("-[2]", -2.0),
])
def test_expression_operators_and_functions(expr, value):
    (m,) = moves(f"G0 X{expr}\n")
    assert m.end[0] == pytest.approx(value, abs=1e-12)


def test_3d_chips_style_scaled_coordinates():
    out = moves("#1 = .5\n#4 = 1000.0\nG0 X[#1*53.] Y[#1*-56.128]\nG1 Z[#1*-2] F[#4*0.06]\n")
    assert out[0].end == (26.5, -28.064, 0.0)
    assert out[1].feed_mm_s == pytest.approx(1.0)


# ---- modal groups ----------------------------------------------------------------------------

def test_motion_g0_g1_modal():
    out = moves("G0 X1\nY2\nG1 X3 F120\nY4\n")
    assert [type(m) for m in out] == [Rapid, Rapid, Line, Line]
    assert out[3].start == (3.0, 2.0, 0.0) and out[3].end == (3.0, 4.0, 0.0)
    assert out[0].feed_mm_s is None and out[3].feed_mm_s == pytest.approx(2.0)


def test_motion_codes_written_with_leading_zero():
    out = moves("G00 X1\nG01 X2 F60\nG02 X3 Y1 I0 J1\nG03 X2 Y2 R1\n")
    assert [type(m) for m in out] == [Rapid, Line, Arc, Arc]


def test_g80_cancels_modal_motion():
    assert error("G1 X1 F10\nG80\nX2\n").code == "E-NO-MOTION-MODE"


@pytest.mark.parametrize("code,plane", [("G17", "XY"), ("G18", "ZX"), ("G19", "YZ")])
def test_plane_selection(code, plane):
    offsets = {"XY": "I1", "ZX": "K1", "YZ": "J1"}[plane]
    (arc,) = moves(f"{code} F60\nG2 {offsets}\n")
    assert arc.plane == plane


def test_distance_modes():
    out = moves("G0 X1 Y1\nG91 G0 X1 Y-3\nX1\nG90 X0\n")
    assert [m.end for m in out] == [(1, 1, 0), (2, -2, 0), (3, -2, 0), (0, -2, 0)]


def test_arc_centre_distance_modes():
    out = moves("F60\nG0 X10 Y0\nG90.1 G3 X0 Y10 I0 J0\nG91.1 G3 X-10 Y0 I0 J-10\n")
    assert out[1].center == pytest.approx((0, 0, 0)) and out[2].center == pytest.approx((0, 0, 0))


def test_units_inch_converted_once():
    out = moves("G20 G0 X1 Y2 Z-0.5\nF10\nG1 X2\nG21 G1 X10\nG64 P0.01\nG20 G1 X1\n")
    assert out[0].end == pytest.approx((25.4, 50.8, -12.7))
    assert out[1].end == pytest.approx((50.8, 50.8, -12.7)) and out[1].feed_mm_s == pytest.approx(25.4 * 10 / 60)
    assert out[2].end == pytest.approx((10.0, 50.8, -12.7))
    assert out[2].feed_mm_s == pytest.approx(25.4 * 10 / 60)   # a unit change keeps the feed's speed
    assert out[3].path.blend_tol_mm == pytest.approx(0.01)       # set in mm
    assert out[3].end[0] == pytest.approx(25.4)


def test_feed_in_the_block_of_a_unit_change_uses_the_old_units():
    """RS274NGC sets F (step 3) before G20/G21 (step 12), as rs274 does."""
    (m,) = moves("G21\nG20 G1 X1 F10\n")
    assert m.feed_mm_s == pytest.approx(10 / 60)


def test_feed_mode():
    assert moves("G94 G1 X1 F60\n")[0].feed_mm_s == pytest.approx(1.0)
    # G93: F2 is half a minute per move, whatever its length (rs274: SET_FEED_RATE(F * length))
    out = moves("G93 G1 X3 F2\nG1 X7 F2\nG20 G1 X1 F4\n")
    assert [m.feed_mm_s for m in out] == pytest.approx([3 * 2 / 60, 4 * 2 / 60, (25.4 - 7) * 4 / 60])
    # G95: F per revolution of the programmed S
    assert moves("S1200 M3\nG95 G1 X1 F0.05\n")[0].feed_mm_s == pytest.approx(0.05 * 1200 / 60)


def test_path_control():
    out = moves("G61 G0 X1\nG64 G0 X2\nG64 P0.05 Q0.01 G0 X3\nG20 G64 P0.001 G0 X4\n")
    assert out[0].path.exact_stop and not out[1].path.exact_stop
    assert out[1].path.blend_tol_mm is None
    assert (out[2].path.blend_tol_mm, out[2].path.merge_tol_mm) == (0.05, 0.01)
    assert out[3].path.blend_tol_mm == pytest.approx(0.0254)


def test_work_coordinate_systems_from_setup():
    setup = ipr.Setup(work_offsets_mm={"G54": (10.0, 0.0, 0.0), "G55": (0.0, 20.0, 0.0), "G59": (1, 2, 3)})
    out = moves("G0 X1\nG55 G0 X1\nG0 Y1\nG56 G0 X1\nG59 G0 X0 Y0 Z0\n", setup=setup)
    assert [m.end for m in out] == [(11, 0, 0), (1, 0, 0), (1, 21, 0), (1, 21, 0), (1, 2, 3)]


def test_g92_offset_and_cancel():
    out = moves("G0 X10 Y10\nG92 X0 Y0\nG0 X5\nG92.1\nG0 X5\n")
    assert [m.end for m in out] == [(10, 10, 0), (15, 10, 0), (5, 10, 0)]


def test_g53_machine_coordinates_for_one_block():
    setup = ipr.Setup(work_offsets_mm={"G54": (100.0, 0.0, 0.0)})
    out = moves("G0 X1\nG53 G0 X1\nX2\n", setup=setup)
    assert [m.end[0] for m in out] == [101, 1, 102]


def test_tool_length_offset():
    setup = ipr.Setup(tool_lengths_mm={1: 50.0})
    out = moves("G43 H1 G0 Z0\nG49 G0 Z0\nG43 H0 G0 Z1\n", setup=setup)
    assert [m.end[2] for m in out] == [50.0, 0.0, 1.0]
    assert ents("G40 G0 X1\n")[0].end == (1.0, 0.0, 0.0)


def test_tool_missing_from_table_is_a_warning_and_zero():
    prog = ipr.parse_text("G0 Z5.0 G43 H7 M8\n")
    rapid = [e for e in prog.entities if isinstance(e, Rapid)][0]
    assert rapid.end == (0.0, 0.0, 5.0)
    (w,) = prog.warnings
    assert (w.code, w.severity, w.line, w.col) == ("W-TOOL-UNKNOWN", "warning", 1, 13)


@pytest.mark.parametrize("code", ["G41", "G42"])
def test_cutter_compensation_of_an_unknown_tool_is_zero(code):
    prog = ipr.parse_text(f"G0 X1\n{code} D1\nG0 X2 Y3\n")
    assert prog.motions()[-1].end == (2.0, 3.0, 0.0)
    (w,) = prog.warnings
    assert (w.code, w.line, w.col) == ("W-TOOL-UNKNOWN", 2, 5) and "D1" in w.message


def test_dwell():
    (d,) = [e for e in ents("G4 P1.5\n") if isinstance(e, Dwell)]
    assert d.seconds == 1.5 and d.line == 1


@pytest.mark.parametrize("code", ["G28", "G30"])
def test_stored_positions(code):
    """G28/G30 Z5 in G91: up by 5 (the intermediate point), then Z only to the stored position;
    G28.1/G30.1 store the position the machine stands at (sequence checked by hand)."""
    out = moves(f"G0 X1 Y2 Z3\nG91 {code} Z5\nG90 G0 X4 Y5 Z6\n{code}.1\nG0 X0 Y0 Z0\n{code}\n")
    assert [m.end for m in out] == [(1, 2, 3), (1, 2, 8), (1, 2, 0), (4, 5, 6), (0, 0, 0), (0, 0, 0),
                                    (4, 5, 6)]


def test_spindle_coolant_stops_end_and_tool_change():
    setup = ipr.Setup(tool_lengths_mm={2: 10.0})
    out = ents("T2 M6\nS1000 M3\nS2000\nM4\nM5\nM7\nM8\nM9\nM0\nM1\nM30\nG0 X1\n", setup=setup)
    assert out == [
        ToolChange(1, 2),
        Spindle(2, 1000.0, "cw"), Spindle(3, 2000.0, "cw"), Spindle(4, 2000.0, "ccw"), Spindle(5, 2000.0, None),
        Coolant(6, True, False), Coolant(7, True, True), Coolant(8, False, False),
        Stop(9, False), Stop(10, True), ProgramEnd(11),
    ]


def test_m2_ends_the_program():
    assert [type(e) for e in ents("G0 X1\nM2\nG0 X2\n")] == [Rapid, ProgramEnd]


def test_unknown_tool_in_m6_is_a_warning():
    prog = ipr.parse_text("M6 T3\n")
    assert prog.entities == [ToolChange(1, 3)]
    assert [w.code for w in prog.warnings] == ["W-TOOL-UNKNOWN"]


def test_entities_carry_line_feed_and_path_mode():
    out = moves("G61\n\nG1 X1 F30\n")
    assert out[0].line == 3 and out[0].feed_mm_s == 0.5 and out[0].path.exact_stop


def test_iter_entities_streams_the_same_entities():
    text = "G21 F600\nG0 X1\nG1 X2 Y2\nG2 X3 Y1 R1\nM2\n"
    assert list(ipr.iter_entities(text.split("\n"))) == ents(text)
