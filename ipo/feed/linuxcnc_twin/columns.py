"""The queued segments as two arrays, one row per segment: what the compiled run cycle reads.

`pack` turns planned segments (ipo.feed.linuxcnc_twin.segments.Tc) into rows of a float
matrix (kinematics, then geometry) and an int matrix (kind, flags, source line). The column
numbers are module constants, so the numba kernels index them as compile-time constants.
"""
from __future__ import annotations

import numpy as np

from ipo.feed.linuxcnc_twin.segments import (TC_CIRCULAR, TC_LINEAR, Tc, start_accel_unit, end_accel_unit,
                                             tangential_max_accel)
from ipo.feed.linuxcnc_twin.tp import triangle_vel

# float columns: kinematics
TARGET, PROGRESS, REQVEL, MAXVEL, FINALVEL, CURVEL, TERMVEL, CYCLE = 0, 1, 2, 3, 4, 5, 6, 7
ACC_T, TOL, BLENDVEL, VEL_AT_BLEND, V_TRI = 8, 9, 10, 11, 12
UAS, UAE = 13, 16  # start / end acceleration unit vectors (3 each)
# float columns: geometry (line: P0 start, P1 end, U direction; circle: C centre, N normal,
# RT, RP, RH its rTan, rPerp, rHelix; blend arc: P0 start, C centre, RT rStart, RP rEnd, U uTan)
P0, P1, U, C, N, RT, RP, RH = 19, 22, 25, 28, 31, 34, 37, 40
RADIUS, ANGLE, SPIRAL, B0, B1, PLEN, SANGLE, LINE_LEN = 43, 44, 45, 46, 47, 48, 49, 50
NF = 51
# int columns
KIND, CANON, LINE, TERM, ACTIVE, BLENDING_NEXT, SPLITTING, REMOVE = 0, 1, 2, 3, 4, 5, 6, 7
IS_BLENDING, ON_FINAL_DECEL, ACCEL_MODE, FINALIZED, SPIRAL_IN, VMAX_REASON, TMAG_ZERO = 8, 9, 10, 11, 12, 13, 14
# the first segment after the queue ran empty: the run cycle activates it before any later one
# arrives (or under the feed hold of run_linuxcnc.sh's pre-fill), so it never gets a ramp
QUEUE_START = 15
NI = 16


def pack(segs: list[Tc], queue_start: bool) -> tuple[np.ndarray, np.ndarray]:
    """Rows for segments whose plan is final; `queue_start`: the first one starts the queue."""
    F = np.zeros((len(segs), NF))
    I = np.zeros((len(segs), NI), np.int64)
    for k, tc in enumerate(segs):
        f, i = F[k], I[k]
        f[TARGET], f[PROGRESS], f[REQVEL], f[MAXVEL] = tc.target, tc.progress, tc.reqvel, tc.maxvel
        f[FINALVEL], f[CYCLE], f[ACC_T], f[TOL] = tc.finalvel, tc.cycle_time, tangential_max_accel(tc), tc.tolerance
        f[V_TRI] = triangle_vel(tc)
        ua, ue = start_accel_unit(tc), end_accel_unit(tc)
        if ua is not None:
            f[UAS:UAS + 3] = ua
        if ue is not None:
            f[UAE:UAE + 3] = ue
        i[KIND], i[CANON], i[LINE], i[TERM] = tc.kind, tc.canon, tc.line_no, tc.term_cond
        i[FINALIZED], i[VMAX_REASON] = tc.finalized, tc.vmax_reason
        s = tc.shape
        if tc.kind == TC_LINEAR:
            f[P0:P0 + 3], f[P1:P1 + 3], f[U:U + 3] = s.start, s.end, s.uvec
            i[TMAG_ZERO] = s.tmag_zero
        elif tc.kind == TC_CIRCULAR:
            f[C:C + 3], f[N:N + 3], f[RT:RT + 3], f[RP:RP + 3], f[RH:RH + 3] = (s.center, s.normal, s.rtan, s.rperp,
                                                                              s.rhelix)
            f[RADIUS], f[ANGLE], f[SPIRAL], f[B0], f[B1], f[PLEN] = (s.radius, s.angle, s.spiral, s.b0, s.b1,
                                                                     s.planar_length)
            i[SPIRAL_IN] = s.spiral_in
        else:
            f[P0:P0 + 3], f[C:C + 3], f[RT:RT + 3], f[RP:RP + 3], f[U:U + 3] = (s.start, s.center, s.rstart,
                                                                              s.rend, s.utan)
            f[RADIUS], f[ANGLE], f[SPIRAL], f[LINE_LEN] = s.radius, s.angle, s.spiral, s.line_length
            f[SANGLE] = np.sin(s.angle)
    if len(segs) and queue_start:
        I[0, QUEUE_START] = 1
    return F, I
