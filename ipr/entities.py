"""Motion entities and events: what the interpreter hands to the interpolator.

Everything here is in machine coordinates and millimetres: work offsets (G54–G59,
G92), tool length offsets (G43) and inch units (G20) are already applied, so a
consumer never sees a program's units or offsets. Feeds are in mm/s.

The types are small, immutable and stable: ipo/ and machine/ depend on them.
Every item carries `line`, the 1-based source line of the block that produced it
(for a NURBS group, the line of its first block), and `file`: None for the program
itself, the path of the subroutine file (ipr.program_counter) for the lines of one.
"""
from __future__ import annotations

from collections import deque
from dataclasses import MISSING, dataclass, field, fields
from itertools import compress, repeat
from operator import is_
from typing import Literal, Union

import numpy as np

Vec3 = tuple[float, float, float]
Plane = Literal["XY", "ZX", "YZ"]

# Index of the two in-plane axes and the normal axis for each plane, RS274NGC
# orientation: G18's first axis is Z, so a CCW arc in ZX turns from +Z to +X.
PLANE_AXES: dict[str, tuple[int, int, int]] = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}


class FromFile:
    """`file`: None for an entity of the program itself, the path of the subroutine file it
    came from otherwise (set by ipr.program_counter with `set_file`). A slot outside the
    dataclass fields, so that constructing an entity costs no more (the IPO builds millions)."""

    __slots__ = ("_file",)

    @property
    def file(self) -> str | None:
        return getattr(self, "_file", None)


def quick_init(cls):
    """Give a frozen slots dataclass an __init__ that sets its slots through their descriptors.
    The generated one calls object.__setattr__ per field, which makes a Line cost 2.5 times
    as much to build, and the interpreter builds one per line of a CAM program. Same
    signature and defaults, so keywords and dataclasses.replace work as before."""
    names = [f.name for f in fields(cls)]
    scope = {f"_set_{n}": cls.__dict__[n].__set__ for n in names}
    scope.update({f"_default_{f.name}": f.default for f in fields(cls) if f.default is not MISSING})
    params = ", ".join(f"{n}=_default_{n}" if f"_default_{n}" in scope else n for n in names)
    body = "".join(f"    _set_{n}(self, {n})\n" for n in names)
    exec(f"def __init__(self, {params}):\n{body}", scope)
    cls.__init__ = scope["__init__"]
    cls._setters = tuple(scope[f"_set_{n}"] for n in names)
    return cls


def build_many(cls, count: int, *columns) -> list:
    """list(map(cls, *columns)) for a quick_init class given every field, `count` objects long,
    built without a Python call per object (the slots are set column by column through their
    descriptors): a run of plain lines (ipr.plain_runs) makes thousands of Lines at once."""
    objs = list(map(object.__new__, repeat(cls, count)))
    for setter, column in zip(cls._setters, columns, strict=True):
        deque(map(setter, objs, column), 0)
    return objs


def set_file(entity, file: str) -> None:
    """Mark an entity as coming from a subroutine file (entities are otherwise immutable)."""
    object.__setattr__(entity, "_file", file)


@dataclass(frozen=True, slots=True)
class PathControl:
    """G61/G61.1 exact stop, or G64 continuous with optional P blend and Q merge tolerances.
    `exact_path` tells G61 (LinuxCNC's exact path: its planner may still run through joints it
    finds tangent) from G61.1 (exact stop at every joint); `startup` marks the mode a program
    runs in before it programs G61, G61.1 or G64 (continuous, as LinuxCNC starts; its canned
    cycles then restore its canon's start-up blend tolerance, 0.001 in, after themselves)."""

    exact_stop: bool = False
    blend_tol_mm: float | None = None
    merge_tol_mm: float | None = None
    exact_path: bool = False
    startup: bool = False


EXACT_STOP = PathControl(exact_stop=True)
EXACT_PATH = PathControl(exact_stop=True, exact_path=True)
CONTINUOUS = PathControl(startup=True)


@quick_init
@dataclass(frozen=True, slots=True)
class Rapid(FromFile):
    """G0: straight traverse at the machine's rapid rate."""

    line: int
    start: Vec3
    end: Vec3
    path: PathControl = CONTINUOUS

    feed_mm_s = None


@quick_init
@dataclass(frozen=True, slots=True)
class Line(FromFile):
    """G1: straight feed move."""

    line: int
    start: Vec3
    end: Vec3
    feed_mm_s: float
    path: PathControl = CONTINUOUS


