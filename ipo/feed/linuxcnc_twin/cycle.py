"""LinuxCNC 2.9's run cycle (tp.c tpRunCycle, tc.c), compiled: one call per servo period.

Each period the segment at the head of the queue is activated (a short tangent segment gets
a velocity ramp instead of a trapezoid: ARC_BLEND_RAMP_FREQ), then either finishes a split
cycle (it reached its end inside the last period: the next segment runs the rest of this
period from the speed it ended with) or runs a regular cycle: the trapezoid step
(tpCalculateTrapezoidalAccel: the highest speed from which the segment can still brake to
its final speed, in discrete time), the position update by trapezoidal integration, the end
check that schedules a split (tpCheckEndCondition) and, for a parabolic blend, the next
segment's own cycle while this one brakes. Positions are summed from displacements as
tp->currentPos is.
"""
from __future__ import annotations

from math import acos, cos, sin, sqrt
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_ACCEL, LIMIT_AXIS, LIMIT_CURVATURE, LIMIT_DWELL, LIMIT_PROGRAMMED, LIMIT_SEGMENT
from ipo.feed.linuxcnc_twin.columns import (ACC_T, ACCEL_MODE, ACTIVE, ANGLE, B0, B1, BLENDING_NEXT, BLENDVEL, C,
                                            CANON, CURVEL, CYCLE, FINALIZED, FINALVEL, IS_BLENDING, KIND, LINE,
                                            LINE_LEN, MAXVEL, ON_FINAL_DECEL, P0, PLEN, PROGRESS, RADIUS, REMOVE,
                                            REQVEL, RH, RP, RT, SANGLE, SPIRAL, SPIRAL_IN, SPLITTING, TARGET, TERM,
                                            TERMVEL, TMAG_ZERO, TOL, U, UAE, UAS, V_TRI, VEL_AT_BLEND, VMAX_REASON,
                                            P1, QUEUE_START)
from ipo.feed.linuxcnc_twin.segments import TC_LINEAR, TC_CIRCULAR, TERM_EXACT, TERM_PARABOLIC, TERM_STOP, \
    TERM_TANGENT, TRAVERSE, VMAX_CURVATURE, VMAX_SAMPLE

POS_EPSILON = 1e-12
VEL_EPSILON = 1e-8
TIME_EPSILON = 1e-12
MIN_ARC_ANGLE = 1e-3
STILL_MM = 1e-9  # below this a period's displacement is no motion
# params: T, feed scale (G1..G3), max feed scale ([DISPLAY]MAX_FEED_OVERRIDE), vLimit, ramp frequency
P_T, P_SCALE, P_MAXSCALE, P_VLIMIT, P_RAMP = 0, 1, 2, 3, 4


@njit(cache=True, error_model="numpy")
def _position(F, I, k, progress, out):
    """tcGetPos: the point at arc length `progress` of segment k."""
    kind = I[k, KIND]
    if kind == TC_LINEAR:
        if I[k, TMAG_ZERO]:
            for d in range(3):
                out[d] = F[k, P1 + d]
        else:
            for d in range(3):
                out[d] = F[k, P0 + d] + F[k, U + d] * progress
    elif kind == TC_CIRCULAR:
        h2 = F[k, RH] ** 2 + F[k, RH + 1] ** 2 + F[k, RH + 2] ** 2
        t = progress / sqrt(F[k, PLEN] ** 2 + h2)
        if I[k, SPIRAL_IN]:
            t = 1.0 - t
        s_in = t * F[k, PLEN]
        disc = F[k, B1] ** 2 + 4.0 * F[k, B0] * s_in
        ang = (-2.0 * s_in) / (-F[k, B1] - sqrt(max(disc, 0.0)))
        if I[k, SPIRAL_IN]:
            ang = F[k, ANGLE] - ang
        c, s = cos(ang), sin(ang)
        m = 0.0
        for d in range(3):
            out[d] = F[k, RT + d] * c + F[k, RP + d] * s
            m += out[d] * out[d]
        m = sqrt(m)
        sc = ang / F[k, ANGLE]
        for d in range(3):
            rad = out[d] / m if m > 0.0 else out[d]
            out[d] = F[k, C + d] + out[d] + rad * sc * F[k, SPIRAL] + F[k, RH + d] * sc
    else:
        net = progress - F[k, LINE_LEN]
        if net <= 0.0 and F[k, LINE_LEN] > 0:
            for d in range(3):
                out[d] = F[k, P0 + d] + F[k, U + d] * net
        else:
            a = net / F[k, RADIUS]
            s0 = sin(F[k, ANGLE] - a) / F[k, SANGLE]
            s1 = sin(a) / F[k, SANGLE]
            for d in range(3):
                out[d] = F[k, C + d] + F[k, RT + d] * s0 + F[k, RP + d] * s1


