"""The blend arcs LinuxCNC 2.9 puts into G64 corners (blendmath.c), as plain functions.

For a corner between two segments (line or circle each) it finds the plane of the corner,
the largest arc within the tolerance and within half of each segment that the normal share of
the acceleration allows at the requested speed, and the trims of both segments. Every step
follows blendmath.c: blendInit3From*, blendParamKinematics, blendComputeParameters,
blendFindPoints3, the line/arc post-processing, blendCheckConsume.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ipo.feed.linuxcnc_twin import vec as v
from ipo.feed.linuxcnc_twin.geometry import BLEND_ACC_RATIO_NORMAL, Circle, GeometryError
from ipo.feed.linuxcnc_twin.segments import (TC_CIRCULAR, TC_LINEAR, Tc, blend_tolerance, end_tangent,
                                             intersection_point, max_target_vel, start_tangent)
from ipo.feed.linuxcnc_twin.vec import Vec

POS_EPSILON = 1e-12
MIN_ARC_LENGTH = 1e-6
ANGLE_EPSILON = 1e-6
BLEND_DIST_FRACTION = 0.5
BLEND_KINK_FACTOR = 0.25


@dataclass(slots=True)
class Blend:
    """BlendGeom3 and BlendParameters in one: the corner and the arc chosen for it."""

    u_tan1: Vec
    u_tan2: Vec
    P: Vec
    theta_tan: float
    binormal: Vec = (0.0, 0.0, 1.0)
    normal: Vec = (0.0, 0.0, 0.0)
    u1: Vec = (0.0, 0.0, 0.0)
    u2: Vec = (0.0, 0.0, 0.0)
    center1: Vec = (0.0, 0.0, 0.0)
    center2: Vec = (0.0, 0.0, 0.0)
    radius1: float = 0.0
    radius2: float = 0.0
    convex1: bool = False
    convex2: bool = False
    phi1_max: float = 0.0
    phi2_max: float = 0.0
    theta: float = 0.0
    phi: float = 0.0
    L1: float = 0.0
    L2: float = 0.0
    tolerance: float = 0.0
    a_max: float = 0.0
    a_n_max: float = 0.0
    v_req: float = 0.0
    v_goal: float = 0.0
    v_plan: float = 0.0
    R_plan: float = 0.0
    d_plan: float = 0.0
    consume: bool = False
    line_length: float = 0.0
    arc_start: Vec = (0.0, 0.0, 0.0)
    arc_end: Vec = (0.0, 0.0, 0.0)
    arc_center: Vec = (0.0, 0.0, 0.0)
    trim1: float = 0.0
    trim2: float = 0.0
    extra: dict = field(default_factory=dict)


def intersection_angle(u1: Vec, u2: Vec) -> float:
    """findIntersectionAngle: half the supplement of the angle between the directions."""
    return math.acos(-max(-1.0, min(1.0, v.dot(u1, u2)))) / 2.0


def inscribed_diameter(normal: Vec, bounds: Vec) -> float:
    """calculateInscribedDiameter: the axis limits' box cut by the corner's plane (axis i's
    unit vector projected on the plane, its own component kept above 1e-12, as the C does)."""
    if abs(1.0 - v.mag_sq(normal)) > math.sqrt(POS_EPSILON):
        raise GeometryError("corner normal not a unit vector")
    nx, ny, nz = normal
    out, low = 0.0, math.inf
    for i, b in enumerate(bounds):
        if b == 0:
            continue
        ni = normal[i]
        c = [nx * -ni, ny * -ni, nz * -ni]
        c[i] = max(abs(c[i] + 1.0), POS_EPSILON)
        extent = b / math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
        out, low = max(out, extent), min(low, extent)
    return low if low < math.inf else out


def accel_scale(acc: Vec, bounds: Vec) -> Vec:
    """findAccelScale: |acc| per axis as a share of the axis limits."""
    return tuple(abs(acc[i] / bounds[i]) if bounds[i] != 0 else 0.0 for i in range(3))


def _geom(prev: Tc, tc: Tc) -> Blend:
    """blendGeom3Init: tangents at the corner, its point and its angle, normal and binormal."""
    u1, u2 = end_tangent(prev), start_tangent(tc)
    theta = intersection_angle(u1, u2)
    if math.pi / 2.0 - theta < ANGLE_EPSILON or theta < ANGLE_EPSILON:
        raise GeometryError("corner too shallow or a reversal")
    b = Blend(u1, u2, intersection_point(prev, tc), theta, u1=u1, u2=u2)
    _normals(b)
    return b


def _normals(b: Blend) -> None:
    b.binormal = v.unit(v.cross(b.u_tan1, b.u_tan2))
    b.normal = v.unit(v.sub(b.u_tan2, b.u_tan1))


def _kinematics(b: Blend, prev: Tc, tc: Tc, acc_bound: Vec, vel_bound: Vec, max_feed_scale: float) -> None:
    """blendParamKinematics: tolerance, the plane's accelerations and the speed to plan for."""
    b.phi = math.pi - b.theta * 2.0
    b.tolerance = blend_tolerance(prev, tc)
    b.a_max = inscribed_diameter(b.binormal, acc_bound)
    b.a_n_max = b.a_max * BLEND_ACC_RATIO_NORMAL
    b.v_req = max(max_target_vel(prev, 1.0), max_target_vel(tc, 1.0))
    b.v_goal = max(max_target_vel(prev, max_feed_scale), max_target_vel(tc, max_feed_scale))
    v_planar_max = inscribed_diameter(b.binormal, vel_bound)
    phi_eff = min(b.phi, math.pi * 0.49)
    v1 = min(prev.maxvel, tc.maxvel / math.cos(phi_eff))
    v2 = min(tc.maxvel, prev.maxvel / math.cos(phi_eff))
    area = v1 * v2 / 2.0 * math.sin(b.phi)
    base = v.mag(v.sub(v.scale(b.u2, v2), v.scale(b.u1, v1)))
    v_alt = 2.0 * area / base if (prev.kind == TC_LINEAR and tc.kind == TC_LINEAR) else 0.0
    b.v_goal = min(b.v_goal, max(v_alt, v_planar_max))


