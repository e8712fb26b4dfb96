"""The machine file's value checks, shared by the loader (ipo.config) and the sections it
delegates (ipo.grbl_settings): the documented ranges, and the error that names the key."""
from __future__ import annotations

import math
from typing import Any

# key pattern (an axis, tool or work offset name as *) -> inclusive (low, high) and why the bounds
RANGES: dict[str, tuple[float, float, str]] = {
    "period_s": (1e-5, 0.1, "10 us (a fast FPGA loop) to 100 ms"),
    "blu_mm": (1e-6, 0.01, "1 nm to 10 um"),
    "chord_tol_mm": (1e-6, 1.0, "1 nm to 1 mm"),
    "g64_blend_tol_mm": (0.0, 10.0, "0 (no blending) to 10 mm"),
    "rapid_mm_s": (0.01, 1e4, "0.6 mm/min to 600 m/min"),
    "axes.*.max_velocity_mm_s": (0.01, 1e4, "0.6 mm/min to 600 m/min"),
    "axes.*.max_accel_mm_s2": (1.0, 1e6, "1 mm/s^2 to about 100 g"),
    "axes.*.max_jerk_mm_s3": (10.0, 1e9, "10 mm/s^3 to 1e9 mm/s^3"),
    "axes.*.min_mm": (-1e5, 1e5, "within 100 m of the origin"),
    "axes.*.max_mm": (-1e5, 1e5, "within 100 m of the origin"),
    "work_offsets_mm.*": (-1e5, 1e5, "within 100 m of the origin"),
    "tools.*.length_mm": (-1000.0, 1000.0, "up to 1 m either way"),
    "tools.*.ball_radius_mm": (0.0, 100.0, "0 (flat end mill) to 100 mm"),
    "tools.*.flutes": (1, 100, "1 to 100"),
    "tools.*.diameter_mm": (0.0, 200.0, "0 (from ball_radius_mm) to 200 mm"),
    "tools.*.corner_radius_mm": (0.0, 100.0, "0 to 100 mm"),
    "stock.min_mm": (-1e5, 1e5, "within 100 m of the origin"),
    "stock.max_mm": (-1e5, 1e5, "within 100 m of the origin"),
    "finishing.pick_feed_mm": (1e-4, 100.0, "0.1 um to 100 mm (and below the ball diameter)"),
    "finishing.roughness_target_um": (1e-3, 1e3, "1 nm to 1 mm"),
    "servo.time_constant_s": (0.0, 1.0, "0 to 1 s"),
    "servo.kp_1_s": (0.0, 1e4, "0 to 10,000 1/s"),
    "servo.kd": (0.0, 100.0, "0 to 100"),
    "grbl.baud": (300, 1e7, "300 baud to 10 Mbaud (a board with native USB)"),
}


def range_key(key: str) -> str:
    """The RANGES pattern of a key: its axis, tool or work offset name replaced by *."""
    parts = key.split(".")
    if parts[0] in ("axes", "tools") and len(parts) == 3:
        parts[1] = "*"
    elif parts[0] == "work_offsets_mm" and len(parts) == 2:
        parts[1] = "*"
    return ".".join(parts)


class ConfigError(ValueError):
    """A bad machine configuration; the message starts with the key."""

    def __init__(self, key: str, message: str):
        self.key = key
        super().__init__(f"{key}: {message}")


def take(table: dict, key: str, prefix: str) -> Any:
    if key not in table:
        raise ConfigError(prefix + key, "missing")
    return table[key]


def number(value: Any, key: str, *, positive: bool = False, nonneg: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(key, f"must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ConfigError(key, f"must be > 0, got {value!r}")
    if nonneg and value < 0:
        raise ConfigError(key, f"must be >= 0, got {value!r}")
    if (bounds := RANGES.get(range_key(key))) is not None and not bounds[0] <= value <= bounds[1]:
        low, high, why = bounds
        raise ConfigError(key, f"must be between {low:g} and {high:g} ({why}), got {value!r}")
    return float(value)


def choice(value: Any, key: str, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ConfigError(key, f"must be one of {', '.join(choices)}, got {value!r}")
    return value


def no_extra(table: dict, allowed: set[str], prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise ConfigError(prefix + str(key), "unknown key")
