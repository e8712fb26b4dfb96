"""Which planner a run uses: the machine file's `planner` (or --planner), from the registry
ipo.config.PLANNERS via ipo.feed.profiles, with what machine must hand a twin.

The grbl twin plans what the board would receive, so it gets the grbl link's lines for the
program (machine.grbl.program.stream_groups, written in the G54 frame as the program's own
numbers; NURBS as the G1 segments vcnc's IPO plans) and the serial link's baud rate. A twin
that needs nothing but the entities runs as it is.
"""
from __future__ import annotations

import dataclasses
import functools
from typing import Callable

from ipo.config import PLANNERS, MachineConfig


def describe(config: MachineConfig) -> str:
    """The summary's name of the planner that ran."""
    if config.planner == "grbl":
        from ipo.feed.grbl_twin.twin import settings_of

        return f"grbl 1.1 twin: $$ of {settings_of(config).source}, {config.grbl_baud} baud"
    if config.planner == "linuxcnc":
        source = config.linuxcnc_ini.source if config.linuxcnc_ini else "the machine file's axes"
        return f"LinuxCNC 2.9 twin: {source}"
    return config.planner


def planner_for(config: MachineConfig, program, start_mm) -> Callable:
    """plan_periods for this program on the configured planner (the grbl twin: with the lines
    the grbl link would send it)."""
    if config.planner != "grbl":
        return plan_with_lines(config, ())
    return plan_with_lines(config, grbl_groups(program.entities, config, start_mm))


def grbl_groups(entities, config: MachineConfig, start_mm=(0.0, 0.0, 0.0)):
    """stream_groups of the entities as `vcnc stream` makes them for a board standing at start_mm
    after a reset: written in the G54 frame (the program's own numbers), the IPO planning from
    the start when there is a NURBS (as build_job does)."""
    from ipr.entities import Nurbs
    from machine.grbl.program import stream_groups
    from machine.grbl.words import Format

    entities = list(entities)
    frame = config.work_offsets_mm.get("G54", (0.0, 0.0, 0.0))
    return stream_groups(entities, config, start_mm=tuple(start_mm), fmt_=Format(tuple(frame), config.blu_mm / 10.0),
                         ipo_from_start=any(isinstance(e, Nurbs) for e in entities))


def plan_with_lines(config: MachineConfig, groups) -> Callable:
    """plan_periods of the configured planner; the grbl twin takes the stream's (entity, lines)
    groups (machine.grbl.program.stream_groups), any other planner ignores them."""
    from ipo.feed.profiles import plan_function

    plan = plan_function(config.planner)
    if config.planner == "grbl":
        from machine.grbl.wire import wire_lines

        plan = functools.partial(plan, wire=wire_lines(groups))
    return plan


def with_planner(config: MachineConfig, name: str | None, grbl_settings=None, linuxcnc_ini=None) -> MachineConfig:
    """config with a command line's --planner, --grbl-settings and --linuxcnc-ini (None: the
    file's); a LinuxCNC INI file also brings its servo period and axis limits (ipo.linuxcnc_ini)."""
    if name is not None and name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; choose one of {', '.join(PLANNERS)}")
    changes = {}
    if name is not None:
        changes["planner"] = name
    if grbl_settings is not None:
        changes["grbl_settings"] = grbl_settings
    out = dataclasses.replace(config, **changes) if changes else config
    if linuxcnc_ini is not None:
        from ipo.linuxcnc_ini import with_ini

        out = with_ini(out, linuxcnc_ini)
    return out
