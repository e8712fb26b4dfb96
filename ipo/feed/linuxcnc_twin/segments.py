"""One planner segment of LinuxCNC 2.9 (TC_STRUCT) and the per-segment rules of tc.c.

A segment is a line, a circle or a spherical blend arc with the kinematic state the planner
keeps for it: requested and maximum speed, acceleration, the speed it must end with, its
terminal condition (stop, exact, parabolic blend, tangent), and the reductions an almost
tangent joint (a "kink") costs it. The per-period state (progress, speed, split cycles)
lives in the compiled run cycle (ipo.feed.linuxcnc_twin.cycle) once the segment is queued.
"""
from __future__ import annotations

import math

from ipo.feed.linuxcnc_twin import vec as v
from ipo.feed.linuxcnc_twin.geometry import BLEND_ACC_RATIO_TANGENTIAL, Circle, Line, SphericalArc
from ipo.feed.linuxcnc_twin.vec import Vec

# motion_type (tc_types.h)
TC_LINEAR, TC_CIRCULAR, TC_SPHERICAL = 1, 2, 4
# canon motion type (motion_types.h): traverse (G0), feed (G1), arc (G2/G3)
TRAVERSE, FEED, ARC = 1, 2, 3
# terminal conditions (tc_types.h)
TERM_STOP, TERM_EXACT, TERM_PARABOLIC, TERM_TANGENT = 0, 1, 2, 3
# what set a segment's maxvel below its requested speed (for the period's limit reason)
VMAX_AXIS, VMAX_CURVATURE, VMAX_SAMPLE = 0, 1, 2


class Tc:
    """TC_STRUCT: the fields the planner sets before a segment runs."""

    __slots__ = ("kind", "canon", "line_no", "shape", "target", "nominal_length", "reqvel", "maxvel",
                 "vmax_reason", "maxaccel", "acc_ratio_tan", "finalvel", "kink_vel", "kink_accel_reduce",
                 "kink_accel_reduce_prev", "term_cond", "tolerance", "blend_prev", "finalized",
                 "optimization_state", "atspeed", "progress", "cycle_time")

    def __init__(self, kind: int, canon: int, line_no: int, shape, target: float, *, reqvel: float,
                 maxvel: float, maxaccel: float, term_cond: int, tolerance: float, cycle_time: float):
        self.kind, self.canon, self.line_no, self.shape = kind, canon, line_no, shape
        self.target = self.nominal_length = target
        self.reqvel, self.maxvel, self.maxaccel = reqvel, maxvel, maxaccel
        self.vmax_reason = VMAX_AXIS
        self.acc_ratio_tan = BLEND_ACC_RATIO_TANGENTIAL
        self.finalvel = 0.0
        self.kink_vel, self.kink_accel_reduce, self.kink_accel_reduce_prev = -1.0, 0.0, 0.0
        self.term_cond, self.tolerance = term_cond, tolerance
        self.blend_prev = False
        self.finalized = False
        self.optimization_state = 0
        self.atspeed = False
        self.progress = 0.0  # the planner never sees a segment move: it plans ahead of the run
        self.cycle_time = cycle_time


def max_target_vel(tc: Tc, max_scale: float) -> float:
    """tcGetMaxTargetVel: the requested speed at the highest feed override, within maxvel."""
    return min(tc.reqvel * max_scale, tc.maxvel)


def overall_max_accel(tc: Tc) -> float:
    """tcGetOverallMaxAccel: kinks take their share; a parabolic blend halves it."""
    r1, r2 = tc.kink_accel_reduce, tc.kink_accel_reduce_prev
    scale = 1.0 - (r1 if r1 >= r2 else r2)
    if tc.blend_prev or tc.term_cond == TERM_PARABOLIC:
        scale *= 0.5
    return tc.maxaccel * scale


def tangential_max_accel(tc: Tc) -> float:
    """tcGetTangentialMaxAccel: on circles and blend arcs only acc_ratio_tan of it is tangential."""
    a = overall_max_accel(tc)
    return a if tc.kind == TC_LINEAR else a * tc.acc_ratio_tan


def set_term_cond(prev: Tc | None, tc: Tc | None, cond: int) -> None:
    """tcSetTermCond: the joint prev -> tc ends with cond (a parabolic blend marks tc too)."""
    if tc is not None:
        tc.blend_prev = cond == TERM_PARABOLIC
    if prev is not None:
        prev.term_cond = cond


