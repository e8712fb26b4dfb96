"""What the LinuxCNC 2.9 twin knows of the machine: the limits and [TRAJ] tuning its planner reads.

LinuxCNC plans coordinated motion with the [AXIS_*] limits (the canon layer projects them on
each move, the planner bounds its blend arcs with them), [TRAJ]MAX_LINEAR_VELOCITY (a cap on
every move, rapids included), the [TRAJ] arc-blend keys and [DISPLAY]MAX_FEED_OVERRIDE (blends
are sized for the highest override). [JOINT_n] limits bound only jogging and homing in 2.9.

Without a LinuxCNC INI file (ipo.feed.linuxcnc_twin.ini) the settings come from the machine
file: its axis limits as [AXIS_*], its period as [EMCMOT]SERVO_PERIOD, its rapid_mm_s as
[TRAJ]MAX_LINEAR_VELOCITY, task's and iocontrol's cycles as LinuxCNC's configuration tools
write them (10 ms, 100 ms), and LinuxCNC 2.9's defaults for the rest (initraj.cc).
"""
from __future__ import annotations

from dataclasses import dataclass

from ipo.config import MachineConfig

# LinuxCNC 2.9's defaults when the INI file does not name the key (src/emc/ini/initraj.cc)
DEFAULT_ARC_BLEND_ENABLE = True
DEFAULT_OPTIMIZATION_DEPTH = 50
DEFAULT_GAP_CYCLES = 4
DEFAULT_RAMP_FREQ_HZ = 100.0
DEFAULT_KINK_RATIO = 0.1
DEFAULT_MAX_FEED_OVERRIDE = 1.0
DEFAULT_TASK_CYCLE_S = 0.100  # [TASK]CYCLE_TIME (emccfg.h)
DEFAULT_IO_CYCLE_S = 0.100  # [EMCIO]CYCLE_TIME
# what LinuxCNC's configuration tools (stepconf, pncconf) write: the machine file's stand-ins
MACHINE_TASK_CYCLE_S = 0.010
MACHINE_IO_CYCLE_S = 0.100


@dataclass(frozen=True, slots=True)
class LinuxcncSettings:
    servo_period_s: float
    axis_velocity_mm_s: tuple[float, float, float]  # [AXIS_X/Y/Z]MAX_VELOCITY
    axis_accel_mm_s2: tuple[float, float, float]  # [AXIS_X/Y/Z]MAX_ACCELERATION
    max_linear_velocity_mm_s: float = float("inf")  # [TRAJ]MAX_LINEAR_VELOCITY
    arc_blend_enable: bool = DEFAULT_ARC_BLEND_ENABLE
    optimization_depth: int = DEFAULT_OPTIMIZATION_DEPTH  # [TRAJ]ARC_BLEND_OPTIMIZATION_DEPTH
    gap_cycles: int = DEFAULT_GAP_CYCLES  # [TRAJ]ARC_BLEND_GAP_CYCLES
    ramp_freq_hz: float = DEFAULT_RAMP_FREQ_HZ  # [TRAJ]ARC_BLEND_RAMP_FREQ
    kink_ratio: float = DEFAULT_KINK_RATIO  # [TRAJ]ARC_BLEND_KINK_RATIO
    max_feed_override: float = DEFAULT_MAX_FEED_OVERRIDE  # [DISPLAY]MAX_FEED_OVERRIDE
    task_cycle_s: float = MACHINE_TASK_CYCLE_S  # [TASK]CYCLE_TIME: task's loop
    io_cycle_s: float = MACHINE_IO_CYCLE_S  # [EMCIO]CYCLE_TIME: iocontrol's loop (coolant, tools)
    source: str = "machine file"

    @property
    def tangent_kink_ratio(self) -> float:
        """The kink ratio as the planner bounds it (tp.c tpGetTangentKinkRatio)."""
        return min(max(self.kink_ratio, 0.001), 0.7071)


def from_machine(config: MachineConfig) -> LinuxcncSettings:
    """The settings a LinuxCNC with the machine file's limits would run with."""
    return LinuxcncSettings(
        servo_period_s=config.period_s,
        axis_velocity_mm_s=tuple(a.max_velocity_mm_s for a in config.axes),
        axis_accel_mm_s2=tuple(a.max_accel_mm_s2 for a in config.axes),
        max_linear_velocity_mm_s=config.rapid_mm_s)
