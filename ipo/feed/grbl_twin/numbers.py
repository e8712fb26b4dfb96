"""grbl's numbers: single-precision floats, as the board (and grbl-sim) hold them.

A coordinate of 3816.5 steps rounds to 3816 or 3817 depending on the last bit of the
float grbl parsed, which decides the direction of a 0.02 mm block and so its junction
speed; the twin reads the numbers as grbl's parser does and rounds them to steps as
plan_buffer_line does (nuts_bolts.c read_float, planner.c lround(target * steps_per_mm)).
"""
from __future__ import annotations

import math

import numpy as np

MAX_INT_DIGITS = 8  # nuts_bolts.h

f32 = np.float32


def read_float(text: str) -> np.float32:
    """nuts_bolts.c read_float: the digits as an integer (at most 8, later ones dropped), then
    the decimal point applied with float multiplications by 0.01, 0.1 or 10 (each product
    rounded to single precision, as grbl-sim's x86 build does)."""
    negative = text.startswith("-")
    digits = text.lstrip("+-")
    intval, exp, ndigit, decimal = 0, 0, 0, False
    for c in digits:
        if c == "." and not decimal:
            decimal = True
            continue
        if not c.isdigit():
            break
        ndigit += 1
        if ndigit <= MAX_INT_DIGITS:
            exp -= decimal
            intval = intval * 10 + int(c)
        elif not decimal:
            exp += 1
    value = f32(intval)
    if value != 0:
        while exp <= -2:
            value = f32(float(value) * 0.01)
            exp += 2
        if exp < 0:
            value = f32(float(value) * 0.1)
        while exp > 0:
            value = f32(float(value) * 10.0)
            exp -= 1
    return -value if negative else value


def to_steps(target_mm: float, steps_per_mm: float) -> int:
    """plan_buffer_line: lround(target * steps_per_mm) with a single-precision product (halves
    away from zero)."""
    x = float(f32(target_mm) * f32(steps_per_mm))
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))