def _spiral_approx(c: Circle, P: Vec, u_tan: Vec) -> tuple[Vec, float]:
    """findSpiralApproximation: the centre and radius of the circle that fits the spiral at P."""
    center = v.add(c.center, v.scale(u_tan, c.spiral / c.angle))
    return center, v.mag(v.sub(P, center))


def _convex(center: Vec, P: Vec, u: Vec, reverse: bool) -> bool:
    """arcConvexTest."""
    return reverse != (v.dot(v.sub(P, center), u) < 0)


def _arc_side_first(b: Blend, prev: Tc) -> None:
    """The first segment is a circle: its fitted centre, convexity, angle it may give up."""
    c: Circle = prev.shape
    b.center1, b.radius1 = _spiral_approx(c, b.P, b.u_tan1)
    b.convex1 = _convex(b.center1, b.P, b.u_tan2, False)
    b.phi1_max = min(c.angle * 2.0 / 3.0, b.theta_tan if b.convex1 else math.pi / 2.0)
    if b.convex1:
        b.u1 = v.unit(v.sub(b.P, c.point(c.angle - b.phi1_max / 2.0)))
        b.theta = min(b.theta, b.theta_tan - b.phi1_max / 4.0)


def _arc_side_second(b: Blend, tc: Tc) -> None:
    c: Circle = tc.shape
    b.center2, b.radius2 = _spiral_approx(c, b.P, b.u_tan2)
    b.convex2 = _convex(b.center2, b.P, b.u_tan1, True)
    b.phi2_max = min(c.angle / 3.0, b.theta_tan if b.convex2 else math.pi / 2.0)
    if b.convex2:
        b.u2 = v.unit(v.sub(c.point(b.phi2_max / 2.0), b.P))
        b.theta = min(b.theta, b.theta_tan - b.phi2_max / 4.0)


