"""Dialects (ipr.dialect) and G5/G5.1 splines."""
from __future__ import annotations

from math import comb

import numpy as np
import pytest
from scipy.interpolate import BSpline

import ipr
from ipr.entities import Auxiliary, Dwell, GCodeError, Nurbs


def _ents(text: str, dialect: str = "linuxcnc"):
    return ipr.parse_text(text, setup=ipr.Setup(dialect=dialect))


def test_fanuc_dwell_is_in_milliseconds() -> None:
    assert [e.seconds for e in _ents("G4 P500\n", "fanuc").entities if isinstance(e, Dwell)] == [0.5]
    assert [e.seconds for e in _ents("G4 P500\n").entities if isinstance(e, Dwell)] == [500.0]
    cycle = "G0 Z5\nG82 X1 Z-1 R1 P250 F100\n"
    assert [e.seconds for e in _ents(cycle, "fanuc").entities if isinstance(e, Dwell)] == [0.25]


@pytest.mark.parametrize("dialect", ["fanuc", "haas", "mach3", "grbl"])
def test_zero_normal_offset_on_an_arc(dialect: str) -> None:
    text = "G17 G0 X1 Y0\nG2 X-1 Y0 I-1 J0 K0 F100\n"
    prog = _ents(text, dialect)
    assert prog.motions()[-1].center == (0.0, 0.0, 0.0)
    assert [w.code for w in prog.warnings] == ["N-RECORDED"]
    with pytest.raises(GCodeError) as err:
        _ents(text)
    assert err.value.diagnostics[0].code == "E-ARC-FORMAT"
    with pytest.raises(GCodeError):
        _ents(text.replace("K0", "K0.5"), dialect)


def test_bookkeeping_codes_per_dialect() -> None:
    ents = _ents("M31\nG187 P2 E0.05\nG103 P1\nM88\n", "haas").entities
    assert [e.code for e in ents if isinstance(e, Auxiliary)] == ["M31", "G187", "G103", "M88"]
    assert [e.code for e in _ents("G05.1 Q1\nG08 P1\nM29 S500\n", "fanuc").entities
            if isinstance(e, Auxiliary)] == ["G5.1", "G8", "M29"]
    for text in ("M31\n", "G187 P2\n"):
        with pytest.raises(GCodeError):
            _ents(text)


def test_grbl_system_commands_are_refused_in_every_dialect() -> None:
    for dialect in ("linuxcnc", "grbl"):
        with pytest.raises(GCodeError) as err:
            _ents("G21\n$H\n", dialect)
        assert (err.value.diagnostics[0].code, err.value.diagnostics[0].line) == ("E-DIALECT", 2)


def test_g5_is_the_cubic_bezier_and_continues_smoothly() -> None:
    """G5 I J P Q: control points start + (I, J) and end + (P, Q); a following G5 without I J
    starts along the previous end tangent (I J = -P -Q). Checked with scipy's B-spline on the
    Bernstein form B(t) = sum C(3,k) t^k (1-t)^(3-k) P_k."""
    prog = ipr.parse_text("G21 G17 G0 X0 Y0 Z2\nG5 I0 J3 P0 Q-3 X1 Y1 F100\nG5 P1 Q0 X4 Y0\nG5.1 I1 J1 X6 Y0\n")
    c1, c2, q = [e for e in prog.entities if isinstance(e, Nurbs)]
    assert c1.points.tolist() == [[0, 0, 2], [0, 3, 2], [1, -2, 2], [1, 1, 2]]
    assert c2.points.tolist() == [[1, 1, 2], [1, 4, 2], [5, 0, 2], [4, 0, 2]]
    assert q.degree == 2 and q.points.tolist() == [[4, 0, 2], [5, 1, 2], [6, 0, 2]]
    t = np.linspace(0, 1, 11)
    for curve in (c1, c2, q):
        d = curve.degree
        bern = sum(comb(d, k) * np.outer(t**k * (1 - t) ** (d - k), curve.points[k]) for k in range(d + 1))
        assert np.allclose(BSpline(curve.knots, curve.points, d)(t), bern, atol=1e-12)


def test_g5_needs_its_words() -> None:
    for text in ("G0 X0\nG5 X1 Y1 P0 Q1 F10\n", "G0 X0\nG5 I1 J1 X1 Y1 F10\n", "G0 X0\nG5.1 X1 Y1 F10\n",
                 "G18 G0 X0\nG5.1 I1 J1 X1 Y1 F10\n"):
        with pytest.raises(GCodeError):
            ipr.parse_text(text)
