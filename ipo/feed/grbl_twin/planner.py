"""grbl 1.1's planner: a ring of 16 blocks (15 usable), junction speeds from the junction
deviation, and the two-pass re-planning each new block starts (gnea/grbl planner.c).

Units are grbl's own: mm, mm/min, mm/min^2, steps. What the stepper has prepared of the
executing block is gone from it (`Block.mm` shrinks as segments are cut, stepper.py), and
the executing block's entry speed is reset to the prepared speed when a new block changes
its exit (`on_replan_tail`), as grbl's st_update_plan_block_parameters does.
"""
from __future__ import annotations

import math
from typing import Callable

from ipo.feed.grbl_twin.numbers import to_steps

BLOCK_BUFFER_SIZE = 16  # planner.h: one slot always empty, 15 blocks usable
MINIMUM_JUNCTION_SPEED_MM_MIN = 0.0  # config.h
MINIMUM_FEED_RATE_MM_MIN = 1.0  # config.h
SOME_LARGE_VALUE = 1.0e38  # nuts_bolts.h
_STRAIGHT_COS = 0.999999  # config-free constants of plan_buffer_line's junction test


class Block:
    """One planner block (plan_block_t) and what the twin needs to place it."""

    __slots__ = ("steps", "step_event_count", "mm", "accel", "rapid_rate", "programmed_rate", "rapid",
                 "entry_sqr", "max_entry_sqr", "max_junction_sqr", "start_steps", "target_steps", "line")

    def __init__(self):
        self.entry_sqr = 0.0


def _limit_by_axes(max_values, unit) -> float:
    """nuts_bolts.c limit_value_by_axis_maximum: the largest value along `unit` within every axis's."""
    out = SOME_LARGE_VALUE
    for m, u in zip(max_values, unit):
        if u != 0.0:
            out = min(out, abs(m / u))
    return out


