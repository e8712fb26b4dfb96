"""Machine configuration: a TOML file read once into typed, validated dataclasses.

The documented default is `ipo/machine.toml` (linked as `programs/machine.toml`);
`default_config()` reads that same file, so the two can never disagree.
Every bad value raises ConfigError naming the offending key; every number must lie in its
key's physically sensible range (RANGES, documented in docs/machine-file.md), so that a value
the loader accepts is one the planner and the drive can run with.
"""
from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from ipo.config_values import RANGES, ConfigError, range_key  # noqa: F401 (the loader's public names)
from ipo.config_values import choice as _choice
from ipo.config_values import no_extra as _no_extra
from ipo.config_values import number as _number
from ipo.config_values import take as _take
from ipo.grbl_settings import DEFAULT_GRBL_BAUD, GrblSettings, machine_file_keys
from ipo.linuxcnc_ini import LinuxcncSettings, with_ini
from ipo.linuxcnc_ini import machine_file_keys as linuxcnc_keys

# NURBS interpolators that can follow a feed profile (constant du cannot: it is for `vcnc interp` studies)
METHODS = ("recursive", "taylor1", "taylor2")
ACCEL_MODES = ("trapezoid", "scurve")
SERVO_MODELS = ("none", "lag", "pd")
TOOL_SHAPES = ("flat", "ball", "bull")
AXIS_NAMES = ("x", "y", "z")
WORK_OFFSET_NAMES = tuple(f"G{n}" for n in range(54, 60)) + ("G59.1", "G59.2", "G59.3")
DIALECTS = ("linuxcnc", "fanuc", "haas", "mach3", "grbl")
# planner profiles: the machine file's `planner` -> the ipo.feed module whose `plan_periods` runs it
# (ipo.feed.profiles imports it); a controller twin joins with one entry here
PLANNERS = {
    "vcnc": "ipo.feed.planner",
    "grbl": "ipo.feed.grbl_twin.twin",
    "linuxcnc": "ipo.feed.linuxcnc_twin.planner",
}


@dataclass(frozen=True, slots=True)
class AxisLimits:
    max_velocity_mm_s: float
    max_accel_mm_s2: float
    max_jerk_mm_s3: float
    min_mm: float
    max_mm: float


@dataclass(frozen=True, slots=True)
class Tool:
    length_mm: float = 0.0
    ball_radius_mm: float = 0.0  # 0 for a flat end mill
    flutes: int = 2
    shape: str = ""  # flat | ball | bull; "" = ball if ball_radius_mm > 0, else flat
    diameter_mm: float = 0.0  # 0 = 2 * ball_radius_mm
    corner_radius_mm: float = 0.0  # bull nose only


@dataclass(frozen=True, slots=True)
class Finishing:
    """002's roughness limiter settings; `tool` is a key of MachineConfig.tools."""

    tool: int
    pick_feed_mm: float
    roughness_target_um: float | Literal["isotropic"] = "isotropic"


@dataclass(frozen=True, slots=True)
class Servo:
    model: Literal["none", "lag", "pd"] = "none"
    time_constant_s: float = 0.0
    kp_1_s: float = 0.0
    kd: float = 0.0


@dataclass(frozen=True, slots=True)
class MachineConfig:
    period_s: float
    blu_mm: float
    chord_tol_mm: float
    g64_blend_tol_mm: float
    method: str
    axes: tuple[AxisLimits, AxisLimits, AxisLimits]
    rapid_mm_s: float
    work_offsets_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    tools: dict[int, Tool] = field(default_factory=dict)
    finishing: Finishing | None = None
    servo: Servo = Servo()
    accel_mode: Literal["trapezoid", "scurve"] = "trapezoid"
    dialect: str = "linuxcnc"    # ipr.dialect: what posts of other controls write
    g28_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)   # G28/G30 stored positions at start (machine)
    g30_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    user_mcodes: dict[int, str] = field(default_factory=dict)   # M100..M199 the machine has
    # the interpreter's (ipr.Setup): subroutine file folders, loop limit, Fanuc M99 endless repeat
    subroutine_path: tuple[str, ...] = ()
    max_loop_iterations: int = 10_000_000
    m99_repeat: bool = False
    stock_mm: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None  # (min, max), work coords
    planner: str = "vcnc"  # a key of PLANNERS: whose motion planning a run reproduces
    grbl_settings: GrblSettings | None = None  # the grbl twin's `$$` (None: from the axes, ipo.grbl_settings)
    grbl_baud: int = DEFAULT_GRBL_BAUD  # the grbl twin's serial link
    linuxcnc_ini: LinuxcncSettings | None = None  # the LinuxCNC twin's INI file (ipo.linuxcnc_ini)