def init_blend(prev: Tc, tc: Tc, acc_bound: Vec, vel_bound: Vec, max_feed_scale: float) -> Blend:
    """blendInit3FromLineLine / LineArc / ArcLine / ArcArc."""
    b = _geom(prev, tc)
    b.theta = b.theta_tan
    if prev.kind == TC_CIRCULAR:
        _arc_side_first(b, prev)
    if tc.kind == TC_CIRCULAR:
        _arc_side_second(b, tc)
    if prev.kind == TC_CIRCULAR and tc.kind == TC_CIRCULAR and b.theta < math.pi / 12.0:
        raise GeometryError("arc-arc corner too sharp")
    b.phi = math.pi - b.theta * 2.0
    if prev.kind == TC_LINEAR:
        b.L1 = min(prev.target, prev.nominal_length * BLEND_DIST_FRACTION)
    else:
        b.L1 = (math.sin(b.phi1_max / 4.0) if b.convex1 else b.phi1_max) * b.radius1
    if tc.kind == TC_LINEAR:
        b.L2 = tc.target * BLEND_DIST_FRACTION if prev.kind == TC_LINEAR else tc.nominal_length / 2.0
    else:
        b.L2 = (math.sin(b.phi2_max / 4.0) if b.convex2 else b.phi2_max) * b.radius2
    _kinematics(b, prev, tc, acc_bound, vel_bound, max_feed_scale)
    return b


def compute_parameters(b: Blend) -> None:
    """blendComputeParameters: radius, speed and extent of the blend arc."""
    h_tol = b.tolerance / (1.0 - math.sin(b.theta))
    d_tol = math.cos(b.theta) * h_tol
    d_geom = min(b.L1, b.L2, d_tol)
    R_geom = math.tan(b.theta) * d_geom
    b.v_plan = min(math.sqrt(b.a_n_max * R_geom), b.v_goal)
    a_parabolic = b.a_max * 0.5
    v_triangle = math.sqrt(2.0 * a_parabolic * d_geom)
    t_blend = min(v_triangle, b.v_plan) / a_parabolic
    R_blend = min(t_blend * b.v_plan / b.phi, R_geom)
    b.R_plan = max(b.v_plan ** 2 / b.a_n_max, R_blend)
    b.d_plan = b.R_plan / math.tan(b.theta)
    if b.R_plan < POS_EPSILON or b.R_plan * b.phi < MIN_ARC_LENGTH:
        raise GeometryError("blend arc too small")


def find_points(b: Blend) -> None:
    """blendFindPoints3: the arc's centre, start and end for two lines."""
    b.arc_center = v.add(b.P, v.scale(b.normal, b.R_plan / math.sin(b.theta)))
    b.arc_start = v.add(b.P, v.scale(b.u1, -b.d_plan))
    b.arc_end = v.add(b.P, v.scale(b.u2, b.d_plan))
    b.trim1 = b.trim2 = b.d_plan


def _line_circle_center(b: Blend, u_line: Vec, center: Vec, radius: float, convex: bool, sign: float) -> float:
    """The arc centre R_plan off the line and R_plan off the circle (blendLineArcPostProcess and
    blendArcLinePostProcess); returns the distance from P along the line."""
    d = (-b.R_plan if convex else b.R_plan) + radius
    n = v.unit(v.cross(b.binormal, u_line))
    r_pc = v.sub(center, b.P)
    c_u, c_n = v.dot(r_pc, u_line), v.dot(r_pc, n)
    B, C = 2.0 * c_u, c_u * c_u - d * d + (b.R_plan - c_n) ** 2
    disc = B * B - 4.0 * C
    if disc < 0:
        raise GeometryError("no blend arc touches both")
    root = math.sqrt(disc)
    d_l = min(abs((-B + root) / 2.0), abs((-B - root) / 2.0))
    r = v.add(v.scale(u_line, sign * d_l), v.scale(n, b.R_plan))
    b.arc_center = v.add(b.P, r)
    if v.mag(r) - b.R_plan > b.tolerance:
        raise GeometryError("blend arc off the tolerance")
    return d_l


