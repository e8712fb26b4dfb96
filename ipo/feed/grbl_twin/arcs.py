"""grbl 1.1's arcs: G2/G3 as chords within the arc tolerance $12 (gnea/grbl motion_control.c
mc_arc): the chord count from the tolerance, each chord end by rotating the radius vector
with the third-order small-angle rotation, re-computed exactly every N_ARC_CORRECTION
chords, and the last chord ending on the programmed end."""
from __future__ import annotations

import math

from ipr.entities import PLANE_AXES

N_ARC_CORRECTION = 12  # config.h
ARC_ANGULAR_TRAVEL_EPSILON = 5e-7  # config.h, rad


def arc_targets(start_mm, end_mm, center_mm, plane: str, ccw: bool, tolerance_mm: float) -> list[list[float]]:
    """The chord ends grbl plans for an arc from start_mm (the parser's position) to end_mm."""
    a0, a1, lin = PLANE_AXES[plane]
    r0 = start_mm[a0] - center_mm[a0]
    r1 = start_mm[a1] - center_mm[a1]
    radius = math.hypot(r0, r1)  # gcode.c: from the IJK offset
    rt0 = end_mm[a0] - center_mm[a0]
    rt1 = end_mm[a1] - center_mm[a1]
    travel = math.atan2(r0 * rt1 - r1 * rt0, r0 * rt0 + r1 * rt1)
    if not ccw:
        if travel >= -ARC_ANGULAR_TRAVEL_EPSILON:
            travel -= 2.0 * math.pi
    elif travel <= ARC_ANGULAR_TRAVEL_EPSILON:
        travel += 2.0 * math.pi
    segments = int(math.floor(abs(0.5 * travel * radius) / math.sqrt(tolerance_mm * (2.0 * radius - tolerance_mm))))
    out = []
    if segments:
        theta = travel / segments
        linear = (end_mm[lin] - start_mm[lin]) / segments
        cos_t = 2.0 - theta * theta
        sin_t = theta * 0.16666667 * (cos_t + 4.0)
        cos_t *= 0.5
        pos = list(start_mm)
        count = 0
        for i in range(1, segments):
            if count < N_ARC_CORRECTION:
                r0, r1 = r0 * cos_t - r1 * sin_t, r0 * sin_t + r1 * cos_t
                count += 1
            else:
                c, s = math.cos(i * theta), math.sin(i * theta)
                o0, o1 = center_mm[a0] - start_mm[a0], center_mm[a1] - start_mm[a1]
                r0, r1 = -o0 * c + o1 * s, -o0 * s - o1 * c
                count = 0
            pos[a0] = center_mm[a0] + r0
            pos[a1] = center_mm[a1] + r1
            pos[lin] += linear
            out.append(list(pos))
    out.append(list(end_mm))
    return out