def _axis(table: Any, name: str) -> AxisLimits:
    prefix = f"axes.{name}."
    if not isinstance(table, dict):
        raise ConfigError(f"axes.{name}", "must be a table")
    fields = ("max_velocity_mm_s", "max_accel_mm_s2", "max_jerk_mm_s3")
    _no_extra(table, set(fields) | {"min_mm", "max_mm"}, prefix)
    vals = [_number(_take(table, f, prefix), prefix + f, positive=True) for f in fields]
    lo = _number(_take(table, "min_mm", prefix), prefix + "min_mm")
    hi = _number(_take(table, "max_mm", prefix), prefix + "max_mm")
    if lo >= hi:
        raise ConfigError(prefix + "max_mm", f"must exceed min_mm ({lo}), got {hi}")
    return AxisLimits(*vals, lo, hi)


def _tools(table: Any) -> dict[int, Tool]:
    if not isinstance(table, dict):
        raise ConfigError("tools", "must be a table")
    tools = {}
    for key, t in table.items():
        prefix = f"tools.{key}."
        if not str(key).isdigit():
            raise ConfigError(f"tools.{key}", "tool numbers must be non-negative integers")
        if not isinstance(t, dict):
            raise ConfigError(f"tools.{key}", "must be a table")
        _no_extra(t, {"length_mm", "ball_radius_mm", "flutes", "shape", "diameter_mm",
                      "corner_radius_mm"}, prefix)
        flutes = t.get("flutes", 2)
        if isinstance(flutes, bool) or not isinstance(flutes, int):
            raise ConfigError(prefix + "flutes", f"must be an integer, got {flutes!r}")
        _number(flutes, prefix + "flutes")
        tools[int(key)] = _tool_shape(Tool(
            _number(t.get("length_mm", 0.0), prefix + "length_mm"),
            _number(t.get("ball_radius_mm", 0.0), prefix + "ball_radius_mm", nonneg=True), flutes,
            _choice(t["shape"], prefix + "shape", TOOL_SHAPES) if "shape" in t else "",
            _number(t.get("diameter_mm", 0.0), prefix + "diameter_mm", nonneg=True),
            _number(t.get("corner_radius_mm", 0.0), prefix + "corner_radius_mm", nonneg=True)), prefix)
    return tools


def _tool_shape(tool: Tool, prefix: str) -> Tool:
    """Resolve the shape: ball_radius_mm alone is a ball (the old table), a ball's radius and diameter agree."""
    shape = tool.shape or ("ball" if tool.ball_radius_mm > 0 else "flat")
    diameter = tool.diameter_mm or 2.0 * tool.ball_radius_mm
    if shape == "ball":
        if tool.ball_radius_mm and tool.diameter_mm and abs(tool.diameter_mm - 2 * tool.ball_radius_mm) > 1e-9:
            raise ConfigError(prefix + "diameter_mm", f"a ball's diameter is twice ball_radius_mm "
                                                      f"({tool.ball_radius_mm}), got {tool.diameter_mm}")
        if diameter <= 0:
            raise ConfigError(prefix + "diameter_mm", "a ball needs diameter_mm or ball_radius_mm")
        return dataclasses.replace(tool, ball_radius_mm=diameter / 2.0, shape=shape, diameter_mm=diameter)
    if tool.ball_radius_mm > 0:
        raise ConfigError(prefix + "ball_radius_mm", f"only a ball has a ball radius (shape = {shape!r})")
    if shape == "bull" and not 0 < tool.corner_radius_mm <= diameter / 2.0:
        raise ConfigError(prefix + "corner_radius_mm", f"a bull nose needs 0 < corner_radius_mm <= diameter_mm/2 "
                                                       f"({diameter / 2.0}), got {tool.corner_radius_mm}")
    if shape == "flat" and tool.corner_radius_mm:
        raise ConfigError(prefix + "corner_radius_mm", "a flat end mill has no corner radius (use shape = 'bull')")
    return dataclasses.replace(tool, shape=shape, diameter_mm=diameter)


