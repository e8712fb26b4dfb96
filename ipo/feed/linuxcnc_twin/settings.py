"""The twin's settings when no LinuxCNC INI file names them (ipo.linuxcnc_ini reads one).

The machine file stands in: its axis limits as [AXIS_*], its period as [EMCMOT]SERVO_PERIOD,
its rapid_mm_s as [TRAJ]MAX_LINEAR_VELOCITY, task's and iocontrol's cycles as LinuxCNC's
configuration tools (stepconf, pncconf) write them, and LinuxCNC 2.9's defaults for the rest.
"""
from __future__ import annotations

import dataclasses

from ipo.config import MachineConfig
from ipo.linuxcnc_ini import LinuxcncSettings

MACHINE_TASK_CYCLE_S = 0.010
MACHINE_IO_CYCLE_S = 0.100


def settings_of(config: MachineConfig) -> LinuxcncSettings:
    """The machine's LinuxCNC settings: its INI file's, or the machine file's; run at the
    machine's period either way (a --period-ms override included)."""
    s = config.linuxcnc_ini
    if s is None:
        return LinuxcncSettings(
            servo_period_s=config.period_s,
            axis_velocity_mm_s=tuple(a.max_velocity_mm_s for a in config.axes),
            axis_accel_mm_s2=tuple(a.max_accel_mm_s2 for a in config.axes),
            max_linear_velocity_mm_s=config.rapid_mm_s,
            task_cycle_s=MACHINE_TASK_CYCLE_S, io_cycle_s=MACHINE_IO_CYCLE_S)
    return s if s.servo_period_s == config.period_s else dataclasses.replace(s, servo_period_s=config.period_s)
