"""A LinuxCNC 2.9 machine as its INI file describes it, for the LinuxCNC twin
(ipo.feed.linuxcnc_twin), read as LinuxCNC reads it.

LinuxCNC plans coordinated motion with the [AXIS_*] limits (the canon layer projects them on
each move, the planner bounds its blend arcs with them), [TRAJ]MAX_LINEAR_VELOCITY (a cap on
every move, rapids included), the [TRAJ] arc-blend keys and [DISPLAY]MAX_FEED_OVERRIDE (blends
are sized for the highest override); [TASK] and [EMCIO] CYCLE_TIME set how long task waits at
spindle, coolant and tool blocks. [JOINT_n] limits bound only jogging and homing in 2.9.

LinuxCNC's IniFile (src/libnml/inifile/inifile.cc) takes the first `[SECTION]` line, then the
first `KEY = value` line of that section (a line starting with anything else, `#` and `;`
comments included, is skipped; a trailing backslash continues a line); the loaders
(src/emc/ini/initraj.cc, iniaxis.cc) read a number from the start of the value. Read here:

- [EMCMOT]SERVO_PERIOD (ns): the planner's cycle;
- [TRAJ]COORDINATES, LINEAR_UNITS (mm, metric, in, inch, imperial), MAX_LINEAR_VELOCITY and
  the arc-blend keys ARC_BLEND_ENABLE, ARC_BLEND_OPTIMIZATION_DEPTH, ARC_BLEND_GAP_CYCLES,
  ARC_BLEND_RAMP_FREQ, ARC_BLEND_KINK_RATIO; [DISPLAY]MAX_FEED_OVERRIDE; [TASK]CYCLE_TIME and
  [EMCIO]CYCLE_TIME;
- [AXIS_X], [AXIS_Y], [AXIS_Z]: MAX_VELOCITY, MAX_ACCELERATION (and OFFSET_AV_RATIO, the share
  2.9 keeps back for external offsets), MIN_LIMIT and MAX_LIMIT;
- [JOINT_n]: MAX_VELOCITY, MAX_ACCELERATION are checked to be numbers if present.

LinuxCNC falls back to 1.0 mm/s and 1.0 mm/s^2 for an axis without limits, which no machine
means; here SERVO_PERIOD and the axis limits of X, Y and Z must be given, and a key that is
present must hold a number in range. Every refusal names the key (and the file and line).
The machine file names the INI file with `[linuxcnc] ini = "FILE"` (machine_file_keys); its
period and axis limits then replace the machine file's (`with_ini`), so that the drive checks
the motion against the limits LinuxCNC planned it with.
"""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ipo.config_values import ConfigError, no_extra

# LinuxCNC 2.9's defaults when the INI file does not name the key (src/emc/ini/initraj.cc)
DEFAULT_ARC_BLEND_ENABLE = True
DEFAULT_OPTIMIZATION_DEPTH = 50
DEFAULT_GAP_CYCLES = 4
DEFAULT_RAMP_FREQ_HZ = 100.0
DEFAULT_KINK_RATIO = 0.1
DEFAULT_MAX_FEED_OVERRIDE = 1.0
DEFAULT_TASK_CYCLE_S = 0.100  # [TASK]CYCLE_TIME (emccfg.h)
DEFAULT_IO_CYCLE_S = 0.100  # [EMCIO]CYCLE_TIME


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
    task_cycle_s: float = DEFAULT_TASK_CYCLE_S  # [TASK]CYCLE_TIME: task's loop
    io_cycle_s: float = DEFAULT_IO_CYCLE_S  # [EMCIO]CYCLE_TIME: iocontrol's loop (coolant, tools)
    source: str = "machine file"
    travel_mm: tuple[tuple[float, float] | None, ...] = (None, None, None)  # [AXIS_*]MIN_LIMIT, MAX_LIMIT

    @property
    def tangent_kink_ratio(self) -> float:
        """The kink ratio as the planner bounds it (tp.c tpGetTangentKinkRatio)."""
        return min(max(self.kink_ratio, 0.001), 0.7071)