def _stock(table: Any) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    if not isinstance(table, dict):
        raise ConfigError("stock", "must be a table with min_mm and max_mm")
    _no_extra(table, {"min_mm", "max_mm"}, "stock.")
    corners = []
    for key in ("min_mm", "max_mm"):
        v = _take(table, key, "stock.")
        if not isinstance(v, list) or len(v) != 3:
            raise ConfigError("stock." + key, f"must be a list of 3 numbers, got {v!r}")
        corners.append(tuple(_number(c, "stock." + key) for c in v))
    if not all(lo < hi for lo, hi in zip(*corners)):
        raise ConfigError("stock.max_mm", f"must exceed min_mm {list(corners[0])} on every axis, got {list(corners[1])}")
    return corners[0], corners[1]


def _work_offsets(table: Any) -> dict[str, tuple[float, float, float]]:
    if not isinstance(table, dict):
        raise ConfigError("work_offsets_mm", "must be a table")
    out = {}
    for key, v in table.items():
        k = f"work_offsets_mm.{key}"
        if key not in WORK_OFFSET_NAMES:
            raise ConfigError(k, f"must be one of {', '.join(WORK_OFFSET_NAMES)}")
        if not isinstance(v, list) or len(v) != 3:
            raise ConfigError(k, f"must be a list of 3 numbers, got {v!r}")
        out[key] = tuple(_number(c, k) for c in v)
    return out


def _position(v: Any, key: str) -> tuple[float, float, float]:
    if not isinstance(v, list) or len(v) != 3:
        raise ConfigError(key, f"must be a list of 3 numbers, got {v!r}")
    return tuple(_number(c, key) for c in v)


def _user_mcodes(table: Any) -> dict[int, str]:
    """user_mcodes: "M100" = "what it does", for M100..M199."""
    if not isinstance(table, dict):
        raise ConfigError("user_mcodes", "must be a table")
    out = {}
    for key, text in table.items():
        number = str(key).upper().removeprefix("M")
        if not number.isdigit() or not 100 <= int(number) <= 199 or not isinstance(text, str):
            raise ConfigError(f"user_mcodes.{key}", "keys are M100..M199, values describe the code")
        out[int(number)] = text
    return out


def _finishing(table: Any, tools: dict[int, Tool]) -> Finishing:
    if not isinstance(table, dict):
        raise ConfigError("finishing", "must be a table")
    _no_extra(table, {"tool", "pick_feed_mm", "roughness_target_um"}, "finishing.")
    tool = _take(table, "tool", "finishing.")
    if isinstance(tool, bool) or not isinstance(tool, int) or tool not in tools:
        raise ConfigError("finishing.tool", f"must name a tool of the [tools] table, got {tool!r}")
    if tools[tool].ball_radius_mm <= 0:
        raise ConfigError("finishing.tool", f"tool {tool} has no ball radius (tools.{tool}.ball_radius_mm)")
    pick = _number(_take(table, "pick_feed_mm", "finishing."), "finishing.pick_feed_mm", positive=True)
    if pick >= 2 * tools[tool].ball_radius_mm:
        raise ConfigError("finishing.pick_feed_mm", f"must be below the ball diameter, got {pick}")
    target = table.get("roughness_target_um", "isotropic")
    if target != "isotropic":
        target = _number(target, "finishing.roughness_target_um", positive=True)
        _reachable(tools[tool].ball_radius_mm, pick, target)
    return Finishing(tool, pick, target)


def _reachable(ball_mm: float, pick_mm: float, target_um: float) -> None:
    """A roughness target that the ball and pick feed cannot reach at some feed inclination
    is refused here, not when the planner first meets it."""
    import numpy as np

    from ipo.roughness import feed_per_tooth_mm

    try:
        feed_per_tooth_mm(ball_mm, pick_mm, target_um * 1e-3, np.linspace(0.0, 0.5 * math.pi, 91))
    except ValueError as err:
        raise ConfigError("finishing.roughness_target_um", str(err)) from None


def _servo(table: Any) -> Servo:
    if not isinstance(table, dict):
        raise ConfigError("servo", "must be a table")
    _no_extra(table, {"model", "time_constant_s", "kp_1_s", "kd"}, "servo.")
    model = _choice(table.get("model", "none"), "servo.model", SERVO_MODELS)
    servo = Servo(model, *(_number(table.get(k, 0.0), "servo." + k, nonneg=True)
                           for k in ("time_constant_s", "kp_1_s", "kd")))
    if model == "lag" and servo.time_constant_s <= 0:
        raise ConfigError("servo.time_constant_s", "must be > 0 for model = 'lag'")
    if model == "pd" and servo.kp_1_s <= 0:
        raise ConfigError("servo.kp_1_s", "must be > 0 for model = 'pd'")
    return servo


