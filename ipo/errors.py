"""The interpolator's error type: a block ipo cannot plan or step, with a stable code and its line.

ipr refuses bad text (ipr.entities.GCodeError); ipo refuses, with IpoError, a motion it
was handed but cannot follow: a curve whose derivative vanishes, an arc of zero radius, a
move that does not start where the machine stands; and, in the fitting and surface chain, the
user's points, settings and surfaces it cannot take. The controller and the CLI catch IpoError only;
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
# The fitting and surface chain (vcnc fit, vcnc surface, vcnc toolpath): refusals of user input.
FIT_SETTINGS = "E-IPO-FIT-SETTINGS"  # a fitting setting out of range (tolerance, degree, control points, corner angle)
FIT_DATA = "E-IPO-FIT-DATA"  # points a fit cannot take (fewer than its control points, all at one place)
FIT_TOLERANCE = "E-IPO-FIT-TOLERANCE"  # no control-point count fits every section within the tolerance
SKIN = "E-IPO-SKIN"  # sections (or patches) that cannot be skinned into one surface
SURFACE_POINTS = "E-IPO-SURFACE-POINTS"  # a digitised-points file that cannot be read as sections
IGES = "E-IPO-IGES"  # an IGES file the reader cannot take, or a surface the writer cannot put in one
SURFACE_DATA = "E-IPO-SURFACE-DATA"  # a rational surface whose net, weights or knots are not a surface
TOOLPATH_SETTINGS = "E-IPO-TOOLPATH-SETTINGS"  # a ball, pick feed, tolerance, feed or direction out of range
TOOLPATH_SURFACE = "E-IPO-TOOLPATH-SURFACE"  # a surface the ball cannot finish (undercut, gouge, gap, crease)
STUDY = "E-IPO-STUDY"  # a chord or pulse study (vcnc interp) with no motion, a bad step, or a curve past its grid
CODES = (NURBS_PATH, NURBS_DATA, NURBS_CUT, ARC_RADIUS, NON_FINITE, START, ROUGHNESS_TARGET, SCURVE, TWIN_INPUT,
         FIT_SETTINGS, FIT_DATA, FIT_TOLERANCE, SKIN, SURFACE_POINTS, IGES, SURFACE_DATA, TOOLPATH_SETTINGS,
         TOOLPATH_SURFACE, STUDY)


class IpoError(ValueError):
    """ipo cannot plan or step a motion: `code` (one of CODES), `line` (the source line, or
    None for a machine setting) and `message`. str() reads `line N: message`."""

    def __init__(self, code: str, message: str, line: int | None = None):
        self.code = code
        self.message = message
        self.line = line
        super().__init__(message if line is None else f"line {line}: {message}")