@njit(cache=True, error_model="numpy")
def _max_target_vel(F, I, k, p):
    scale = p[P_MAXSCALE]
    if I[k, IS_BLENDING]:
        scale = min(scale, 1.0)
    return min(min(F[k, REQVEL] * scale, F[k, MAXVEL]), p[P_VLIMIT])


@njit(cache=True, error_model="numpy")
def _feed_scale(F, I, k, p):
    s = 1.0 if I[k, CANON] == TRAVERSE else p[P_SCALE]
    if I[k, IS_BLENDING]:
        s = min(s, 1.0)
    return s


@njit(cache=True, error_model="numpy")
def _target_vel(F, I, k, p):
    """tpGetRealTargetVel."""
    if k < 0:
        return 0.0
    return min(F[k, REQVEL] * _feed_scale(F, I, k, p), _max_target_vel(F, I, k, p))


@njit(cache=True, error_model="numpy")
def _final_vel(F, I, k, nk, p):
    """tpGetRealFinalVel: only a tangent joint keeps speed."""
    if I[k, TERM] != TERM_TANGENT:
        return 0.0
    return min(F[k, FINALVEL], min(_target_vel(F, I, k, p), _target_vel(F, I, nk, p)))


@njit(cache=True, error_model="numpy")
def _trapezoid(F, I, k, nk, p):
    """tpCalculateTrapezoidalAccel: (acceleration, desired speed) of this period."""
    vt = _target_vel(F, I, k, p)
    vf = _final_vel(F, I, k, nk, p)
    dx = F[k, TARGET] - F[k, PROGRESS]
    a = F[k, ACC_T]
    dt = F[k, CYCLE]
    t3 = (a * dt * 0.5) ** 2
    disc = vf * vf + a * (2.0 * dx - F[k, CURVEL] * dt) + t3
    vmax_new = -a * dt * 0.5
    if disc > t3:
        vmax_new += sqrt(disc)
    newvel = min(max(vmax_new, -vt), vt)
    acc = (newvel - F[k, CURVEL]) / max(dt, TIME_EPSILON)
    return min(max(acc, -a), a), vmax_new


@njit(cache=True, error_model="numpy")
def _ramp(F, I, k, nk, p):
    """tpCalculateRampAccel: constant acceleration to the final speed; fails below 1e-8 mm/s."""
    dx = F[k, TARGET] - F[k, PROGRESS]
    if not I[k, BLENDING_NEXT]:
        F[k, VEL_AT_BLEND] = F[k, CURVEL]
    vf = _final_vel(F, I, k, nk, p)
    if vf < VEL_EPSILON:
        return False, 0.0, 0.0
    v_avg = (F[k, CURVEL] + vf) / 2.0
    dt = 1e-16
    if v_avg > VEL_EPSILON:
        dt = max(dx / v_avg, 1e-16)
    acc = (vf - F[k, CURVEL]) / dt
    a = F[k, ACC_T]
    return True, min(max(acc, -a), a), vf


@njit(cache=True, error_model="numpy")
def _set_split(F, I, k, split_time, v_f):
    I[k, SPLITTING] = 1
    F[k, CYCLE] = split_time
    F[k, TERMVEL] = v_f


@njit(cache=True, error_model="numpy")
def _check_end(F, I, k, nk, p):
    """tpCheckEndCondition: a segment less than one period from its end splits the next."""
    T = p[P_T]
    F[k, CYCLE] = T
    dx = F[k, TARGET] - F[k, PROGRESS]
    term = I[k, TERM]
    if dx <= POS_EPSILON:
        F[k, PROGRESS] = F[k, TARGET]
        _set_split(F, I, k, 0.0, F[k, CURVEL])
        if term == TERM_STOP or term == TERM_EXACT:
            I[k, REMOVE] = 1
        return
    if term == TERM_STOP or term == TERM_EXACT:
        return
    v0 = F[k, CURVEL]
    v_f = _final_vel(F, I, k, nk, p)
    v_avg = (v0 + v_f) / 2.0
    dt = TIME_EPSILON / 2.0
    if v_avg > VEL_EPSILON:
        dt = max(dt, dx / v_avg)
    elif dx > v_avg * T and dx > POS_EPSILON:
        return
    a_f = (v_f - v0) / dt
    a_max = F[k, ACC_T]
    if a_f > a_max or a_f < -a_max:
        a = a_max if a_f > 0 else -a_max
        disc = (v0 / a) ** 2 + 2.0 / a * dx
        if disc < 0:
            return
        if disc < TIME_EPSILON * TIME_EPSILON:
            dt = -v0 / a
        elif a > 0:
            dt = -v0 / a + sqrt(disc)
        else:
            dt = -v0 / a - sqrt(disc)
        v_f = v0 + dt * a
    if dt < TIME_EPSILON:
        F[k, PROGRESS] = F[k, TARGET]
        _set_split(F, I, k, 0.0, v_f)
    elif dt < T:
        _set_split(F, I, k, dt, v_f)


