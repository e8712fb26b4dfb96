"""Read a LinuxCNC 2.9 INI file into the twin's settings, as LinuxCNC reads it.

LinuxCNC's IniFile (src/libnml/inifile/inifile.cc) takes the first `[SECTION]` line, then the
first `KEY = value` line of that section (a line starting with anything else, `#` and `;`
comments included, is skipped; a trailing backslash continues a line); the loaders
(src/emc/ini/initraj.cc, iniaxis.cc) read a number from the start of the value. Read here:

- [EMCMOT]SERVO_PERIOD (ns): the planner's cycle;
- [TRAJ]COORDINATES, LINEAR_UNITS (mm, metric, in, inch, imperial), MAX_LINEAR_VELOCITY and
  the arc-blend keys ARC_BLEND_ENABLE, ARC_BLEND_OPTIMIZATION_DEPTH, ARC_BLEND_GAP_CYCLES,
  ARC_BLEND_RAMP_FREQ, ARC_BLEND_KINK_RATIO; [DISPLAY]MAX_FEED_OVERRIDE; [TASK]CYCLE_TIME and
  [EMCIO]CYCLE_TIME (how long task waits at spindle, coolant and tool blocks);
- [AXIS_X], [AXIS_Y], [AXIS_Z]: MAX_VELOCITY, MAX_ACCELERATION (and OFFSET_AV_RATIO, the share
  2.9 keeps back for external offsets);
- [JOINT_n]: MAX_VELOCITY, MAX_ACCELERATION are checked to be numbers if present; in 2.9 they
  bound jogging and homing, not coordinated motion.

LinuxCNC falls back to 1.0 mm/s and 1.0 mm/s^2 for an axis without limits, which no machine
means; here SERVO_PERIOD and the axis limits of X, Y and Z must be given, and a key that is
present must hold a number in range. Every refusal names the key (and the file and line).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

from ipo.config import ConfigError
from ipo.feed.linuxcnc_twin.settings import (DEFAULT_ARC_BLEND_ENABLE, DEFAULT_GAP_CYCLES, DEFAULT_IO_CYCLE_S,
                                             DEFAULT_KINK_RATIO, DEFAULT_MAX_FEED_OVERRIDE,
                                             DEFAULT_OPTIMIZATION_DEPTH, DEFAULT_RAMP_FREQ_HZ, DEFAULT_TASK_CYCLE_S,
                                             LinuxcncSettings)

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
            raise IniError("ini", f"cannot read the LinuxCNC INI file {path}: {err.strerror}") from None
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
    vel, acc = [], []
    for axis in _AXES:
        sec = f"AXIS_{axis}"
        ratio = r.number(sec, "OFFSET_AV_RATIO", 0.0, positive=False, low=0.0, high=0.9)
        vel.append(r.number(sec, "MAX_VELOCITY", None) * scale * (1 - ratio))
        acc.append(r.number(sec, "MAX_ACCELERATION", None) * scale * (1 - ratio))
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
        source=str(path))
