"""G2/G3 geometry: the centre from I/J/K or R, checked against the end point.

All in machine mm, in the plane coordinates of ipr.entities.PLANE_AXES (a, b, normal):
G17 (X, Y), G18 (Z, X) and G19 (Y, Z), so that "counter-clockwise" is the same rule in
every plane, as RS274NGC defines it. The centre's normal coordinate is the start's.
"""
from __future__ import annotations

import math

from ipr.entities import PLANE_AXES, Arc, PathControl
from ipr.errors import BlockError

ARC_TOL_MM = 0.002      # gcode.md: end point on the circle within 0.002 mm ...
ARC_TOL_REL = 0.001     # ... or 0.1 % of the radius, whichever is larger
# In G20 the absolute part is 0.0002 inch (0.00508 mm): an inch program's last digit is
# 0.00254 mm, and rounding four numbers (start, end, I, K) to it moves the end by up to
# ~0.0036 mm (seen in the corpus's g1_stellabee1.ngc). LinuxCNC allows 0.0005 inch.
ARC_TOL_INCH = 0.0002


# LinuxCNC's interp_arc.cc: an end radius off by more than 2*0.001*sqrt(2) inch (G20) or
# 2*0.01*sqrt(2) mm (G21) *and* 0.1 % of the radius, or by more than 100 times that, is refused;
# below that LinuxCNC runs a spiral. vcnc runs a circle: such an arc's centre moves onto the
# perpendicular bisector of start and end (the nearest such point to the programmed centre).
SPIRAL_ABS_MM = 2 * 0.01 * math.sqrt(2)
SPIRAL_ABS_INCH = 2 * 0.001 * math.sqrt(2)
SPIRAL_REL = 0.001


def unit_tolerances_mm(unit_mm: float) -> tuple[float, float]:
    """The absolute part of the end point's tolerance, and LinuxCNC's spiral limit, in a unit."""
    if unit_mm == 1.0:
        return ARC_TOL_MM, SPIRAL_ABS_MM
    return ARC_TOL_INCH * unit_mm, SPIRAL_ABS_INCH * unit_mm


def radius_tolerance_mm(radius_mm: float, unit_mm: float = 1.0) -> float:
    return max(unit_tolerances_mm(unit_mm)[0], ARC_TOL_REL * radius_mm)


def center_from_offsets(start, end, plane: str, center_ab: tuple[float, float], word: int | None,
                        unit_mm: float = 1.0):
    """Check a centre-format arc: the end must lie on the circle through the start."""
    a, b, n = PLANE_AXES[plane]
    ca, cb = center_ab
    r0 = math.hypot(start[a] - ca, start[b] - cb)
    r1 = math.hypot(end[a] - ca, end[b] - cb)
    if r0 < 1e-9:
        raise BlockError("E-ARC-RADIUS", "arc centre is at the start point (zero radius)", word)
    err = abs(r1 - r0)
    limit = unit_tolerances_mm(unit_mm)[1]
    if err > 100.0 * limit or (err > limit and err / max(r0, r1) > SPIRAL_REL):
        raise BlockError("E-ARC-RADIUS", f"arc end point is {err:.3f} mm off the circle through the start "
                         f"point (radius {r0:.3f} mm; LinuxCNC allows {limit:.4f} mm, or 0.1 % of the "
                         f"radius up to {100 * limit:.2f} mm)", word)
    if err > radius_tolerance_mm(r0, unit_mm):
        na, nb = _onto_bisector(start[a], start[b], end[a], end[b], ca, cb)
        if math.hypot(na - ca, nb - cb) > 2.0 * err:   # nearly a full circle: no circle is close
            raise BlockError("E-ARC-RADIUS", f"arc end point is {err:.3f} mm off the circle through the start "
                             f"point (radius {r0:.3f} mm), and start and end are too close for a circle "
                             "through both near the programmed centre (LinuxCNC would run a spiral)", word)
        ca, cb = na, nb
    c = [0.0, 0.0, 0.0]
    c[a], c[b], c[n] = ca, cb, start[n]
    return tuple(c)


def _onto_bisector(sa: float, sb: float, ea: float, eb: float, ca: float, cb: float) -> tuple[float, float]:
    """The point of the perpendicular bisector of start-end nearest to (ca, cb)."""
    ma, mb = (sa + ea) / 2.0, (sb + eb) / 2.0
    da, db = eb - sb, -(ea - sa)          # along the bisector
    norm2 = da * da + db * db
    if norm2 == 0.0:
        return ca, cb
    t = ((ca - ma) * da + (cb - mb) * db) / norm2
    return ma + t * da, mb + t * db


def center_from_radius(start, end, plane: str, radius_mm: float, ccw: bool, word: int | None,
                       unit_mm: float = 1.0):
    """Centre of a radius-format arc; negative radius picks the longer arc (RS274NGC)."""
    a, b, n = PLANE_AXES[plane]
    da, db = end[a] - start[a], end[b] - start[b]
    chord = math.hypot(da, db)
    r = abs(radius_mm)
    if chord < 1e-9:
        raise BlockError("E-ARC-R-FULL", "radius-format arc ends where it starts; program a full "
                         "circle with I/J/K", word)
    half = chord / 2.0
    if half > r:
        if half - r > radius_tolerance_mm(r, unit_mm):
            raise BlockError("E-ARC-R-SMALL", f"arc radius {r:.4f} mm is smaller than half the "
                             f"distance to the end point ({half:.4f} mm)", word)
        half = r
    # the centre lies right of the chord for a short clockwise arc, left for a short CCW one
    left = ccw == (radius_mm > 0)
    h = math.sqrt(max(r * r - half * half, 0.0))
    ua, ub = -db / chord, da / chord            # unit normal, left of start -> end
    sign = 1.0 if left else -1.0
    c = [0.0, 0.0, 0.0]
    c[a] = start[a] + da / 2.0 + sign * h * ua
    c[b] = start[b] + db / 2.0 + sign * h * ub
    c[n] = start[n]
    return tuple(c)


def make_arc(line: int, start, end, plane: str, ccw: bool, feed_mm_s: float, path: PathControl, *,
             center_ab: tuple[float, float] | None = None, radius_mm: float | None = None,
             turns: int = 0, word: int | None = None, unit_mm: float = 1.0) -> Arc:
    """The Arc of a G2/G3 block; unit_mm is 25.4 in G20 (it sets the absolute tolerance)."""
    if radius_mm is not None:
        center = center_from_radius(start, end, plane, radius_mm, ccw, word, unit_mm)
    else:
        center = center_from_offsets(start, end, plane, center_ab, word, unit_mm)
    return Arc(line, tuple(start), tuple(end), center, plane, ccw, feed_mm_s, turns, path)
