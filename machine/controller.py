"""The virtual controller: check the whole program, then run it into the drive.

`check` interprets the whole file with every error collected and checks the travel limits
of the whole path and the NURBS the planner must walk (machine.check: in memory bounded by
the program's text and machine.check.KEEP_UNITS entities, whatever the number of executed
blocks); any problem refuses the run
with every reason and its line, before a single period moves. `run` streams the program
through the feed stage and interpolators (ipo.feed.planner.plan_periods) into the
simulated drive, either as fast as possible or paced in real time (machine.realtime),
and handles the program's events: dwell (standing-still periods from the feed stage),
M0 and M1 (pause; the operator resumes or stops), M2/M30 (end), messages, spindle,
coolant and tool changes. Ctrl-C stops the run cleanly; the result says where.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ipo.contracts import PeriodBatch
from ipo.errors import IpoError
from ipr.entities import Auxiliary, Coolant, GCodeError, Message, ProgramEnd, Spindle, Stop, ToolChange
from machine.check import CheckedProgram, ProgramRejected, check_program, first_motion_start
from machine.collector import collector_held
from machine.drive import Drive, DriveLimits, TravelLimitError
from machine.servo import ServoModel

__all__ = ["Controller", "RunResult", "CheckedProgram", "ProgramRejected", "start_position"]


def start_position(program) -> tuple[float, float, float]:
    """Where the machine stands before the first move: the first motion's start."""
    return first_motion_start(program.entities) or (0.0, 0.0, 0.0)


@dataclass(slots=True)
class RunResult:
    file: str
    state: str  # "completed", "stopped" (operator or M0 answer), "interrupted" (Ctrl-C), "fault"
    line: int  # the source line being executed when the run ended
    position_mm: list[float]
    cycle_time_s: float
    periods: int
    motions: int  # motion entities (a NURBS group of many blocks is one); compare counts blocks
    path_length_mm: float
    max_axis_velocity_mm_s: list[float]
    max_axis_accel_mm_s2: list[float]
    max_axis_jerk_mm_s3: list[float]
    accel_stencil_periods: int
    limit_violations: int  # periods over a limit the mode holds (jerk only in S-curve mode)
    limit_violations_by_kind: dict[str, int]  # periods over each limit, jerk in every mode
    limits_checked: str  # the configured axis limits (velocity; accel; jerk) the periods were measured against
    max_chord_error_um: float
    max_contour_error_um: float | None
    deadline_misses: int | None
    realtime_factor: float  # simulated time / (check_s + wall_s): parse, check, plan, interpolate, drive
    wall_s: float  # the run: plan, interpolate, drive (and the pacing in real-time mode)
    check_s: float
    planner: str = "vcnc"  # whose motion planning ran (machine.planners.describe)
    program_stops: list[int] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)
    fault: str | None = None

    def summary(self) -> dict:
        out = {k: getattr(self, k) for k in self.__slots__}
        for key in ("cycle_time_s", "path_length_mm", "max_chord_error_um", "max_contour_error_um",
                    "realtime_factor", "wall_s", "check_s"):
            if out[key] is not None:
                out[key] = round(float(out[key]), 6)
        out["position_mm"] = [round(v, 6) for v in self.position_mm]
        return out



def _axes(values) -> str:
    return " ".join(f"{float(v):g}" for v in values)