@njit(cache=True, error_model="numpy")
def _update_cycle(F, I, k, nk, p, pos, tmp):
    """tpUpdateCycle: one period (or the rest of one) of segment k; returns its acceleration."""
    _position(F, I, k, F[k, PROGRESS], tmp)
    for d in range(3):
        pos[d] -= tmp[d]
    if not I[k, BLENDING_NEXT]:
        F[k, VEL_AT_BLEND] = F[k, CURVEL]
    ok = False
    acc, vdes = 0.0, 0.0
    if I[k, ACCEL_MODE] and I[k, TERM] == TERM_TANGENT:
        ok, acc, vdes = _ramp(F, I, k, nk, p)
    if not ok:
        acc, vdes = _trapezoid(F, I, k, nk, p)
    # tcUpdateDistFromAccel: trapezoidal integration; a stop snaps to the end when it is close
    dt = F[k, CYCLE]
    v0 = F[k, CURVEL]
    v1 = v0 + acc * dt
    if v1 < 0.0:
        v1 = 0.0
        if F[k, TARGET] - F[k, PROGRESS] < v0 * dt:
            F[k, PROGRESS] = F[k, TARGET]
    else:
        F[k, PROGRESS] = min(max(F[k, PROGRESS] + (v1 + v0) * 0.5 * dt, 0.0), F[k, TARGET])
    F[k, CURVEL] = v1
    I[k, ON_FINAL_DECEL] = abs(vdes - v1) < VEL_EPSILON and acc < 0.0
    _check_end(F, I, k, nk, p)
    _position(F, I, k, F[k, PROGRESS], tmp)
    for d in range(3):
        pos[d] += tmp[d]
    return acc


@njit(cache=True, error_model="numpy")
def _blend_velocity(F, I, k, nk, p):
    """tpComputeBlendVelocity for the parabolic blend k -> nk: (v_this, v_next)."""
    if nk < 0:
        return 0.0, 0.0
    vt_this, vt_next = _target_vel(F, I, k, p), _target_vel(F, I, nk, p)
    a_this, a_next = F[k, ACC_T], F[nk, ACC_T]
    v_this = min(F[k, V_TRI], vt_this)
    v_next = min(F[nk, V_TRI], vt_next)
    t_blend = min(min(F[k, TARGET] / v_this, F[nk, TARGET] / v_next), max(v_this / a_this, v_next / a_next))
    b_this, b_next = min(v_this, t_blend * a_this), min(v_next, t_blend * a_next)
    dot = 0.0
    for d in range(3):
        dot += F[k, UAE + d] * F[nk, UAS + d]
    theta = acos(-min(max(dot, -1.0), 1.0)) / 2.0
    if F[k, TOL] > 0 and cos(theta) > cos(np.pi / 2.0 - MIN_ARC_ANGLE):
        tb = 2.0 * sqrt(a_this * F[k, TOL] / cos(theta))
        b_this, b_next = min(b_this, tb), min(b_next, tb)
    return b_this, b_next


@njit(cache=True, error_model="numpy")
def _activate(F, I, k, p):
    """tpActivateSegment: a tangent segment shorter than one ramp period gets a ramp (not the
    first of a queue: LinuxCNC activates that one while it knows no final speed yet)."""
    if I[k, ACTIVE]:
        return
    length = F[k, TARGET] - F[k, PROGRESS]
    v_sum = F[k, CURVEL] + min(F[k, FINALVEL], _target_vel(F, I, k, p))
    seg_time = 2.0 * length / v_sum if v_sum > 0.0 else np.inf
    if (seg_time < 1.0 / max(p[P_RAMP], TIME_EPSILON) and I[k, CANON] != TRAVERSE and I[k, TERM] == TERM_TANGENT
            and length != 0 and not I[k, QUEUE_START]):
        I[k, ACCEL_MODE] = 1
    I[k, ACTIVE] = 1
    I[k, BLENDING_NEXT] = 0
    I[k, ON_FINAL_DECEL] = 0


