"""LinuxCNC 2.9's trajectory planner queue (tp.c): segments in, blended and optimized.

`TrajectoryPlanner.add_line` / `add_circle` do what tpAddLine / tpAddCircle do when task sends
a move: build the segment, check the joint with the segment before it (tpSetupTangent: tangent,
a kink, or a sharp corner that stops), put a blend arc into a G64 corner when it is faster than
a parabolic blend or a tangent kink (tpHandleBlendArc, tpChooseBestBlend), fix the length of
the segment before (tcFinalizeLength) and run the backward "rising tide" pass over the last
ARC_BLEND_OPTIMIZATION_DEPTH segments (tpRunOptimization). The run cycle takes segments from
the front once no later segment can change them (`ready`).
"""
from __future__ import annotations

import math

from ipo.feed.linuxcnc_twin import blendmath as bm
from ipo.feed.linuxcnc_twin import vec as v
from ipo.feed.linuxcnc_twin.geometry import Circle, GeometryError, Line, SphericalArc
from ipo.feed.linuxcnc_twin.segments import (TC_CIRCULAR, TC_LINEAR, TERM_EXACT, TERM_PARABOLIC, TERM_STOP,
                                             TERM_TANGENT, TRAVERSE, VMAX_SAMPLE, Tc, arc_segment,
                                             end_accel_unit, end_tangent, endpoint, finalize, find_v_peak,
                                             max_target_vel, remove_kink, set_circle, set_kink, set_line,
                                             set_term_cond, start_accel_unit, start_tangent, tangential_max_accel,
                                             clamp_by_length)
from ipo.linuxcnc_ini import LinuxcncSettings
from ipo.feed.linuxcnc_twin.vec import Vec

POS_EPSILON = 1e-12
MIN_SEGMENT_CYCLES = 1.02  # TP_MIN_SEGMENT_CYCLES
OPTIMIZATION_CUTOFF = 4  # TP_OPTIMIZATION_CUTOFF: peaks before the pass stops
SHARP_CORNER_EPSILON = (math.pi * 2.0 / 180.0) ** 2
MIN_ARC_ANGLE = 1e-3
NO_BLEND, PARABOLIC_BLEND, TANGENT_BLEND, ARC_BLEND = -1, 0, 1, 2


def triangle_vel(tc: Tc) -> float:
    """tpCalculateTriangleVel: the peak of a triangle over the segment (half of it if a blend
    may still take the rest)."""
    return find_v_peak(tangential_max_accel(tc), tc.target if tc.finalized else tc.target / 2.0)


def blend_velocity(tc: Tc, nxt: Tc, vt_this: float, vt_next: float) -> tuple[float, float, float]:
    """tpComputeBlendVelocity: speeds of a parabolic blend (this, next, net along the blend)."""
    acc_this, acc_next = tangential_max_accel(tc), tangential_max_accel(nxt)
    v_this = min(triangle_vel(tc), vt_this)
    v_next = min(triangle_vel(nxt), vt_next)
    t_blend = min(min(tc.target / v_this, nxt.target / v_next), max(v_this / acc_this, v_next / acc_next))
    b_this, b_next = min(v_this, t_blend * acc_this), min(v_next, t_blend * acc_next)
    u1, u2 = end_accel_unit(tc), start_accel_unit(nxt)
    theta = bm.intersection_angle(u1, u2)
    if tc.tolerance > 0 and math.cos(theta) > math.cos(math.pi / 2.0 - MIN_ARC_ANGLE):
        tblend = 2.0 * math.sqrt(acc_this * tc.tolerance / math.cos(theta))
        b_this, b_next = min(b_this, tblend), min(b_next, tblend)
    return b_this, b_next, math.sin(theta) * (b_this + b_next) / 2.0


