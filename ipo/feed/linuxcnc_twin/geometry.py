"""The three path shapes of LinuxCNC 2.9's planner: lines, circles (with spiral and helix) and
the spherical blend arcs it puts into corners.

Ported from posemath (src/libnml/posemath/_posemath.c: pmCartLineInit/Point/Stretch,
pmCircleInit/Point/Stretch), tc.c (pmCircleTangentVector), blendmath.c (the spiral arc-length
fit, pmCircleEffectiveMinRadius, pmCircleActualMaxVel) and spherical_arc.c. A circle is walked
by arc length through the quadratic fit of arc length against angle, as LinuxCNC does.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ipo.feed.linuxcnc_twin import vec as v
from ipo.feed.linuxcnc_twin.vec import CART_FUZZ, DOUBLE_FUZZ, Vec

BLEND_ACC_RATIO_TANGENTIAL = 0.5
BLEND_ACC_RATIO_NORMAL = math.sqrt(1.0 - BLEND_ACC_RATIO_TANGENTIAL ** 2)
CIRCLE_FUZZ = 1e-9
ARC_MIN_RADIUS = 1e-12
ARC_MIN_ANGLE = 1e-6
ANGLE_EPSILON = 1e-6


class GeometryError(ValueError):
    """A shape LinuxCNC's planner refuses to build (it then falls back or stops)."""


@dataclass(slots=True)
class Line:
    start: Vec
    end: Vec
    uvec: Vec
    tmag: float
    tmag_zero: bool

    @classmethod
    def between(cls, start: Vec, end: Vec) -> "Line":
        d = v.sub(end, start)
        if v.abs_max(d) < CART_FUZZ:
            return cls(start, end, (1.0, 0.0, 0.0), v.mag(d), True)
        return cls(start, end, v.unit(d), v.mag(d), False)

    def point(self, length: float) -> Vec:
        return self.end if self.tmag_zero else v.add(self.start, v.scale(self.uvec, length))

    def stretched(self, new_len: float, from_end: bool) -> "Line":
        """The line cut to new_len, keeping its end (from_end) or its start."""
        if self.tmag_zero or new_len <= DOUBLE_FUZZ:
            raise GeometryError("cannot stretch a zero or to zero length line")
        if from_end:
            return Line(v.add(self.end, v.scale(self.uvec, -new_len)), self.end, self.uvec, new_len, False)
        return Line(self.start, v.add(self.start, v.scale(self.uvec, new_len)), self.uvec, new_len, False)


