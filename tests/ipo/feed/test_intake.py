"""The feed stage's intake: what a build hands on (pieces with the drivers they walk), what
it keeps (the held-back motion), and where an event read now happens, against lengths
computed by hand and by scipy's quadrature."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from ipo.config import default_config
from ipo.feed.intake import CornerRules, Intake
from ipo.feed.pieces import KIND_NURBS
from ipr.entities import EXACT_STOP, Line, Nurbs, PathControl

CFG = default_config()
# the quadratic Bezier (0,0) (5,2) (10,0): B'(u) = (10, 4 (1 - 2u))
ARCH = Nurbs(1, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.ones(3), np.array([[0, 0, 0], [5, 2, 0], [10, 0, 0.0]]),
             20.0, EXACT_STOP)
ARCH_MM = quad(lambda u: np.hypot(10.0, 4.0 * (1 - 2 * u)), 0.0, 1.0, epsabs=1e-13)[0]


def _intake() -> Intake:
    return Intake(method=CFG.method, end_gap_mm=0.0, blend_default_mm=CFG.g64_blend_tol_mm,
                  rapid_mm_s=CFG.rapid_mm_s, corners=CornerRules(0.0, None))


def test_a_build_hands_on_the_drivers_of_its_pieces_and_keeps_the_held_back_motions():
    intake = _intake()
    intake.add_line(Line(1, (-5.0, 0.0, 0.0), (0.0, 0.0, 0.0), 20.0, EXACT_STOP))
    intake.add(ARCH)
    new = intake.build(final=False)  # the line; the curve is held back
    assert list(new.pieces.nurbs) == [-1] and new.drivers == {}
    assert intake.event_at_mm(5.0) == pytest.approx(5.0 + ARCH_MM, abs=1e-6)
    intake.add_line(Line(2, (10.0, 0.0, 0.0), (20.0, 0.0, 0.0), 20.0, EXACT_STOP))
    new = intake.build(final=False)  # the curve; the last line is held back
    assert list(new.pieces.kind) == [KIND_NURBS] and list(new.drivers) == [int(new.pieces.nurbs[0])]
    assert new.pieces.length[0] == pytest.approx(ARCH_MM, abs=1e-6)
    assert intake.event_at_mm(5.0 + ARCH_MM) == pytest.approx(15.0 + ARCH_MM, abs=1e-12)
    new = intake.build(final=True)
    assert list(new.pieces.length) == [10.0] and new.drivers == {}
    assert not intake.pending and intake.build(final=True) is None


def test_an_event_after_a_blended_corner_sits_at_the_held_back_moves_programmed_end():
    """Two 10 mm lines at 90 degrees under G64 P0.1: the arc R (sec 45 - 1) = P takes
    d = R tan 45 of each; the event read after the second line is at its programmed end,
    (10 - d) + R pi / 2 + (10 - d) along the path."""
    p = PathControl(blend_tol_mm=0.1)
    intake = _intake()
    intake.add_line(Line(1, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0), 20.0, p))
    intake.add_line(Line(2, (10.0, 0.0, 0.0), (10.0, 10.0, 0.0), 20.0, p))
    r = 0.1 / (np.sqrt(2) - 1)
    assert intake.build(final=False).pieces.length.sum() == pytest.approx(10 - r + r * np.pi / 2, abs=1e-12)
    assert intake.event_at_mm(10 - r + r * np.pi / 2) == pytest.approx(20 - 2 * r + r * np.pi / 2, abs=1e-12)