def config_from_dict(data: dict, base: Path | None = None) -> MachineConfig:
    """Validate a parsed TOML document into a MachineConfig (files it names are relative to `base`)."""
    top = {"period_s", "blu_mm", "chord_tol_mm", "g64_blend_tol_mm", "method", "rapid_mm_s",
           "accel_mode", "axes", "work_offsets_mm", "tools", "finishing", "servo", "subroutine_path",
           "max_loop_iterations", "m99_repeat", "dialect", "g28_mm", "g30_mm", "user_mcodes", "stock",
           "planner", "grbl", "linuxcnc"}
    _no_extra(data, top, "")
    axes_table = _take(data, "axes", "")
    if not isinstance(axes_table, dict):
        raise ConfigError("axes", "must be a table with x, y and z")
    _no_extra(axes_table, set(AXIS_NAMES), "axes.")
    axes = tuple(_axis(_take(axes_table, a, "axes."), a) for a in AXIS_NAMES)
    tools = _tools(data.get("tools", {}))
    period = _number(_take(data, "period_s", ""), "period_s", positive=True)
    blu = _number(_take(data, "blu_mm", ""), "blu_mm", positive=True)
    config = MachineConfig(
        period_s=period,
        blu_mm=blu,
        chord_tol_mm=_number(_take(data, "chord_tol_mm", ""), "chord_tol_mm", positive=True),
        g64_blend_tol_mm=_number(data.get("g64_blend_tol_mm", 0.0), "g64_blend_tol_mm", nonneg=True),
        method=_choice(data.get("method", "recursive"), "method", METHODS),
        axes=axes,
        rapid_mm_s=_number(_take(data, "rapid_mm_s", ""), "rapid_mm_s", positive=True),
        work_offsets_mm=_work_offsets(data.get("work_offsets_mm", {})),
        tools=tools,
        finishing=_finishing(data["finishing"], tools) if "finishing" in data else None,
        servo=_servo(data.get("servo", {})),
        accel_mode=_choice(data.get("accel_mode", "trapezoid"), "accel_mode", ACCEL_MODES),
        dialect=_choice(data.get("dialect", "linuxcnc"), "dialect", DIALECTS),
        g28_mm=_position(data.get("g28_mm", [0.0, 0.0, 0.0]), "g28_mm"),
        g30_mm=_position(data.get("g30_mm", [0.0, 0.0, 0.0]), "g30_mm"),
        user_mcodes=_user_mcodes(data.get("user_mcodes", {})),
        **_interpreter_keys(data),
        stock_mm=_stock(data["stock"]) if "stock" in data else None,
        planner=_choice(data.get("planner", "vcnc"), "planner", tuple(PLANNERS)),
        **machine_file_keys(data.get("grbl", {}), base),
    )
    ini = linuxcnc_keys(data.get("linuxcnc", {}), base)
    # a LinuxCNC INI file describes the machine: its servo period and axis limits replace these
    return with_ini(config, ini["linuxcnc_ini"]) if ini else config


def _interpreter_keys(data: dict) -> dict:
    path = data.get("subroutine_path", [])
    if not isinstance(path, list) or not all(isinstance(p, str) for p in path):
        raise ConfigError("subroutine_path", f"must be a list of folder names, got {path!r}")
    limit = data.get("max_loop_iterations", 10_000_000)
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise ConfigError("max_loop_iterations", f"must be a whole number >= 1, got {limit!r}")
    repeat = data.get("m99_repeat", False)
    if not isinstance(repeat, bool):
        raise ConfigError("m99_repeat", f"must be true or false, got {repeat!r}")
    return {"subroutine_path": tuple(path), "max_loop_iterations": limit, "m99_repeat": repeat}


def with_period(config: MachineConfig, period_s: float) -> MachineConfig:
    """config with another interpolation period, checked like the file's (a command-line override)."""
    return dataclasses.replace(config, period_s=_number(period_s, "period_s", positive=True))


def load_config(path: str | Path) -> MachineConfig:
    """Read and validate a machine TOML file."""
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), f"not valid TOML: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), f"not valid TOML: not UTF-8 text (byte {exc.start})") from exc
    config = config_from_dict(data, Path(path).parent)
    # subroutine folders are relative to the machine file, as LinuxCNC's are to its INI file
    folders = tuple(str(Path(path).parent / p) for p in config.subroutine_path)
    return dataclasses.replace(config, subroutine_path=folders)


def default_config() -> MachineConfig:
    """The documented default, read from the packaged machine.toml."""
    with resources.files("ipo").joinpath("machine.toml").open("rb") as fh:
        return config_from_dict(tomllib.load(fh))