@njit(cache=True, error_model="numpy")
def _reason(F, I, k, acc, p):
    """vcnc's limit code for a period of segment k."""
    if abs(acc) * p[P_T] > 1e-6:  # the speed changes by more than 1 um/s this period
        return LIMIT_ACCEL
    if F[k, REQVEL] * _feed_scale(F, I, k, p) <= min(F[k, MAXVEL], p[P_VLIMIT]):
        return LIMIT_PROGRAMMED
    if F[k, MAXVEL] > p[P_VLIMIT]:
        return LIMIT_AXIS
    r = I[k, VMAX_REASON]
    return LIMIT_CURVATURE if r == VMAX_CURVATURE else (LIMIT_SEGMENT if r == VMAX_SAMPLE else LIMIT_AXIS)


class Periods(NamedTuple):
    """The arrays run_cycles writes, one row per period."""

    pos: np.ndarray  # (N, 3) commanded position, mm
    vel: np.ndarray  # path speed, mm/s
    line: np.ndarray  # int32 source line
    reason: np.ndarray  # int8 LIMIT_* code


@njit(cache=True, error_model="numpy")
def run_cycles(F, I, head, stop, final, p, pos, out):
    """Periods into out (Periods) until it is full, segment `stop` is reached, or (not final)
    fewer than three segments are left to look at; returns (periods written, new head)."""
    out_pos, out_vel, out_line, out_reason = out
    n = 0
    tmp = np.empty(3)
    before = np.empty(3)
    cap = len(out_vel)
    T = p[P_T]
    tail = len(F)
    while n < cap and head < min(stop, tail) and (final or tail - head >= 3):
        k = head
        nk = head + 1 if head + 1 < tail else -1
        _activate(F, I, k, p)
        I[k, IS_BLENDING] = 0
        if nk >= 0:
            I[nk, IS_BLENDING] = 0
        # the status reads 0 in a period that updates no segment (the end of the last one)
        rep, vel, acc = k, 0.0, 0.0
        for d in range(3):
            before[d] = pos[d]
        if I[k, SPLITTING]:
            if not I[k, REMOVE]:
                _position(F, I, k, F[k, PROGRESS], tmp)
                for d in range(3):
                    pos[d] -= tmp[d]
                F[k, PROGRESS] = F[k, TARGET]
                _position(F, I, k, F[k, PROGRESS], tmp)
                for d in range(3):
                    pos[d] += tmp[d]
                I[k, REMOVE] = 1
                if nk >= 0:
                    if I[k, TERM] == TERM_TANGENT:
                        F[nk, CYCLE] = T - F[k, CYCLE]
                        F[nk, CURVEL] = F[k, TERMVEL]
                    n2 = head + 2 if head + 2 < tail else -1
                    acc = _update_cycle(F, I, nk, n2, p, pos, tmp)
                    if not (F[k, CYCLE] > F[nk, CYCLE] and I[k, TERM] == TERM_TANGENT):
                        rep = nk
                    vel = F[rep, CURVEL]
        elif not I[k, REMOVE]:
            F[k, CYCLE] = T
            acc = _update_cycle(F, I, k, nk, p, pos, tmp)
            v_this, v_next = _blend_velocity(F, I, k, nk, p)
            F[k, BLENDVEL] = v_this
            vel = F[k, CURVEL]
            if nk >= 0:
                F[nk, BLENDVEL] = v_next
                if (I[k, TERM] == TERM_PARABOLIC and I[k, ON_FINAL_DECEL] and F[k, CURVEL] < F[k, BLENDVEL]):
                    I[k, BLENDING_NEXT] = 1
                if I[k, BLENDING_NEXT]:
                    I[nk, IS_BLENDING] = 1
                    _update_cycle(F, I, nk, -1, p, pos, tmp)
                    if F[k, CURVEL] <= F[nk, CURVEL]:
                        rep = nk
                    vel = F[k, CURVEL] + F[nk, CURVEL]
        for d in range(3):
            out_pos[n, d] = pos[d]
        out_vel[n] = vel
        out_line[n] = I[rep, LINE]
        # a period that moves no axis by STILL_MM stands (as run_linuxcnc.sh reads LinuxCNC)
        moved = max(abs(pos[0] - before[0]), abs(pos[1] - before[1]), abs(pos[2] - before[2])) > STILL_MM
        out_reason[n] = _reason(F, I, rep, acc, p) if moved else LIMIT_DWELL
        n += 1
        if I[k, REMOVE]:
            # tpCompleteSegment
            I[k, ACTIVE], I[k, REMOVE], I[k, IS_BLENDING], I[k, SPLITTING] = 0, 0, 0, 0
            F[k, CYCLE], F[k, CURVEL], F[k, TERMVEL] = T, 0.0, 0.0
            head += 1
    return n, head
