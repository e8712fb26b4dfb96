"""grbl's numbers in single precision: the parser's read_float and plan_buffer_line's rounding to
steps. Checked against grbl 1.1h itself: in grbl-sim (instrumented to log each planned block) the
move from Y15.266 Z-2.7177 to Y15.262 Z-2.6955 at 250 steps/mm was a block of 0.0215 mm, i.e.
2 steps in Y and 5 in Z (sqrt(0.008^2 + 0.020^2)); rounding the decimal values instead gives
1 step in Y (0.0204 mm), and a junction speed of 1929 mm/min where grbl planned 1000.5 (on
g1_3d_chips that was 0.35 % of the job time)."""
from __future__ import annotations

import math

import numpy as np

from ipo.feed.grbl_twin.numbers import read_float, to_steps


def test_half_steps_round_as_grbl_parses_them():
    y0, y1 = read_float("15.266"), read_float("15.262")
    z0, z1 = read_float("-2.7177"), read_float("-2.6955")
    steps = [to_steps(y0, 250.0), to_steps(y1, 250.0), to_steps(z0, 250.0), to_steps(z1, 250.0)]
    assert steps == [3817, 3815, -679, -674]
    assert round(math.hypot((steps[1] - steps[0]) / 250, (steps[3] - steps[2]) / 250), 4) == 0.0215
    # the nearest single-precision values round 15.262 the other way: one step in Y, not two
    assert to_steps(float(np.float32(15.266)), 250.0) - to_steps(float(np.float32(15.262)), 250.0) == 1


def test_read_float_follows_grbls_digits():
    assert read_float("0") == 0.0 and read_float("-.5") == -0.5 and read_float("+3") == 3.0
    assert read_float("12.") == 12.0 and read_float("7.25X") == 7.25  # stops at the next word
    # only 8 digits are kept: later integer digits scale by ten, later decimals are dropped
    assert read_float("123456789") == np.float32(123456780.0)
    assert read_float("1.234567891") == read_float("1.2345678")
    assert to_steps(-0.002, 250.0) == -1 and to_steps(0.002, 250.0) == 1  # halves away from zero