_LINEAR_UNITS_MM = {"mm": 1.0, "metric": 1.0, "in": 25.4, "inch": 25.4, "imperial": 25.4}
_BOOL = {"true": 1, "yes": 1, "1": 1, "false": 0, "no": 0, "0": 0}
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?(?=\s|[#;]|$)")
_AXES = "XYZ"


class IniError(ConfigError):
    """A LinuxCNC INI file the twin cannot use; `key` reads `[SECTION]KEY`."""


def _sections(text: str) -> dict[str, dict[str, tuple[str, int]]]:
    """{section: {key: (value, line)}}, first occurrence of each (LinuxCNC's Find)."""
    out: dict[str, dict[str, tuple[str, int]]] = {}
    current = None
    pending, start = "", 0
    for no, raw in enumerate(text.splitlines(), 1):
        if raw.endswith("\\"):
            pending, start = pending + raw[:-1], start or no
            continue
        line, at = pending + raw, start or no
        pending, start = "", 0
        s = line.strip()
        if s.startswith("["):
            name = s[1:s.find("]")] if "]" in s else None
            current = out.setdefault(name, {}) if name and name not in out else None
            continue
        if current is None or not s or s[0] in "#;":
            continue
        m = re.match(r"([^\s=]+)\s*(=\s*(.*))?$", s)
        if m and m.group(1) not in current:
            current[m.group(1)] = ((m.group(3) or "").strip(), at)
    return out


class _Reader:
    def __init__(self, path: Path):
        self.path = path
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError as err:
            raise IniError(str(path), f"cannot read this LinuxCNC INI file: {err.strerror}") from None
        self.sections = _sections(text)

    def raw(self, section: str, key: str) -> tuple[str, int] | None:
        return self.sections.get(section, {}).get(key)

    def fail(self, section: str, key: str, message: str, line: int | None = None):
        where = f"{self.path}:{line}" if line else str(self.path)
        raise IniError(f"[{section}]{key}", f"{message} ({where})")

    def number(self, section: str, key: str, default: float | None, *, positive: bool = True,
               low: float | None = None, high: float | None = None) -> float:
        found = self.raw(section, key)
        if found is None:
            if default is None:
                self.fail(section, key, "missing: the twin needs it")
            return default
        text, line = found
        m = _NUMBER.match(text)
        if not m:
            self.fail(section, key, f"{text!r} is not a number", line)
        value = float(m.group(0))
        if not math.isfinite(value) or (positive and value <= 0):
            self.fail(section, key, f"{text} must be a finite number > 0", line)
        if (low is not None and value < low) or (high is not None and value > high):
            self.fail(section, key, f"{text} is outside {low:g}..{high:g}", line)
        return value

    def flag(self, section: str, key: str, default: bool) -> bool:
        found = self.raw(section, key)
        if found is None:
            return default
        text, line = found
        word = text.split()[0].lower() if text.split() else ""
        if word not in _BOOL:
            self.fail(section, key, f"{text!r} is not 0/1 (or TRUE/FALSE, YES/NO)", line)
        return bool(_BOOL[word])


def load_ini(path: str | Path) -> LinuxcncSettings:
    """The twin's settings from a LinuxCNC INI file; IniError names the first bad key."""
    r = _Reader(Path(path))
    units = r.raw("TRAJ", "LINEAR_UNITS")
    scale = 1.0
    if units is not None:
        word = units[0].split()[0].lower() if units[0].split() else ""
        if word not in _LINEAR_UNITS_MM:
            r.fail("TRAJ", "LINEAR_UNITS", f"{units[0]!r} is not mm, metric, in, inch or imperial", units[1])
        scale = _LINEAR_UNITS_MM[word]
    coords = r.raw("TRAJ", "COORDINATES")
    if coords is not None:
        missing = [a for a in _AXES if a not in coords[0].upper()]
        if missing:
            r.fail("TRAJ", "COORDINATES", f"{coords[0]!r} lacks {', '.join(missing)}: the twin runs X, Y and Z",
                   coords[1])
    period_ns = r.number("EMCMOT", "SERVO_PERIOD", None, low=1e4, high=1e8)
    vel, acc, travel = [], [], []
    for axis in _AXES:
        sec = f"AXIS_{axis}"
        ratio = r.number(sec, "OFFSET_AV_RATIO", 0.0, positive=False, low=0.0, high=0.9)
        vel.append(r.number(sec, "MAX_VELOCITY", None) * scale * (1 - ratio))
        acc.append(r.number(sec, "MAX_ACCELERATION", None) * scale * (1 - ratio))
        lo = r.number(sec, "MIN_LIMIT", math.nan, positive=False, low=-1e5, high=1e5)
        hi = r.number(sec, "MAX_LIMIT", math.nan, positive=False, low=-1e5, high=1e5)
        travel.append(None if math.isnan(lo) or math.isnan(hi) else (lo * scale, hi * scale))
        if travel[-1] is not None and not lo < hi:
            r.fail(sec, "MAX_LIMIT", f"{hi:g} is not above MIN_LIMIT {lo:g}", r.raw(sec, "MAX_LIMIT")[1])
    for j in range(len(r.sections)):
        if f"JOINT_{j}" in r.sections:
            for key in ("MAX_VELOCITY", "MAX_ACCELERATION"):
                r.number(f"JOINT_{j}", key, 1.0)
    return LinuxcncSettings(
        servo_period_s=period_ns * 1e-9,
        axis_velocity_mm_s=tuple(vel),
        axis_accel_mm_s2=tuple(acc),
        max_linear_velocity_mm_s=r.number("TRAJ", "MAX_LINEAR_VELOCITY", math.inf) * scale,
        arc_blend_enable=r.flag("TRAJ", "ARC_BLEND_ENABLE", DEFAULT_ARC_BLEND_ENABLE),
        optimization_depth=int(r.number("TRAJ", "ARC_BLEND_OPTIMIZATION_DEPTH", DEFAULT_OPTIMIZATION_DEPTH,
                                        positive=False, low=0, high=10000)),
        gap_cycles=int(r.number("TRAJ", "ARC_BLEND_GAP_CYCLES", DEFAULT_GAP_CYCLES, positive=False, low=0,
                                high=1000)),
        ramp_freq_hz=r.number("TRAJ", "ARC_BLEND_RAMP_FREQ", DEFAULT_RAMP_FREQ_HZ, positive=False, low=0,
                              high=1e6),
        kink_ratio=r.number("TRAJ", "ARC_BLEND_KINK_RATIO", DEFAULT_KINK_RATIO),
        max_feed_override=r.number("DISPLAY", "MAX_FEED_OVERRIDE", DEFAULT_MAX_FEED_OVERRIDE),
        task_cycle_s=r.number("TASK", "CYCLE_TIME", DEFAULT_TASK_CYCLE_S, low=1e-4, high=10.0),
        io_cycle_s=r.number("EMCIO", "CYCLE_TIME", DEFAULT_IO_CYCLE_S, low=1e-4, high=10.0),
        source=str(path), travel_mm=tuple(travel))


def with_ini(config, s: LinuxcncSettings):
    """The machine configuration with the INI file's servo period and axis limits (its travel
    where MIN_LIMIT and MAX_LIMIT are given): LinuxCNC's machine, for every planner."""
    axes = tuple(dataclasses.replace(a, max_velocity_mm_s=v, max_accel_mm_s2=acc,
                                     **({"min_mm": t[0], "max_mm": t[1]} if t else {}))
                 for a, v, acc, t in zip(config.axes, s.axis_velocity_mm_s, s.axis_accel_mm_s2, s.travel_mm))
    return dataclasses.replace(config, period_s=s.servo_period_s, axes=axes, linuxcnc_ini=s)


def machine_file_keys(table: Any, base: Path | None) -> dict:
    """[linuxcnc]: the LinuxCNC twin's INI file (`ini`, relative to the machine file)."""
    if not isinstance(table, dict):
        raise ConfigError("linuxcnc", "must be a table")
    no_extra(table, {"ini"}, "linuxcnc.")
    if "ini" not in table:
        return {}
    name = table["ini"]
    if not isinstance(name, str) or not name:
        raise ConfigError("linuxcnc.ini", f"must name a LinuxCNC INI file, got {name!r}")
    try:
        return {"linuxcnc_ini": load_ini(Path(name) if base is None else base / name)}
    except IniError as err:
        raise ConfigError("linuxcnc.ini", str(err)) from None
