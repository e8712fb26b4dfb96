"""The interpolator's error type: a block ipo cannot plan or step, with a stable code and its line.

ipr refuses bad text (ipr.entities.GCodeError); ipo refuses, with IpoError, a motion it
was handed but cannot follow: a curve whose derivative vanishes, an arc of zero radius, a
move that does not start where the machine stands. The controller catches IpoError only;
anything else ipo raises (a ValueError for a bad argument, a RuntimeError, an
AssertionError) is a bug and surfaces as one. The codes are listed in docs/gcode-errors.md.
"""
from __future__ import annotations

# The codes (stable; docs/gcode-errors.md explains each).
NURBS_PATH = "E-NURBS-PATH"  # a NURBS the feed stage cannot walk (its derivative vanishes)
NURBS_DATA = "E-IPO-NURBS-DATA"  # a NURBS entity whose degree, points, weights or knots are not a curve
NURBS_CUT = "E-IPO-NURBS-CUT"  # a cut of a NURBS outside its knot range
ARC_RADIUS = "E-IPO-ARC-RADIUS"  # an arc whose start lies on its centre
NON_FINITE = "E-IPO-NON-FINITE"  # a motion with a non-finite coordinate
START = "E-IPO-START"  # a motion that does not start where the machine stands
ROUGHNESS_TARGET = "E-IPO-ROUGHNESS-TARGET"  # a roughness target the pick feed cannot meet
SCURVE = "E-IPO-SCURVE"  # no jerk-limited profile within the axis limits was found (S-curve mode)
TWIN_INPUT = "E-IPO-TWIN-INPUT"  # a block a controller twin cannot model as the controller would receive it
CODES = (NURBS_PATH, NURBS_DATA, NURBS_CUT, ARC_RADIUS, NON_FINITE, START, ROUGHNESS_TARGET, SCURVE, TWIN_INPUT)


class IpoError(ValueError):
    """ipo cannot plan or step a motion: `code` (one of CODES), `line` (the source line, or
    None for a machine setting) and `message`. str() reads `line N: message`."""

    def __init__(self, code: str, message: str, line: int | None = None):
        self.code = code
        self.message = message
        self.line = line
        super().__init__(message if line is None else f"line {line}: {message}")
