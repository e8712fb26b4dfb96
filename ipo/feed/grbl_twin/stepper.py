"""grbl 1.1's segment generator and step timer (gnea/grbl stepper.c, st_prep_buffer and the
Timer1 ISR), as time: each segment is cut from the planner's tail block over
DT_SEGMENT = 1/ACCELERATION_TICKS_PER_SECOND of the block's trapezoid (longer where fewer
than one step would fall in it), rounded to whole steps, and run at a whole number of
16 MHz timer ticks per step (AMASS divides the ticks of slow segments and multiplies their
steps; the timer's compare period is one tick longer than its compare value, CTC mode).

`Prep.cut()` makes one segment, exactly as st_prep_buffer's loop body does for normal
operation (feed hold, parking and mid-run override changes are not modelled).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ipo.feed.grbl_twin.planner import Block, Planner

F_CPU_HZ = 16_000_000
ACCELERATION_TICKS_PER_SECOND = 100  # config.h
DT_SEGMENT_MIN = 1.0 / (ACCELERATION_TICKS_PER_SECOND * 60.0)
SEGMENT_BUFFER_SIZE = 6  # stepper.h: 5 segments prepared ahead of the one running
REQ_MM_INCREMENT_SCALAR = 1.25
MAX_AMASS_LEVEL = 3
AMASS_LEVEL_CYCLES = (F_CPU_HZ // 8000, F_CPU_HZ // 4000, F_CPU_HZ // 2000)  # cut-offs of levels 1..3
TICKS_PER_MIN = F_CPU_HZ * 60.0
RAMP_ACCEL, RAMP_CRUISE, RAMP_DECEL = 0, 1, 2


@dataclass(slots=True)
class Segment:
    """One prepared segment: where it starts and ends (steps, along its block's line), how
    many timer ticks it runs (steps x (compare value + 1)) and what set its speed. The
    planner's block slot is reused later: a segment keeps its own copy of all it needs."""

    from_steps: tuple[float, float, float]
    to_steps: tuple[float, float, float]
    n_tick: int
    isr_ticks: int  # ticks between two runs of the step interrupt in it
    amass_level: int  # the interrupt runs 2**level times per step of the block's longest axis
    ramp: int  # the ramp it ends in
    line: int
    axis_limited: bool  # a feed move whose F the axes' max rates cut (cruising at the axis limit)


class Prep:
    """st_prep_buffer's state (`prep` and `pl_block`)."""

    def __init__(self, planner: Planner):
        self.pl = planner
        self.block: Block | None = None
        self.recalculate = False
        self.steps_remaining = 0.0
        self.step_per_mm = 0.0
        self.req_mm = 0.0
        self.dt_remainder = 0.0
        self.current_speed = 0.0
        self.maximum_speed = 0.0
        self.exit_speed = 0.0
        self.accelerate_until = 0.0
        self.decelerate_after = 0.0
        self.ramp = RAMP_ACCEL
        planner.on_replan_tail = self.update_block_parameters

    def update_block_parameters(self) -> None:
        """st_update_plan_block_parameters: the planner changed the executing block's exit;
        its profile restarts from the speed prepared so far."""
        if self.block is not None:
            self.recalculate = True
            self.block.entry_sqr = self.current_speed * self.current_speed
            self.block = None

    def _load(self) -> Block | None:
        b = self.pl.current()
        if b is None:
            return None
        if self.recalculate:
            self.recalculate = False
        else:
            self.steps_remaining = float(b.step_event_count)
            self.step_per_mm = self.steps_remaining / b.mm
            self.req_mm = REQ_MM_INCREMENT_SCALAR / self.step_per_mm
            self.dt_remainder = 0.0
            self.current_speed = math.sqrt(b.entry_sqr)
        self.block = b
        self._profile(b)
        return b

    def _profile(self, b: Block) -> None:
        """The block's trapezoid from its entry (or the prepared speed) to its exit speed."""
        a2 = 0.5 / b.accel
        self.ramp = RAMP_ACCEL
        self.accelerate_until = b.mm
        exit_sqr = self.pl.exit_speed_sqr()
        self.exit_speed = math.sqrt(exit_sqr)
        nominal = self.pl.nominal_speed(b)
        nominal_sqr = nominal * nominal
        intersect = 0.5 * (b.mm + a2 * (b.entry_sqr - exit_sqr))
        if intersect > 0.0:
            if intersect < b.mm:  # trapezoid or triangle
                self.decelerate_after = a2 * (nominal_sqr - exit_sqr)
                if self.decelerate_after < intersect:  # trapezoid
                    self.maximum_speed = nominal
                    if b.entry_sqr == nominal_sqr:
                        self.ramp = RAMP_CRUISE
                    else:
                        self.accelerate_until -= a2 * (nominal_sqr - b.entry_sqr)
                else:  # triangle
                    self.accelerate_until = self.decelerate_after = intersect
                    self.maximum_speed = math.sqrt(2.0 * b.accel * intersect + exit_sqr)
            else:  # deceleration only
                self.ramp = RAMP_DECEL
        else:  # acceleration only
            self.accelerate_until = 0.0
            self.maximum_speed = self.exit_speed

    def cut(self) -> Segment | None:
        """The next segment, or None when the planner holds no block."""
        b = self.block if self.block is not None else self._load()
        if b is None:
            return None
        # 1. walk the ramps for DT_SEGMENT (longer until at least one step falls in it)
        dt_max = DT_SEGMENT_MIN
        dt = 0.0
        time_var = dt_max
        mm_remaining = b.mm
        minimum_mm = max(mm_remaining - self.req_mm, 0.0)
        while True:
            if self.ramp == RAMP_ACCEL:
                speed_var = b.accel * time_var
                mm_remaining -= time_var * (self.current_speed + 0.5 * speed_var)
                if mm_remaining < self.accelerate_until:  # end of the acceleration ramp
                    mm_remaining = self.accelerate_until
                    time_var = 2.0 * (b.mm - mm_remaining) / (self.current_speed + self.maximum_speed)
                    self.ramp = RAMP_DECEL if mm_remaining == self.decelerate_after else RAMP_CRUISE
                    self.current_speed = self.maximum_speed
                else:
                    self.current_speed += speed_var
            elif self.ramp == RAMP_CRUISE:
                mm_var = mm_remaining - self.maximum_speed * time_var
                if mm_var < self.decelerate_after:  # end of the cruise
                    time_var = (mm_remaining - self.decelerate_after) / self.maximum_speed
                    mm_remaining = self.decelerate_after
                    self.ramp = RAMP_DECEL
                else:
                    mm_remaining = mm_var
            else:
                speed_var = b.accel * time_var
                done = True
                if self.current_speed > speed_var:
                    mm_var = mm_remaining - time_var * (self.current_speed - 0.5 * speed_var)
                    if mm_var > 0.0:
                        mm_remaining = mm_var
                        self.current_speed -= speed_var
                        done = False
                if done:  # the end of the block
                    time_var = 2.0 * mm_remaining / (self.current_speed + self.exit_speed)
                    mm_remaining = 0.0
                    self.current_speed = self.exit_speed
            dt += time_var
            if dt < dt_max:
                time_var = dt_max - dt  # a ramp ended inside the segment
            elif mm_remaining > minimum_mm:
                dt_max += DT_SEGMENT_MIN  # no step yet: a longer segment
                time_var = dt_max - dt
            else:
                break
            if not mm_remaining > 0.0:
                break
        # 2. whole steps, and the step period in timer ticks (the partial step's time carries on)
        step_dist_remaining = self.step_per_mm * mm_remaining
        n_steps_remaining = math.ceil(step_dist_remaining)
        last_n = math.ceil(self.steps_remaining)
        n_step = int(last_n - n_steps_remaining)
        dt += self.dt_remainder
        inv_rate = dt / (last_n - step_dist_remaining)
        cycles = math.ceil(TICKS_PER_MIN * inv_rate)
        level = 0
        if cycles >= AMASS_LEVEL_CYCLES[0]:
            level = 1 if cycles < AMASS_LEVEL_CYCLES[1] else 2 if cycles < AMASS_LEVEL_CYCLES[2] else MAX_AMASS_LEVEL
            cycles >>= level
        per_step = min(cycles, 0xFFFF) + 1
        done = b.step_event_count - int(last_n)
        f0, f1 = done / b.step_event_count, (done + n_step) / b.step_event_count
        seg = Segment(tuple(s + f0 * (e - s) for s, e in zip(b.start_steps, b.target_steps)),
                      tuple(s + f1 * (e - s) for s, e in zip(b.start_steps, b.target_steps)),
                      (n_step << level) * per_step, per_step, level, self.ramp, b.line,
                      not b.rapid and b.programmed_rate * self.pl.override > b.rapid_rate)
        # 3. what is left of the block
        b.mm = mm_remaining
        self.steps_remaining = float(n_steps_remaining)
        self.dt_remainder = (n_steps_remaining - step_dist_remaining) * inv_rate
        if mm_remaining == 0.0:
            self.block = None
            self.pl.discard()
        return seg
