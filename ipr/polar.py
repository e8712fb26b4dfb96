"""LinuxCNC's polar coordinates: `@` (radius) and `^` (angle, degrees) in place of X and Y.

The pole is the active origin of program coordinates. In G90 `@`/`^` set the end point's
radius/angle (a missing one keeps the current point's); in G91 they are added to the current
point's radius and angle, so `G91 G1 ^10` turns about the origin, not about the current
point (rs274's interp_find.cc find_ends; LinuxCNC G-code reference, "Polar coordinates").
Only for motion in the G17 plane, never with X or Y or with G53.
"""
from __future__ import annotations

import math

from ipr.errors import BlockError

RADIUS, ANGLE = "@", "^"


def end_xy(st, spec, vals, here_xy, absolute: bool) -> tuple[float, float]:
    """The XY end point, in the units of `here_xy` (the current point, program coordinates)."""
    r_i, a_i = spec.index.get(RADIUS), spec.index.get(ANGLE)
    if st.plane != "XY":
        raise BlockError("E-POLAR", "polar coordinates (@, ^) only in the G17 (XY) plane",
                         r_i if r_i is not None else a_i)
    if here_xy[0] == 0.0 and here_xy[1] == 0.0 and (not absolute or a_i is None):
        raise BlockError("E-POLAR", "at the origin the current angle is undefined: "
                         + ("G91 polar motion cannot start here" if not absolute else "give the angle (^)"),
                         r_i if r_i is not None else a_i)
    radius = math.hypot(here_xy[0], here_xy[1])
    angle = math.atan2(here_xy[1], here_xy[0])
    if absolute:
        radius = vals[r_i] if r_i is not None else radius
        angle = math.radians(vals[a_i]) if a_i is not None else angle
    else:
        radius += vals[r_i] if r_i is not None else 0.0
        angle += math.radians(vals[a_i]) if a_i is not None else 0.0
    return radius * math.cos(angle), radius * math.sin(angle)