@dataclass(slots=True)
class Circle:
    center: Vec
    normal: Vec
    rtan: Vec
    rperp: Vec
    rhelix: Vec
    radius: float
    angle: float
    spiral: float
    # quadratic fit of planar arc length s(angle) = b0 angle^2 + b1 angle (blendmath.c)
    b0: float = 0.0
    b1: float = 0.0
    planar_length: float = 0.0
    spiral_in: bool = False

    @classmethod
    def init(cls, start: Vec, end: Vec, center: Vec, normal: Vec, turn: int) -> "Circle":
        """pmCircleInit: start, end, centre and normal of a G2/G3 as the canon layer sends them."""
        off = v.sub(start, center)
        nn = v.dot(normal, normal)
        if nn == 0.0:
            raise GeometryError("zero normal")
        center = v.add(center, v.scale(normal, v.dot(off, normal) / nn))
        n = v.unit(normal)
        if turn < 0:
            turn = -1 - turn
            n = v.scale(n, -1.0)
        radius = v.mag(v.sub(start, center))
        rtan = v.sub(start, center)
        rperp = v.cross(n, rtan)
        rh = v.sub(end, center)
        rend = v.plane_proj(rh, n)
        spiral = v.mag(rend) - radius
        rhelix = v.sub(rh, rend)
        rend = v.scale(v.unit(rend), radius)
        if v.mag(rend) == 0.0:
            rend = v.add(rend, v.scale(n, DOUBLE_FUZZ))
        c = v.dot(rtan, rend) / (radius * radius)
        angle = 0.0 if c > 1.0 else (math.pi if c < -1.0 else math.acos(c))
        if v.dot(v.cross(rtan, rend), n) < DOUBLE_FUZZ:
            angle = 2 * math.pi - angle
        if v.mag(v.sub(v.plane_proj(start, normal), v.plane_proj(end, normal))) < CART_FUZZ:
            angle = 2 * math.pi
        if turn > 0:
            angle += turn * 2.0 * math.pi
        if angle == 0:
            angle += CIRCLE_FUZZ / 2
        circ = cls(center, n, rtan, rperp, rhelix, radius, angle, spiral)
        circ.fit()
        return circ

    def fit(self) -> None:
        """findSpiralArcLengthFit: slopes of s(angle) matched at both ends."""
        coef = self.spiral / self.angle
        r0 = self.radius
        self.spiral_in = self.spiral < 0
        if self.spiral_in:
            coef, r0 = -coef, r0 + self.spiral
        slope0 = math.hypot(r0, coef)
        slope1 = math.hypot(r0 + coef * self.angle, coef)
        self.b0 = (slope1 - slope0) / (2.0 * self.angle)
        self.b1 = slope0
        self.planar_length = self.b0 * self.angle ** 2 + self.b1 * self.angle

    @property
    def length(self) -> float:
        return math.sqrt(self.planar_length ** 2 + v.mag_sq(self.rhelix))

    def point(self, angle: float) -> Vec:
        p = v.add(v.scale(self.rtan, math.cos(angle)), v.scale(self.rperp, math.sin(angle)))
        s = angle / self.angle
        p = v.add(p, v.scale(v.unit(p), s * self.spiral))
        return v.add(self.center, v.add(p, v.scale(self.rhelix, s)))

    def tangent(self, angle: float) -> Vec:
        """pmCircleTangentVector: unit tangent (plane, helix and spiral parts)."""
        r = v.sub(self.point(angle), self.center)
        u = v.cross(self.normal, r)
        u = v.add(u, v.scale(self.rhelix, 1.0 / self.angle))
        u = v.add(u, v.scale(v.unit(r), self.spiral / self.angle))
        return v.unit(u)

    def stretched(self, new_angle: float, from_end: bool) -> "Circle":
        """pmCircleStretch: the circle cut to new_angle, keeping its end or its start."""
        if new_angle <= DOUBLE_FUZZ or v.mag_sq(self.rhelix) > 1e-6:
            raise GeometryError("cannot stretch a helix or to zero angle")
        out = Circle(self.center, self.normal, self.rtan, self.rperp, self.rhelix, self.radius, new_angle,
                     self.spiral * (new_angle / self.angle))
        if from_end:
            rtan = v.sub(self.point(self.angle - new_angle), self.center)
            out.rtan, out.rperp, out.radius = rtan, v.cross(self.normal, rtan), v.mag(rtan)
        out.fit()
        return out

    def effective_min_radius(self) -> float:
        """pmCircleEffectiveMinRadius: radius of curvature of the spiral and helix."""
        dr = self.spiral / self.angle
        h2 = v.mag_sq(self.rhelix)
        n_inner = dr * dr + self.radius * self.radius
        r_spiral = math.sqrt(n_inner ** 3) / (n_inner + dr * dr)
        return h2 / r_spiral + r_spiral

    def actual_max_vel(self, v_max: float, a_max: float) -> tuple[float, float]:
        """pmCircleActualMaxVel: (max speed, tangential share of the acceleration)."""
        a_n_cut = BLEND_ACC_RATIO_NORMAL * a_max
        r = self.effective_min_radius()
        a_n_vmax = v_max * v_max / max(r, DOUBLE_FUZZ)
        if a_n_vmax > a_n_cut:
            return math.sqrt(a_n_cut * r), BLEND_ACC_RATIO_TANGENTIAL
        return v_max, math.sqrt(1.0 - (a_n_vmax / a_max) ** 2)


@dataclass(slots=True)
class SphericalArc:
    """A blend arc (spherical_arc.c); with line_length > 0 it first runs the consumed line."""

    start: Vec
    end: Vec
    center: Vec
    rstart: Vec
    rend: Vec
    radius: float
    angle: float
    spiral: float
    utan: Vec
    binormal: Vec
    line_length: float

    @classmethod
    def from_points(cls, start: Vec, end: Vec, center: Vec, utan: Vec, binormal: Vec,
                    line_length: float) -> "SphericalArc":
        rs, re = v.sub(start, center), v.sub(end, center)
        r0, r1 = v.mag(rs), v.mag(re)
        if r0 < ARC_MIN_RADIUS or r1 < ARC_MIN_RADIUS:
            raise GeometryError("blend arc radius too small")
        c = v.dot(v.scale(rs, 1.0 / r0), v.scale(re, 1.0 / r1))
        angle = math.acos(max(-1.0, min(1.0, c)))
        if angle < ARC_MIN_ANGLE:
            raise GeometryError("blend arc angle too small")
        return cls(start, end, center, rs, re, r0, angle, r1 - r0, utan, binormal, line_length)

    @property
    def length(self) -> float:
        return self.radius * self.angle + self.line_length

    def tangent(self, at_end: bool) -> Vec:
        r = self.rend if at_end else self.rstart
        t = v.cross(self.binormal, r)
        return v.unit(v.add(v.scale(v.unit(r), self.spiral / self.angle), t))