@quick_init
@dataclass(frozen=True, slots=True)
class Arc(FromFile):
    """G2/G3: circular (or helical) feed move.

    `center` lies in the plane of `start` (its normal-axis coordinate equals the
    start's); the normal-axis travel from start to end is the helix. `turns` counts
    the extra full revolutions (P word), 0 for an ordinary arc. A full circle has
    end == start in the plane and sweeps 2*pi.
    """

    line: int
    start: Vec3
    end: Vec3
    center: Vec3
    plane: Plane
    ccw: bool
    feed_mm_s: float
    turns: int = 0
    path: PathControl = CONTINUOUS

    @property
    def radius_mm(self) -> float:
        a, b, _ = PLANE_AXES[self.plane]
        return float(np.hypot(self.start[a] - self.center[a], self.start[b] - self.center[b]))

    @property
    def sweep_rad(self) -> float:
        """Signed angle swept in the plane (positive = CCW), including full turns."""
        a, b, _ = PLANE_AXES[self.plane]
        a0 = np.arctan2(self.start[b] - self.center[b], self.start[a] - self.center[a])
        a1 = np.arctan2(self.end[b] - self.center[b], self.end[a] - self.center[a])
        if self.ccw:
            sweep = (a1 - a0) % (2 * np.pi)
            sweep = sweep if sweep > 1e-12 else 2 * np.pi
        else:
            sweep = -((a0 - a1) % (2 * np.pi))
            sweep = sweep if sweep < -1e-12 else -2 * np.pi
        return float(sweep + np.copysign(2 * np.pi * self.turns, sweep))


@dataclass(frozen=True, slots=True, eq=False)
class Nurbs(FromFile):
    """A NURBS curve: G06.2 (Fanuc), G6.2 and G5.2 (LinuxCNC) all become this.

    `knots` has len(points) + degree + 1 entries, clamped (first and last repeated
    degree + 1 times), so the curve starts at points[0] == start and ends at
    points[-1] == end. `points` is (n, 3) in mm, `weights` (n,) all > 0.
    Arrays are read-only.
    """

    line: int
    degree: int
    knots: np.ndarray
    weights: np.ndarray
    points: np.ndarray
    feed_mm_s: float
    path: PathControl = CONTINUOUS

    @property
    def start(self) -> Vec3:
        return tuple(float(c) for c in self.points[0])

    @property
    def end(self) -> Vec3:
        return tuple(float(c) for c in self.points[-1])


@dataclass(frozen=True, slots=True)
class Dwell(FromFile):
    """G4 P: stand still for `seconds`."""

    line: int
    seconds: float


Motion = Union[Rapid, Line, Arc, Nurbs]


@dataclass(frozen=True, slots=True)
class Spindle(FromFile):
    """M3/M4/M5 with S: `rpm` is the programmed speed, direction None means stopped."""

    line: int
    rpm: float
    direction: Literal["cw", "ccw"] | None


@dataclass(frozen=True, slots=True)
class Coolant(FromFile):
    """M7/M8/M9."""

    line: int
    mist: bool
    flood: bool


@dataclass(frozen=True, slots=True)
class ToolChange(FromFile):
    """M6 with T."""

    line: int
    tool: int


@dataclass(frozen=True, slots=True)
class Message(FromFile):
    """(MSG, ...) comment."""

    line: int
    text: str


@dataclass(frozen=True, slots=True)
class Stop(FromFile):
    """M0 (optional=False) or M1 (optional=True) program stop."""

    line: int
    optional: bool


@dataclass(frozen=True, slots=True)
class ProgramEnd(FromFile):
    """M2 or M30."""

    line: int


@dataclass(frozen=True, slots=True)
class Auxiliary(FromFile):
    """A code the virtual machine records and passes on without acting on it: M19 spindle
    orient, M48..M53 override switches, M61 tool number, M62..M68 digital and analog I/O,
    G96/G97 spindle speed mode, the machine file's M100..M199, a dialect's bookkeeping
    M-codes. `code` as written ("M64", "G96"), `text` says what it does."""

    line: int
    code: str
    text: str


Event = Union[Spindle, Coolant, ToolChange, Message, Stop, ProgramEnd, Auxiliary]
Entity = Union[Rapid, Line, Arc, Nurbs, Dwell, Spindle, Coolant, ToolChange, Message, Stop, ProgramEnd,
               Auxiliary]

MOTION_TYPES = (Rapid, Line, Arc, Nurbs)


def group_by_type(entities: list) -> dict[type, list]:
    """The entities of each type, in order (C-level passes: a consumer of million-entity
    programs must not spend a Python loop per entity on sorting them)."""
    types = list(map(type, entities))
    kinds = set(types)
    if len(kinds) == 1:
        return {types[0]: entities}
    return {cls: list(compress(entities, map(is_, types, repeat(cls)))) for cls in kinds}


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """An error or warning tied to a place in the source."""

    file: str
    line: int
    col: int
    code: str
    message: str
    severity: Literal["error", "warning", "notice"] = "error"

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}: {self.severity}[{self.code}]: {self.message}"


class GCodeError(Exception):
    """The interpreter's only exception type: one or more diagnostics."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = diagnostics
        super().__init__("\n".join(str(d) for d in diagnostics))


@dataclass(slots=True)
class Program:
    """A whole interpreted program: entities in execution order plus notices."""

    file: str
    entities: list[Entity] = field(default_factory=list)
    warnings: list[Diagnostic] = field(default_factory=list)
    program_number: int | None = None  # the O word, if the program has one

    def motions(self) -> list[Motion]:
        return [e for e in self.entities if isinstance(e, MOTION_TYPES)]
