"""The two contracts every IPO stage shares: per-entity stepping and period batches.

Stepping (interpolators). A stepper walks one motion entity. It is built with
`lead_mm`, the part of the current period already travelled at the end of the
previous entity (0 at a standstill), and `advance(steps_mm)` takes the desired
chord of each following period (d_j = v_j * T, 000 §2.2). The first target lies
steps_mm[0] - lead_mm from the entity's start; each further target lies steps_mm[j]
beyond the previous point. It returns the point reached at the end of each period
that ends inside the entity. When a period's target reaches or passes the end, that
period's point is the end point itself (u clamped at u_max), `done` becomes True and
`carry_mm` is the part of that period's step not used; the caller may then drop that
end point and start the next entity with lead_mm = step - carry_mm, so that a block
boundary does not dip the feed. Steps of 0 (standing still) are allowed.

Period batches (feed stage -> machine). One batch covers a run of consecutive
periods; nothing per period is a Python object.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class Steps:
    """What one `advance` call produced: k periods."""

    pos_mm: np.ndarray  # (k, 3) point at the end of each period
    u: np.ndarray  # (k,) curve parameter of each point (arc length in mm for lines and arcs)
    evals: np.ndarray  # (k,) curve evaluations spent in each period (0 for lines and arcs)
    done: bool  # the entity's end was reached by the last period
    carry_mm: float  # unused part of the last period's step when done, else 0


# Why the machine slowed down: one code per period in PeriodBatch.limit.
LIMIT_PROGRAMMED = 0  # the programmed F (or the rapid rate)
LIMIT_AXIS = 1  # an axis's velocity limit along the tangent
LIMIT_CURVATURE = 2  # centripetal acceleration on a curve
LIMIT_CHORD = 3  # chord error within the tolerance delta
LIMIT_ROUGHNESS = 4  # 002's surface-roughness limiter
LIMIT_ACCEL = 5  # accelerating or braking (look-ahead)
LIMIT_DWELL = 6  # standing still: dwell, stop, or start
LIMIT_SEGMENT = 7  # a controller that finishes at most one segment per period (LinuxCNC): length / T
LIMIT_NAMES = ("programmed", "axis", "curvature", "chord", "roughness", "accel", "dwell", "segment rate")


@dataclass(slots=True)
class PeriodBatch:
    """A run of consecutive interpolation periods, as the machine receives them."""

    pos_mm: np.ndarray  # (N, 3) commanded position at the end of each period, quantised to BLU
    inc_blu: np.ndarray  # (N, 3) int64 axis increments of each period in BLU
    feed_mm_s: np.ndarray  # (N,) planned path speed in the period
    limit: np.ndarray  # (N,) int8 limiting reason (LIMIT_*)
    line: np.ndarray  # (N,) int32 source line of the block being executed

    def __len__(self) -> int:
        return len(self.feed_mm_s)