class TrajectoryPlanner:
    """The queue of segments not yet handed to the run cycle (TP_STRUCT's queue)."""

    def __init__(self, s: LinuxcncSettings):
        self.s = s
        self.T = s.servo_period_s
        self.acc_bound: Vec = tuple(s.axis_accel_mm_s2)
        self.vel_bound: Vec = tuple(s.axis_velocity_mm_s)
        self.queue: list[Tc] = []
        self.term_cond = TERM_PARABOLIC
        self.tolerance = 0.0
        self.goal: Vec = (0.0, 0.0, 0.0)

    def max_target_vel(self, tc: Tc) -> float:
        """tpGetMaxTargetVel: at the highest feed override, within [TRAJ]MAX_LINEAR_VELOCITY."""
        return min(max_target_vel(tc, self.s.max_feed_override), self.s.max_linear_velocity_mm_s)

    # ---- adding segments -------------------------------------------------------------
    def _new(self, kind: int, canon: int, line_no: int, shape, target: float, vel: float, ini_maxvel: float,
             acc: float) -> Tc:
        return Tc(kind, canon, line_no, shape, target, reqvel=vel, maxvel=ini_maxvel, maxaccel=acc,
                  term_cond=self.term_cond, tolerance=self.tolerance, cycle_time=self.T)

    def add_line(self, end: Vec, canon: int, vel: float, ini_maxvel: float, acc: float, line_no: int) -> bool:
        """tpAddLine; False for a segment too short to queue."""
        line = Line.between(self.goal, end)
        target = 0.0 if line.tmag_zero else line.tmag
        if target < POS_EPSILON:
            return False
        self._append(self._new(TC_LINEAR, canon, line_no, line, target, vel, ini_maxvel, acc))
        return True

    def add_circle(self, end: Vec, center: Vec, normal: Vec, turn: int, canon: int, vel: float, ini_maxvel: float,
                   acc: float, line_no: int) -> bool:
        """tpAddCircle."""
        circ = Circle.init(self.goal, end, center, normal, turn)
        if circ.length < POS_EPSILON:
            return False
        self._append(self._new(TC_CIRCULAR, canon, line_no, circ, circ.length, vel, ini_maxvel, acc))
        return True

    def _append(self, tc: Tc) -> None:
        # 1. the speed the period allows over the whole (untrimmed) segment
        clamp_by_length(tc)
        prev = self.queue[-1] if self.queue else None
        # 2. no blending between a rapid and a feed move (handleModeChange)
        if prev is not None and (prev.canon == TRAVERSE) != (tc.canon == TRAVERSE):
            set_term_cond(prev, tc, TERM_STOP)
        # 3. the joint with the segment before: tangent, a kink, a blend arc or a stop
        if prev is not None and self.s.arc_blend_enable:
            self._handle_blend_arc(prev, tc)
        # 4. the segment before keeps its length from now on (a blend arc is final already);
        #    then the backward pass
        finalize(prev)
        self.queue.append(tc)
        self.goal = endpoint(tc)
        self._optimize()

    # ---- joints ----------------------------------------------------------------------
    def _setup_tangent(self, prev: Tc, tc: Tc) -> str:
        """tpSetupTangent: "ok" (tangent within the kink ratio), "fail" (no blend), "more"."""
        if self.s.optimization_depth < 2 or prev.term_cond == TERM_STOP:
            return "fail"
        prev_tan, this_tan = end_tangent(prev), start_tangent(tc)
        if v.anti_parallel(prev_tan, this_tan, SHARP_CORNER_EPSILON):
            set_term_cond(prev, tc, TERM_STOP)
            return "fail"
        v_max = min(max_target_vel(prev, self.s.max_feed_override), max_target_vel(tc, self.s.max_feed_override))
        # the worst case: stop on one segment and reach full speed on the next within a period
        a_inst = v_max / self.T + tc.maxaccel
        diff = v.sub(v.scale(this_tan, a_inst), v.scale(prev_tan, a_inst))
        scale = max(bm.accel_scale(diff, self.acc_bound))
        if prev.kind == TC_CIRCULAR or tc.kind == TC_CIRCULAR:
            scale /= 0.5
        ratio = self.s.tangent_kink_ratio
        if scale < ratio:
            set_term_cond(prev, tc, TERM_TANGENT)
            set_kink(prev, tc, v_max, scale)
            return "ok"
        set_kink(prev, tc, v_max * ratio / scale, ratio)
        return "more"

    def _handle_blend_arc(self, prev: Tc, tc: Tc) -> None:
        """tpHandleBlendArc."""
        if self._setup_tangent(prev, tc) != "more":
            return
        blend = None
        if prev.term_cond == TERM_PARABOLIC:
            try:
                blend = self._create_blend(prev, tc)
            except GeometryError:
                blend = None
        if blend:
            self.queue.append(blend)
        else:  # tp.c asks once more, without the arc, also when the arc lost
            self._choose_best_blend(prev, tc, None)

    def _choose_best_blend(self, prev: Tc, tc: Tc, blend: Tc | None) -> int:
        """tpChooseBestBlend: the fastest of a parabolic blend (counted at half, it slows the
        segments either side), a tangent kink and the blend arc."""
        if prev.term_cond in (TERM_EXACT, TERM_STOP):
            return NO_BLEND
        perf = [self._parabolic_performance(prev, tc) / 2.0, prev.kink_vel, blend.maxvel if blend else 0.0]
        best = max(range(3), key=lambda i: (perf[i], -i))
        if best == PARABOLIC_BLEND:
            remove_kink(prev, tc)
            set_term_cond(prev, tc, TERM_PARABOLIC)
        elif best == TANGENT_BLEND:
            set_term_cond(prev, tc, TERM_TANGENT)
        else:
            remove_kink(prev, tc)
        return best

    def _parabolic_performance(self, prev: Tc, tc: Tc) -> float:
        return blend_velocity(prev, tc, self.max_target_vel(prev), self.max_target_vel(tc))[2]

    def _create_blend(self, prev: Tc, tc: Tc):
        """tpCreate{LineLine,LineArc,ArcLine,ArcArc}Blend: the blend arc segment, None when
        there is none (a failed check), False when a parabolic or tangent joint won."""
        if prev.finalized or tc.finalized:
            return None
        if prev.kind == TC_CIRCULAR and tc.kind == TC_CIRCULAR and not v.colinear(prev.shape.normal,
                                                                                  tc.shape.normal):
            return None
        b = bm.init_blend(prev, tc, self.acc_bound, self.vel_bound, self.s.max_feed_override)
        for t in (prev, tc):
            if t.kind == TC_CIRCULAR and not v.colinear(b.binormal, t.shape.normal):
                return None
        bm.compute_parameters(b)
        bm.find_points(b)
        if prev.kind == TC_LINEAR and tc.kind == TC_LINEAR:
            return self._finish_line_line(prev, tc, b)
        bm.post_process(b, prev, tc)
        if (tc.kind == TC_CIRCULAR and b.trim2 > b.phi2_max) or (prev.kind == TC_CIRCULAR and b.trim1 > b.phi1_max):
            return None
        bm.check_consume(b, prev, self.s.gap_cycles, not prev.blend_prev)
        first = (prev.shape.stretched(prev.shape.tmag - b.trim1, False) if prev.kind == TC_LINEAR
                 else prev.shape.stretched(prev.shape.angle - b.trim1, False))
        second = (tc.shape.stretched(tc.target - b.trim2, True) if tc.kind == TC_LINEAR
                  else tc.shape.stretched(tc.shape.angle - b.trim2, True))
        start = first.end if prev.kind == TC_LINEAR else first.point(first.angle)
        end = second.start if tc.kind == TC_LINEAR else second.point(0.0)
        arc = SphericalArc.from_points(start, end, b.arc_center, b.u_tan1, b.binormal, b.line_length)
        blend = arc_segment(prev, arc, b.v_req, b.v_plan, b.a_max, tc.line_no)
        if prev.kind == TC_CIRCULAR and not self._tangent_ok(first, arc, b, False):
            return None
        if tc.kind == TC_CIRCULAR and not self._tangent_ok(second, arc, b, True):
            return None
        if self._choose_best_blend(prev, tc, blend) != ARC_BLEND:
            return False
        if b.consume:
            self.queue.pop()
        else:
            (set_line if prev.kind == TC_LINEAR else set_circle)(prev, first)
        (set_line if tc.kind == TC_LINEAR else set_circle)(tc, second)
        set_term_cond(prev, tc, TERM_TANGENT)
        return blend

    def _finish_line_line(self, prev: Tc, tc: Tc, b: bm.Blend):
        bm.check_consume(b, prev, self.s.gap_cycles, not prev.blend_prev)
        arc = SphericalArc.from_points(b.arc_start, b.arc_end, b.arc_center, b.u_tan1, b.binormal, b.line_length)
        blend = arc_segment(prev, arc, b.v_req, b.v_plan, b.a_max, tc.line_no)
        if self._choose_best_blend(prev, tc, blend) != ARC_BLEND:
            return False
        # tcConnectBlendArc: the lines now end and start where the arc does
        if b.consume:
            self.queue.pop()
        else:
            set_line(prev, Line.between(prev.shape.start, b.arc_start))
            set_term_cond(prev, tc, TERM_TANGENT)
        set_line(tc, Line.between(b.arc_end, tc.shape.end))
        tc.blend_prev = False
        return blend

    def _tangent_ok(self, circ: Circle, arc: SphericalArc, b: bm.Blend, at_end: bool) -> bool:
        """checkTangentAngle: the blend arc meets the circle within one period's kink."""
        u_arc = v.unit(arc.tangent(at_end))
        u_circ = circ.tangent(0.0) if at_end else circ.tangent(circ.angle)
        angle = math.acos(max(-1.0, min(1.0, v.dot(u_circ, u_arc))))
        return angle <= bm.max_tangent_angle(b.v_plan, b.a_max, self.T)

    # ---- the backward pass -----------------------------------------------------------
    def _initial_vel(self, tc: Tc) -> float:
        """tpCalculateOptimizationInitialVel: a last segment may lose half of itself to a blend."""
        return min(find_v_peak(tangential_max_accel(tc), tc.target), self.max_target_vel(tc))

    def _optimize(self) -> None:
        """tpRunOptimization: from the back, the highest final speed each segment may keep."""
        q = self.queue
        n = len(q)
        hit_peaks, hit_non_tangent = 0, False
        for x in range(1, self.s.optimization_depth + 2):
            ind = n - x
            if ind - 1 < 0:
                return
            tc, prev1 = q[ind], q[ind - 1]
            if prev1.term_cond != TERM_TANGENT:
                if hit_non_tangent:
                    return
                hit_non_tangent = True
                continue
            if tc.atspeed:
                tc.finalvel = 0.0
            if not tc.finalized:
                prev1.finalvel = min(prev1.maxvel, self._initial_vel(tc))
                if prev1.kink_vel >= 0:
                    prev1.finalvel = min(prev1.finalvel, prev1.kink_vel)
                tc.finalvel = 0.0
            else:
                self._optimal_velocity(tc, prev1)
            if tc.optimization_state:
                hit_peaks += 1
            if hit_peaks > OPTIMIZATION_CUTOFF:
                return

    def _optimal_velocity(self, tc: Tc, prev1: Tc) -> None:
        """tpComputeOptimalVelocity."""
        vs_back = math.sqrt(tc.finalvel * tc.finalvel + 2.0 * tangential_max_accel(tc) * tc.target)
        vf_limit = prev1.maxvel
        if prev1.kink_vel >= 0 and prev1.term_cond == TERM_TANGENT and prev1.kink_vel < vf_limit:
            vf_limit = prev1.kink_vel
        if tc.maxvel < vf_limit:
            vf_limit = tc.maxvel
        if vs_back >= vf_limit:
            vs_back = vf_limit
            prev1.optimization_state = 1
        prev1.finalvel = vs_back
        sample = tc.target / (self.T * MIN_SEGMENT_CYCLES)
        if sample < tc.maxvel:
            tc.maxvel, tc.vmax_reason = sample, VMAX_SAMPLE

    # ---- handing segments to the run cycle -------------------------------------------
    def ready(self) -> int:
        """How many segments at the front no later add can change any more."""
        return max(0, len(self.queue) - (self.s.optimization_depth + 3))

    def take(self, n: int) -> list[Tc]:
        out, self.queue[:n] = self.queue[:n], []
        return out