def _trim_angle(P: Vec, arc_center: Vec, center: Vec) -> float:
    """findTrimAngle."""
    return math.acos(max(-1.0, min(1.0, v.dot(v.unit(v.sub(arc_center, center)), v.unit(v.sub(P, center))))))


def post_process(b: Blend, prev: Tc, tc: Tc) -> None:
    """Exact trims of circles (the lines' approximation made exact)."""
    if prev.kind == TC_LINEAR and tc.kind == TC_CIRCULAR:
        b.trim1 = _line_circle_center(b, b.u1, b.center2, b.radius2, b.convex2, -1.0)
        b.trim2 = _trim_angle(b.P, b.arc_center, b.center2)
    elif prev.kind == TC_CIRCULAR and tc.kind == TC_LINEAR:
        b.trim2 = _line_circle_center(b, b.u2, b.center1, b.radius1, b.convex1, 1.0)
        b.trim1 = _trim_angle(b.P, b.arc_center, b.center1)
    else:
        _arc_arc_center(b)
        b.trim1 = _trim_angle(b.P, b.arc_center, b.center1)
        b.trim2 = _trim_angle(b.P, b.arc_center, b.center2)


def _arc_arc_center(b: Blend) -> None:
    """blendArcArcPostProcess: the centre R_plan off both circles, on the corner's side."""
    d1 = (-b.R_plan if b.convex1 else b.R_plan) + b.radius1
    d2 = (-b.R_plan if b.convex2 else b.R_plan) + b.radius2
    r12 = v.sub(b.center2, b.center1)
    c2x = v.mag(r12)
    cx = (-d1 * d1 + d2 * d2 - c2x * c2x) / (-2.0 * c2x)
    cy_sq = d1 * d1 - cx * cx
    if c2x == 0.0 or cy_sq < 0.0:
        raise GeometryError("no blend arc touches both circles")
    cy = math.sqrt(cy_sq)
    uc = v.unit(r12)
    nc = v.cross(b.binormal, uc)
    if v.dot(b.normal, nc) < 0:
        nc = v.scale(nc, -1.0)
    nc = v.unit(nc)
    c_x, c_y = v.scale(uc, cx), v.scale(nc, cy)
    base = v.add(v.sub(b.center1, b.P), c_x)
    if v.mag(v.sub(base, c_y)) < v.mag(v.add(base, c_y)):
        c_y = v.scale(c_y, -1.0)
    b.arc_center = v.add(b.center1, v.add(c_x, c_y))
    if v.mag(v.sub(b.arc_center, b.P)) - b.R_plan > b.tolerance:
        raise GeometryError("blend arc off the tolerance")


def check_consume(b: Blend, prev: Tc, gap_cycles: int, can_consume: bool) -> None:
    """blendCheckConsume: a line left shorter than gap_cycles periods joins the arc."""
    b.consume, b.line_length = False, 0.0
    if prev.kind != TC_LINEAR:
        return
    rest = prev.target - b.trim1
    b.consume = rest / b.v_plan < gap_cycles * prev.cycle_time and can_consume
    if b.consume:
        b.line_length = rest


def max_tangent_angle(v_plan: float, a_limit: float, cycle_time: float) -> float:
    """findMaxTangentAngle: the kink one period at v_plan may turn within the margin."""
    dx = v_plan / cycle_time
    return BLEND_ACC_RATIO_NORMAL * BLEND_KINK_FACTOR * a_limit / dx if dx > 0.0 else ANGLE_EPSILON