def set_kink(prev: Tc, tc: Tc, kink_vel: float, reduction: float) -> None:
    prev.kink_vel = kink_vel
    prev.kink_accel_reduce = max(reduction, prev.kink_accel_reduce)
    tc.kink_accel_reduce_prev = max(reduction, tc.kink_accel_reduce_prev)


def remove_kink(prev: Tc, tc: Tc) -> None:
    prev.kink_vel, prev.kink_accel_reduce = -1.0, 0.0
    tc.kink_accel_reduce_prev = 0.0


def clamp_by_length(tc: Tc) -> None:
    """tcClampVelocityByLength: at most one segment per cycle (target / cycle time)."""
    cap = tc.target / tc.cycle_time
    if cap < tc.maxvel:
        tc.maxvel, tc.vmax_reason = cap, VMAX_SAMPLE


def finalize(tc: Tc | None) -> None:
    """tcFinalizeLength: the segment's length is fixed; circles get their true speed limits."""
    if tc is None or tc.finalized:
        return
    clamp_by_length(tc)
    if tc.kind == TC_CIRCULAR:
        vmax, ratio = tc.shape.actual_max_vel(tc.maxvel, overall_max_accel(tc))
        if vmax < tc.maxvel:
            tc.maxvel, tc.vmax_reason = vmax, VMAX_CURVATURE
        tc.acc_ratio_tan = ratio
    tc.finalized = True


def start_tangent(tc: Tc) -> Vec:
    if tc.kind == TC_LINEAR:
        return tc.shape.uvec
    return tc.shape.tangent(0.0)


def end_tangent(tc: Tc) -> Vec:
    if tc.kind == TC_LINEAR:
        return tc.shape.uvec
    return tc.shape.tangent(tc.shape.angle)


def start_accel_unit(tc: Tc) -> Vec | None:
    """tcGetStartAccelUnitVector: a circle's start leans toward its centre."""
    if tc.kind == TC_LINEAR:
        return tc.shape.uvec
    if tc.kind != TC_CIRCULAR:
        return None
    c: Circle = tc.shape
    p = c.point(0.0)
    tan = v.scale(v.unit(v.cross(c.normal, v.sub(p, c.center))), overall_max_accel(tc))
    perp = v.scale(v.unit(v.sub(c.center, p)), (0.5 * tc.reqvel) ** 2 / c.radius)
    return v.unit(v.add(tan, perp))


def end_accel_unit(tc: Tc) -> Vec | None:
    if tc.kind == TC_LINEAR:
        return tc.shape.uvec
    if tc.kind != TC_CIRCULAR:
        return None
    c: Circle = tc.shape
    return v.unit(v.cross(c.normal, v.sub(c.point(c.angle), c.center)))


def intersection_point(prev: Tc, tc: Tc) -> Vec:
    if tc.kind == TC_LINEAR:
        return tc.shape.start
    if prev.kind == TC_LINEAR:
        return prev.shape.end
    return tc.shape.point(0.0)


def endpoint(tc: Tc) -> Vec:
    s = tc.shape
    if tc.kind == TC_LINEAR or tc.kind == TC_SPHERICAL:
        return s.end
    return s.point(s.angle)


def set_line(tc: Tc, line: Line) -> None:
    tc.shape, tc.target = line, line.tmag


def set_circle(tc: Tc, circ: Circle) -> None:
    tc.shape, tc.target = circ, circ.length


def blend_tolerance(prev: Tc, tc: Tc) -> float:
    """tcFindBlendTolerance: no tolerance (G64 without P) means a quarter of the segments."""
    ratio = 0.25
    t1 = prev.tolerance or prev.nominal_length * ratio
    t2 = tc.tolerance or tc.nominal_length * ratio
    return min(min(t1, t2), prev.nominal_length * ratio, tc.nominal_length * ratio)


def arc_segment(prev: Tc, arc: SphericalArc, v_req: float, v_plan: float, a_max: float, line_no: int) -> Tc:
    """tpInitBlendArcFromPrev: a blend arc takes the previous segment's type and the line of
    the move it leads into (the id task gave the move being added)."""
    tc = Tc(TC_SPHERICAL, prev.canon, line_no, arc, arc.length, reqvel=v_req, maxvel=v_plan,
            maxaccel=a_max, term_cond=TERM_TANGENT, tolerance=prev.tolerance, cycle_time=prev.cycle_time)
    tc.vmax_reason = VMAX_CURVATURE
    finalize(tc)
    return tc


def find_v_peak(a_t_max: float, distance: float) -> float:
    return math.sqrt(a_t_max * distance)
