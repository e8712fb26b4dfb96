"""grbl 1.1's `$$` settings, as far as its planner and stepper use them.

`read_dump` reads a `$$` printout exactly as grbl prints it (`$110=6000.000`, one per line;
the `ok` that ends it, blank lines and grbl 1.0's `(comment)` after a value are allowed);
any other line is refused naming its line. `from_machine` makes the settings a board
configured from the machine file would hold (`vcnc grbl settings --apply-machine` writes
$110-$122 that way); the rest are grbl's defaults (gnea/grbl defaults.h).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ipo.config_values import ConfigError, no_extra, number

# grbl 1.1's defaults for what the machine file does not say (defaults.h, DEFAULTS_GENERIC)
DEFAULT_JUNCTION_DEVIATION_MM = 0.010  # $11
DEFAULT_ARC_TOLERANCE_MM = 0.002  # $12
DEFAULT_IDLE_LOCK_MS = 25  # $1 (255: the steppers stay enabled, no wait)
DEFAULT_GRBL_BAUD = 115200
NEEDED = (11, 12, 100, 101, 102, 110, 111, 112, 120, 121, 122)
_LINE = re.compile(r"^\$(\d+)=(-?\d+(?:\.\d*)?)(?:\s+\(.*\))?$")


class GrblSettingsError(ValueError):
    """A `$$` dump that cannot be read; the message names the file and line."""


@dataclass(frozen=True, slots=True)
class GrblSettings:
    steps_per_mm: tuple[float, float, float]  # $100-$102
    max_rate_mm_min: tuple[float, float, float]  # $110-$112
    accel_mm_s2: tuple[float, float, float]  # $120-$122
    junction_deviation_mm: float  # $11
    arc_tolerance_mm: float  # $12
    laser_mode: bool = False  # $32: spindle changes during motion do not stop the planner
    idle_lock_ms: int = DEFAULT_IDLE_LOCK_MS  # $1: the stepper interrupt waits this long when motion stops
    source: str = "the machine file's axes"

    @property
    def idle_lock_s(self) -> float:
        """st_go_idle's wait inside the stepper interrupt when motion stops (none with $1=255)."""
        return 0.0 if self.idle_lock_ms == 255 else self.idle_lock_ms / 1000.0


def parse_dump(text: str, source: str) -> GrblSettings:
    """Settings from a `$$` printout; raises GrblSettingsError naming `source` and the line."""
    values: dict[int, float] = {}
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line == "ok":
            continue
        m = _LINE.match(line)
        if m is None:
            raise GrblSettingsError(f"{source}:{n}: not a grbl setting line ($N=value): {raw!r}")
        values[int(m.group(1))] = float(m.group(2))
    return from_values(values, source)


def from_values(values: dict[int, float], source: str) -> GrblSettings:
    """Settings from {N: value} (a board's `$$`, read by the link); raises GrblSettingsError."""
    missing = [f"${k}" for k in NEEDED if k not in values]
    if missing:
        raise GrblSettingsError(f"{source}: the dump lacks {', '.join(missing)} (save the whole `$$` answer)")
    for key in NEEDED:
        if not (math.isfinite(values[key]) and values[key] > 0):
            raise GrblSettingsError(f"{source}: ${key}={values[key]:g} must be > 0")
    return GrblSettings(tuple(values[k] for k in (100, 101, 102)), tuple(values[k] for k in (110, 111, 112)),
                        tuple(values[k] for k in (120, 121, 122)), values[11], values[12],
                        bool(values.get(32, 0.0)), int(values.get(1, DEFAULT_IDLE_LOCK_MS)), source)


def read_dump(path: str | Path) -> GrblSettings:
    try:
        text = Path(path).read_bytes().decode("ascii")
    except UnicodeDecodeError as err:
        raise GrblSettingsError(f"{path}: not a `$$` printout (byte {err.start} is not ASCII)") from None
    except OSError as err:
        raise GrblSettingsError(f"{path}: {err.strerror or err}") from None
    return parse_dump(text, str(path))


def from_machine(axes, blu_mm: float) -> GrblSettings:
    """What a board set up from the machine file holds: its rates and accelerations, one step
    per BLU, and grbl's default $11 and $12."""
    return GrblSettings(tuple(1.0 / blu_mm for _ in axes), tuple(a.max_velocity_mm_s * 60.0 for a in axes),
                        tuple(a.max_accel_mm_s2 for a in axes), DEFAULT_JUNCTION_DEVIATION_MM,
                        DEFAULT_ARC_TOLERANCE_MM)


def machine_file_keys(table: Any, base: Path | None) -> dict:
    """[grbl]: the grbl twin's `$$` dump (`settings`, relative to the machine file) and `baud`."""
    if not isinstance(table, dict):
        raise ConfigError("grbl", "must be a table")
    no_extra(table, {"settings", "baud"}, "grbl.")
    baud = number(table.get("baud", DEFAULT_GRBL_BAUD), "grbl.baud", positive=True)
    if not baud.is_integer():
        raise ConfigError("grbl.baud", f"must be a whole number, got {baud!r}")
    out = {"grbl_baud": int(baud)}
    if "settings" in table:
        name = table["settings"]
        if not isinstance(name, str) or not name:
            raise ConfigError("grbl.settings", f"must name a `$$` dump file, got {name!r}")
        try:
            out["grbl_settings"] = read_dump(Path(name) if base is None else base / name)
        except GrblSettingsError as err:
            raise ConfigError("grbl.settings", str(err)) from None
    return out