class Planner:
    """The block ring and grbl's planner state (planner_t); see the module docstring."""

    def __init__(self, steps_per_mm, max_rate_mm_min, accel_mm_min2, junction_deviation_mm: float,
                 start_steps=(0, 0, 0)):
        self.steps_per_mm = tuple(steps_per_mm)
        self.max_rate = tuple(max_rate_mm_min)
        self.accel = tuple(accel_mm_min2)
        self.junction_deviation = junction_deviation_mm
        self.ring: list[Block] = [Block() for _ in range(BLOCK_BUFFER_SIZE)]
        self.tail = self.head = self.planned = 0
        self.position = list(start_steps)
        self.prev_unit = [0.0, 0.0, 0.0]
        self.prev_nominal = 0.0
        self.override = 1.0
        self.on_replan_tail: Callable[[], None] = lambda: None

    # ---- the ring ------------------------------------------------------------------
    @staticmethod
    def _next(i: int) -> int:
        return 0 if i + 1 == BLOCK_BUFFER_SIZE else i + 1

    @staticmethod
    def _prev(i: int) -> int:
        return BLOCK_BUFFER_SIZE - 1 if i == 0 else i - 1

    def full(self) -> bool:
        return self.tail == self._next(self.head)

    def empty(self) -> bool:
        return self.head == self.tail

    def current(self) -> Block | None:
        return None if self.head == self.tail else self.ring[self.tail]

    def exit_speed_sqr(self) -> float:
        """plan_get_exec_block_exit_speed_sqr: the next block's entry, 0 when there is none."""
        i = self._next(self.tail)
        return 0.0 if i == self.head else self.ring[i].entry_sqr

    def discard(self) -> None:
        """plan_discard_current_block: the stepper has prepared all of the tail block."""
        if self.head != self.tail:
            i = self._next(self.tail)
            if self.tail == self.planned:
                self.planned = i
            self.tail = i

    def nominal_speed(self, b: Block) -> float:
        """plan_compute_profile_nominal_speed (mm/min): the feed override scales feed moves only."""
        if b.rapid:
            v = b.programmed_rate
        else:
            v = min(b.programmed_rate * self.override, b.rapid_rate)
        return max(v, MINIMUM_FEED_RATE_MM_MIN)

    # ---- plan_buffer_line ------------------------------------------------------------
    def add(self, target_mm, feed_mm_min: float, rapid: bool, line: int) -> bool:
        """Queue a straight move to `target_mm` (machine mm); False when it moves no step
        (grbl drops it). The caller checks `full()` first, as mc_line waits for a free block."""
        b = self.ring[self.head]
        # 1. steps and the unit vector, from the rounded step targets
        target = [to_steps(t, s) for t, s in zip(target_mm, self.steps_per_mm)]
        delta = [(t - p) / s for t, p, s in zip(target, self.position, self.steps_per_mm)]
        b.steps = [abs(t - p) for t, p in zip(target, self.position)]
        b.step_event_count = max(b.steps)
        if b.step_event_count == 0:
            return False
        b.mm = math.sqrt(sum(d * d for d in delta))
        unit = [d / b.mm for d in delta]
        # 2. the block's limits projected on its direction
        b.accel = _limit_by_axes(self.accel, unit)
        b.rapid_rate = _limit_by_axes(self.max_rate, unit)
        b.rapid = rapid
        b.programmed_rate = b.rapid_rate if rapid else feed_mm_min
        b.start_steps, b.target_steps, b.line = list(self.position), target, line
        # 3. junction speed: a circle tangent to both moves, junction deviation from the corner
        if self.head == self.tail:
            b.entry_sqr = 0.0
            b.max_junction_sqr = 0.0  # from rest
        else:
            cos_theta = -sum(p * u for p, u in zip(self.prev_unit, unit))
            if cos_theta > _STRAIGHT_COS:
                b.max_junction_sqr = MINIMUM_JUNCTION_SPEED_MM_MIN ** 2  # a full reversal
            elif cos_theta < -_STRAIGHT_COS:
                b.max_junction_sqr = SOME_LARGE_VALUE  # straight on
            else:
                ju = [u - p for u, p in zip(unit, self.prev_unit)]
                norm = math.sqrt(sum(j * j for j in ju))
                junction_accel = _limit_by_axes(self.accel, [j / norm for j in ju])
                sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
                b.max_junction_sqr = max(MINIMUM_JUNCTION_SPEED_MM_MIN ** 2,
                                         junction_accel * self.junction_deviation * sin_half / (1.0 - sin_half))
        # 4. entry limit from the junction and both nominal speeds; then re-plan
        nominal = self.nominal_speed(b)
        b.max_entry_sqr = min(min(nominal, self.prev_nominal) ** 2, b.max_junction_sqr)
        self.prev_nominal = nominal
        self.prev_unit = unit
        self.position = target
        self.head = self._next(self.head)
        self._recalculate()
        return True

    def _recalculate(self) -> None:
        """planner_recalculate: reverse pass from the newest block (which ends at rest), then
        the forward pass from the last block whose plan cannot improve (`planned`)."""
        ring = self.ring
        i = self._prev(self.head)
        if i == self.planned:
            return
        cur = ring[i]
        cur.entry_sqr = min(cur.max_entry_sqr, 2.0 * cur.accel * cur.mm)
        i = self._prev(i)
        if i == self.planned:
            if i == self.tail:
                self.on_replan_tail()
        else:
            while i != self.planned:
                nxt, cur = cur, ring[i]
                i = self._prev(i)
                if i == self.tail:
                    self.on_replan_tail()
                if cur.entry_sqr != cur.max_entry_sqr:
                    cur.entry_sqr = min(nxt.entry_sqr + 2.0 * cur.accel * cur.mm, cur.max_entry_sqr)
        nxt = ring[self.planned]
        i = self._next(self.planned)
        while i != self.head:
            cur, nxt = nxt, ring[i]
            if cur.entry_sqr < nxt.entry_sqr:
                reach = cur.entry_sqr + 2.0 * cur.accel * cur.mm
                if reach < nxt.entry_sqr:
                    nxt.entry_sqr = reach
                    self.planned = i
            if nxt.entry_sqr == nxt.max_entry_sqr:
                self.planned = i
            i = self._next(i)