class Controller:
    """One machine configuration, one run at a time."""

    def __init__(self, config, *, method: str | None = None, feed_override: float = 1.0, sinks=(),
                 optional_stop: bool = False,
                 on_program_stop: Callable[[Stop], bool] = lambda stop: True,
                 on_event: Callable[[object], None] = lambda event: None, planner=None):
        if not feed_override > 0:
            raise ValueError(f"feed override must be > 0 % (got {feed_override * 100:g} %)")
        self.config = config
        self.method = method or config.method
        self.feed_override = feed_override
        self.sinks = list(sinks)
        self.optional_stop = optional_stop
        self.on_program_stop = on_program_stop
        self.on_event = on_event
        self.limits = DriveLimits.from_config(config)
        self.planner = planner  # plan_periods's signature; None = the machine file's planner (machine.planners)
        self.check_s = 0.0

    def check(self, path: str | Path) -> CheckedProgram:
        """Interpret and check the whole program (machine.check); raise ProgramRejected with every reason."""
        with collector_held():
            program, self.check_s = check_program(path, self.config, self.limits.min_mm, self.limits.max_mm)
        return program

    def make_drive(self, program: CheckedProgram) -> Drive:
        servo = ServoModel.from_config(self.config.servo, self.config.period_s, program.start_mm)
        return Drive(self.limits, start_mm=program.start_mm, servo=servo, sinks=self.sinks)

    def run(self, program: CheckedProgram, *, progress: Callable[[int], None] | None = None,
            player=None) -> RunResult:
        """Stream the checked program into a new drive. `player` (machine.realtime) paces it."""
        with collector_held():
            return self._run(program, progress, player)

    def _run(self, program: CheckedProgram, progress: Callable[[int], None] | None, player) -> RunResult:
        plan = self.planner
        if plan is None:
            from machine.planners import planner_for
            plan = planner_for(self.config, program, program.start_mm)
        drive = self.make_drive(program)
        drive.warm_up()  # numba's one-off start-up (about a second) is process start-up, not run time
        deliver = player.play if player is not None else drive.receive
        if player is not None:
            player.attach(drive)
        stops: list[int] = []
        messages: list[str] = []
        state, fault = "completed", None
        stream = plan(program.entities, self.config, method=self.method, feed_override=self.feed_override,
                      start_mm=program.start_mm)
        if player is not None:
            from machine.realtime import prefetch
            stream = prefetch(stream)
        t0 = time.perf_counter()
        try:
            for item in stream:
                if isinstance(item, PeriodBatch):
                    deliver(item)
                    if progress is not None:
                        progress(drive.line)
                    if player is not None and player.stopped:
                        state = "stopped"
                        break
                    continue
                if player is not None:
                    player.flush()
                    if player.stopped:
                        state = "stopped"
                        break
                if isinstance(item, ProgramEnd):
                    drive.line = item.line
                    break
                if isinstance(item, Stop):
                    if item.optional and not self.optional_stop:
                        continue
                    stops.append(item.line)
                    drive.line = item.line
                    if not self.on_program_stop(item):
                        state = "stopped"
                        break
                elif isinstance(item, Message):
                    messages.append(f"line {item.line}: {item.text}")
                    self.on_event(item)
                elif isinstance(item, (Spindle, Coolant, ToolChange, Auxiliary)):
                    if isinstance(item, Spindle):
                        sign = {"cw": 1.0, "ccw": -1.0}.get(item.direction, 0.0)
                        drive.spindle_rad_s = sign * item.rpm * 2.0 * math.pi / 60.0
                    self.on_event(item)
            else:
                if player is not None:
                    player.flush()
                    state = "stopped" if player.stopped else state
        except KeyboardInterrupt:
            state = "interrupted"
        except TravelLimitError as err:
            state, fault = "fault", str(err)
        except IpoError as err:  # the planner refused a block the checks let through: stop, say why
            state, fault = "fault", (f"the planner stopped at line {drive.line if err.line is None else err.line}: "
                                     f"error[{err.code}]: {err.message}")
        except GCodeError as err:  # the second reading differs from the checked one: a bug, but stop safely
            state, fault = "fault", f"the program read differently when run than when checked: {err}"
        finally:
            stream.close()
            if player is not None:
                player.detach()
        wall = time.perf_counter() - t0
        return self._result(program, drive, state, fault, wall, stops, messages, player)

    def _result(self, program, drive, state, fault, wall, stops, messages, player) -> RunResult:
        st = drive.stats
        sim = drive.t_s
        lim = self.limits
        # trapezoid mode steps the acceleration by design: its periods over the jerk limit are
        # counted and said to be unlimited, not added to the violations of the limits it holds
        kinds = {"velocity": st.velocity_violations, "accel": st.accel_violations, "jerk": st.jerk_violations}
        held = st.velocity_violations + st.accel_violations + (st.jerk_violations if lim.jerk_limited else 0)
        checked = (f"{_axes(lim.max_velocity_mm_s)} mm/s; {_axes(lim.max_accel_mm_s2)} mm/s^2; "
                   f"{_axes(lim.max_jerk_mm_s3)} mm/s^3" + ("" if lim.jerk_limited else
                                                            " (jerk counted, not limited in trapezoid mode)"))
        return RunResult(
            file=program.file, state=state, line=drive.line, position_mm=drive.position_mm.tolist(),
            cycle_time_s=sim, periods=st.periods,
            motions=program.motion_count,
            path_length_mm=st.path_length_mm,
            max_axis_velocity_mm_s=[round(float(v), 4) for v in st.max_velocity_mm_s],
            max_axis_accel_mm_s2=[round(float(v), 3) for v in st.max_accel_mm_s2],
            max_axis_jerk_mm_s3=[round(float(v), 1) for v in st.max_jerk_mm_s3],
            accel_stencil_periods=self.limits.stencil_periods(),
            limit_violations=held, limit_violations_by_kind=kinds,
            limits_checked=checked,
            max_chord_error_um=st.max_chord_error_mm * 1e3,
            max_contour_error_um=None if st.max_contour_error_mm is None else st.max_contour_error_mm * 1e3,
            deadline_misses=None if player is None else player.deadline_misses,
            realtime_factor=sim / (wall + self.check_s) if wall > 0 else math.inf,
            wall_s=wall, check_s=self.check_s,
            planner=self._planner_name(), program_stops=stops, messages=messages, fault=fault)

    def _planner_name(self) -> str:
        from machine.planners import describe

        return describe(self.config) if self.planner is None else getattr(self.planner, "__name__", "custom")
