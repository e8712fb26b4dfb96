"""NURBS block forms: Fanuc G06.2, LinuxCNC G6.2 and G5.2/G5.3, all to ipr.entities.Nurbs."""
from __future__ import annotations

import numpy as np
import pytest

import ipr
from ipr.entities import GCodeError, Line, Nurbs

FANUC = """G21 G90 G17
G0 X0 Y0 Z0
G06.2 P4 K0. X0. Y0. Z0. R1. F5000.
K0. X10. Y5. Z0. R1.
K0. X20. Y-5. Z0. R2.
K0. X30. Y0. Z0. R1.
K1.
K1.
K1.
K1.
G1 X40
"""


def _nurbs(text: str, **kw) -> list[Nurbs]:
    return [e for e in ipr.parse_text(text, **kw).entities if isinstance(e, Nurbs)]


def test_fanuc_example_of_the_spec():
    prog = ipr.parse_text(FANUC)
    (n,) = [e for e in prog.entities if isinstance(e, Nurbs)]
    assert n.line == 3 and n.degree == 3
    assert n.points.tolist() == [[0, 0, 0], [10, 5, 0], [20, -5, 0], [30, 0, 0]]
    assert n.weights.tolist() == [1, 1, 2, 1]
    assert n.knots.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    assert n.feed_mm_s == pytest.approx(5000 / 60)
    assert n.start == (0.0, 0.0, 0.0) and n.end == (30.0, 0.0, 0.0)
    line = prog.entities[-1]
    assert isinstance(line, Line) and line.start == (30.0, 0.0, 0.0)   # position = last point
    for arr in (n.points, n.weights, n.knots):
        assert not arr.flags.writeable


def test_default_order_weight_and_first_point_from_position():
    (n,) = _nurbs("G0 X1 Y2 Z3\nF600\nG6.2 K0\nX4 K0\nX5 K0\nX6 K0\nK1\nK1\nK1\nK1\n")
    assert n.degree == 3
    assert n.points.tolist() == [[1, 2, 3], [4, 2, 3], [5, 2, 3], [6, 2, 3]]   # omitted axes modal
    assert n.weights.tolist() == [1, 1, 1, 1]


@pytest.mark.parametrize("dx,ok", [(0.0009, True), (0.0011, False)])
def test_first_control_point_must_be_the_current_position(dx, ok):
    text = f"G0 X0 Y0\nF600\nG6.2 P2 K0 X{dx}\nX10 K0\nK1\nK1\n"
    if ok:
        assert len(_nurbs(text)) == 1
    else:
        with pytest.raises(GCodeError) as info:
            ipr.parse_text(text)
        d = info.value.diagnostics[0]
        assert (d.code, d.line, d.col) == ("E-NURBS-START", 3, 12)


def test_incremental_control_points_are_relative_to_the_previous_one():
    (n,) = _nurbs("G0 X5 Y5\nF600\nG91\nG6.2 P3 K0 R1\nX10 Y0 K0\nX0 Y10 K0 R3\nX-5 K0.5\nK1\nK1\nK1\n")
    assert n.points.tolist() == [[5, 5, 0], [15, 5, 0], [15, 15, 0], [10, 15, 0]]
    assert n.weights.tolist() == [1, 1, 3, 1]


def test_inch_and_work_offset_control_points():
    setup = ipr.Setup(work_offsets_mm={"G54": (100.0, 0.0, -10.0)})
    (n,) = _nurbs("G20 G54\nG0 X0 Y0 Z0\nF10\nG6.2 P2 K0\nX1 Y1 K0\nK1\nK1\n", setup=setup)
    np.testing.assert_allclose(n.points, [[100, 0, -10], [125.4, 25.4, -10]], atol=1e-12)
    assert n.feed_mm_s == pytest.approx(10 * 25.4 / 60)


def test_linuxcnc_g6_2_form_with_q_notice():
    text = ("G21 G0 X0 Y0\nF290\nG6.2 X0 Y0 R1 K0 P3 Q1\n X1 Y2 R1 K0\n X2 Y0 R0.5 K0\n X3 Y2 R1 K1\n"
            "G6.2 K2\nG6.2 K2\nG6.2 K2\nG1 X3 Y2 Z1\n")
    prog = ipr.parse_text(text, "g6.ngc")
    (n,) = [e for e in prog.entities if isinstance(e, Nurbs)]
    assert n.degree == 2 and n.knots.tolist() == [0, 0, 0, 1, 2, 2, 2]
    assert n.weights.tolist() == [1, 1, 0.5, 1]
    (notice,) = prog.warnings
    assert (notice.code, notice.line, notice.col, notice.severity) == ("N-Q-IGNORED", 3, 21, "notice")


def test_g5_2_knots_are_linuxcnc_uniform_clamped():
    """LinuxCNC's nurbs_G5_knot_vector_creator for n+1 points, order k, scaled to 0..1."""
    text = "G17 G0 X0 Y0\nF100\nG5.2 P1 L3\n X0 Y1 P1\n X2 Y2 P1\n X2 Y0 P1\n X0 Y0 P2\nG5.3\n"
    (n,) = _nurbs(text)
    # 5 points, order 3: 0 0 0 1 2 3 3 3 (umax = n - k + 2 = 3)
    assert n.knots.tolist() == pytest.approx([0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1])
    assert n.points.tolist() == [[0, 0, 0], [0, 1, 0], [2, 2, 0], [2, 0, 0], [0, 0, 0]]
    assert n.weights.tolist() == [1, 1, 1, 1, 2]
    assert n.degree == 2


def test_g5_2_point_in_the_first_block_and_weight_of_point_zero():
    (n,) = _nurbs("G0 X1 Y1 Z7\nF100\nG5.2 X3 Y3 P2 L4\nX4 Y8 P1\nX5 Y10 P1\nG5.3\nG0 X0\n")
    assert n.points.tolist() == [[1, 1, 7], [3, 3, 7], [4, 8, 7], [5, 10, 7]]
    assert n.weights.tolist() == [1, 2, 1, 1]
    assert n.knots.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    (n,) = _nurbs("G0 X1 Y1\nF100\nG5.2 P3\nX4 Y8 P1\nX5 Y10 P1\nG5.3\n")
    assert n.weights.tolist() == [3, 1, 1]


@pytest.mark.parametrize("plane,words,expected", [
    ("G18", ["Z10 X0", "Z20 X20"], [[5, 1, 0], [0, 1, 10], [20, 1, 20]]),
    ("G19", ["Y10 Z0", "Y20 Z20"], [[1, 5, 0], [1, 10, 0], [1, 20, 20]]),
])
def test_g5_2_in_other_planes_keeps_the_normal_coordinate(plane, words, expected):
    start = "G0 X5 Y1 Z0" if plane == "G18" else "G0 X1 Y5 Z0"
    text = f"{plane} {start}\nF100\nG5.2 P1 L2\n{words[0]} P1\n{words[1]} P1\nG5.3\n"
    (n,) = _nurbs(text)
    assert n.points.tolist() == expected


def test_nurbs_after_nurbs_and_corpus_style_programs():
    text = FANUC.replace("G1 X40\n", "") + FANUC.replace("G21 G90 G17\nG0 X0 Y0 Z0\n", "G0 X0 Y0 Z0\n")
    assert len(_nurbs(text)) == 2


def test_mode_ends_after_the_group():
    """After a finished group no motion mode is active: axis words need a new G-code."""
    with pytest.raises(GCodeError) as info:
        ipr.parse_text(FANUC.replace("G1 X40", "X40"))
    assert info.value.diagnostics[0].code == "E-NO-MOTION-MODE"
