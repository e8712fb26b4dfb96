"""The interpreter's modal state, the machine set-up it reads, block staging, and the
conversion of axis words to machine coordinates.

A block is executed against a `Staged` view of the state: reads fall through to the
state, writes are kept aside and applied by `commit()` only when the whole block has
been accepted (grbl's discipline: an erroneous block changes nothing). Values are
replaced, never mutated in place (positions are tuples).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ipr import polar
from ipr.entities import CONTINUOUS, PathControl
from ipr.gcodes import FEED_PER_MINUTE
from ipr.parameters import Parameters

INCH_MM = 25.4
ZERO3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Setup:
    """What the interpreter needs from the machine configuration.

    work_offsets_mm: "G54".."G59" -> (x, y, z) machine position of the work zero
    (missing = zero). tool_lengths_mm: tool number -> length for G43 H (missing: a
    warning and a zero offset). block_delete: skip lines starting with "/".
    subroutine_path: folders searched for `<name>.ngc` subroutine files after the program's
    own folder. max_loop_iterations: loop iterations allowed over a whole run (E-LOOP-LIMIT).
    max_call_depth: nested calls allowed (E-CALL-DEPTH; rs274 refuses the 10th level).
    m99_repeat: M99 in the main program starts it again (Fanuc's endless repeat), else an error.
    start_*: the machine's state when the program starts (an axis the program never names
    stays at start_mm).
    """

    work_offsets_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    tool_lengths_mm: dict[int, float] = field(default_factory=dict)
    block_delete: bool = True
    tool_radii_mm: dict[int, float] = field(default_factory=dict)   # cutter compensation D
    g28_mm: tuple[float, float, float] = ZERO3   # stored positions (machine), G28.1/G30.1 change them
    g30_mm: tuple[float, float, float] = ZERO3
    user_mcodes: dict[int, str] = field(default_factory=dict)   # M100..M199 the machine names
    dialect: str = "linuxcnc"   # ipr.dialect
    subroutine_path: tuple[str, ...] = ()
    max_loop_iterations: int = 10_000_000
    max_call_depth: int = 9
    m99_repeat: bool = False
    # Where and in which modes the program starts (a controller's state before the program,
    # e.g. read from a grbl board): machine position, G54-G59 as 540..590, G92 offset,
    # tool length offset (Z), G20, G91, plane. The defaults are a machine at its zero.
    start_mm: tuple[float, float, float] = ZERO3
    start_coord: int = 540
    start_g92_mm: tuple[float, float, float] = ZERO3
    start_tool_offset_mm: float = 0.0
    start_inch: bool = False
    start_incremental: bool = False
    start_plane: str = "XY"

    @classmethod
    def from_machine(cls, config) -> Setup:
        """The Setup of a machine configuration (ipo.config.MachineConfig, duck-typed:
        `work_offsets_mm` and `tools` with `length_mm`; the other keys if it has them)."""
        tools = config.tools.items()
        return cls(work_offsets_mm=dict(config.work_offsets_mm),
                   tool_lengths_mm={n: t.length_mm for n, t in tools},
                   tool_radii_mm={n: getattr(t, "diameter_mm", 0.0) / 2.0 for n, t in tools},
                   g28_mm=tuple(getattr(config, "g28_mm", ZERO3)), g30_mm=tuple(getattr(config, "g30_mm", ZERO3)),
                   user_mcodes=dict(getattr(config, "user_mcodes", {})),
                   dialect=getattr(config, "dialect", "linuxcnc"),
                   subroutine_path=tuple(getattr(config, "subroutine_path", ())),
                   max_loop_iterations=getattr(config, "max_loop_iterations", 10_000_000),
                   m99_repeat=getattr(config, "m99_repeat", False))

    def work_offset(self, code10: int) -> tuple[float, float, float]:
        name = f"G{code10 // 10}" + (f".{code10 % 10}" if code10 % 10 else "")
        return tuple(float(v) for v in self.work_offsets_mm.get(name, ZERO3))


class ModalState:
    """Everything a block may read or change. Positions are machine mm.

    `offset` is the sum program -> machine: work offset + G92 offset + tool length (Z).
    `feed_mm_s` is the programmed feed: F is read in the units active before the block's
    own G20/G21 (RS274NGC executes F before the units change), and a later change of
    units keeps the feed's speed, as LinuxCNC does.
    """

    __slots__ = ("pos", "unit", "absolute", "arc_absolute", "plane", "motion", "feed_mm_s",
                 "path", "coord", "coord_offset", "g92", "tool_offset", "offset", "tool_selected",
                 "tool_in_spindle", "spindle_rpm", "spindle_dir", "mist", "flood", "nurbs",
                 "params", "ended", "program_number",
                 # canned cycles, stored positions, offset tables, feed and spindle modes (ipr.cycles,
                 # ipr.offsets, ipr.modes, ipr.mcodes); `detour` is True where a plain block may not
                 # take ipr.plain's short path (cutter compensation, G93/G95, a rotated system)
                 "retract_r", "cycle", "g28", "g30", "coord_table", "rotation_deg", "tool_table",
                 "g92_stored", "feed_mode", "css", "comp", "saved_modes", "detour", "spline_pq")

    def __init__(self, setup: Setup):
        self.pos = tuple(float(v) for v in setup.start_mm)
        self.unit = INCH_MM if setup.start_inch else 1.0
        self.absolute = not setup.start_incremental
        self.arc_absolute = False
        self.plane = setup.start_plane
        self.motion: int | None = None
        self.feed_mm_s = 0.0
        self.path: PathControl = CONTINUOUS
        self.coord = setup.start_coord
        self.coord_offset = setup.work_offset(setup.start_coord)
        self.g92 = tuple(float(v) for v in setup.start_g92_mm)
        self.tool_offset = float(setup.start_tool_offset_mm)
        c, g = self.coord_offset, self.g92
        self.offset = (c[0] + g[0], c[1] + g[1], c[2] + g[2] + self.tool_offset)
        self.tool_selected: int | None = None
        self.tool_in_spindle = 0
        self.spindle_rpm = 0.0
        self.spindle_dir: str | None = None
        self.mist = False
        self.flood = False
        self.nurbs = None
        self.params = Parameters(self, setup)
        self.ended = False
        self.program_number: int | None = None
        self.retract_r = False          # G98 (False) / G99
        self.cycle = None               # ipr.cycles.CycleMemory of the active cycle
        self.g28, self.g30 = setup.g28_mm, setup.g30_mm
        self.coord_table: dict = {}     # G10 L2/L20: coord code -> (x, y, z, rotation_deg)
        self.rotation_deg = 0.0
        self.tool_table: dict = {}      # G10 L1/L10/L11: tool -> (length_mm, radius_mm)
        self.g92_stored = ZERO3         # G92.2 keeps the offset here, G92.3 restores it
        self.feed_mode = 940
        self.css = None                 # G96: (surface speed m/min, max rpm or 0)
        self.comp = None                # ipr.cutter_comp state, None = G40
        self.saved_modes = None         # M70 snapshot
        self.detour = False
        self.spline_pq = None           # the last G5's P Q (ipr.splines)


class Staged:
    """A write-aside view of a ModalState for one block."""

    def __init__(self, base: ModalState):
        object.__setattr__(self, "_base", base)
        object.__setattr__(self, "_upd", {})
        object.__setattr__(self, "after_commit", [])

    def __getattr__(self, name):
        upd = self._upd
        return upd[name] if name in upd else getattr(self._base, name)

    def __setattr__(self, name, value):
        self._upd[name] = value

    def set_offsets(self) -> None:
        """Recompute the combined program -> machine offset after a change of its parts."""
        c, g = self.coord_offset, self.g92
        self.offset = (c[0] + g[0], c[1] + g[1], c[2] + g[2] + self.tool_offset)

    def commit(self) -> None:
        base = self._base
        for name, value in self._upd.items():
            setattr(base, name, value)
        base.detour = base.comp is not None or base.feed_mode != FEED_PER_MINUTE or base.rotation_deg != 0.0
        for action in self.after_commit:
            action()


def to_program(st, pos) -> tuple[float, float, float]:
    """Machine position -> program coordinates of the active system (inverse of the chain)."""
    c, g = st.coord_offset, st.g92
    x, y = pos[0] - c[0], pos[1] - c[1]
    if st.rotation_deg:
        t = math.radians(-st.rotation_deg)
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
    return (x - g[0], y - g[1], pos[2] - c[2] - st.tool_offset - g[2])


def to_machine(st, p) -> tuple[float, float, float]:
    """Program coordinates of the active system -> machine position."""
    c, g = st.coord_offset, st.g92
    x, y = p[0] + g[0], p[1] + g[1]
    if st.rotation_deg:
        t = math.radians(st.rotation_deg)
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
    return (x + c[0], y + c[1], p[2] + g[2] + c[2] + st.tool_offset)


def rotate_xy(st, dx: float, dy: float) -> tuple[float, float]:
    """An XY increment of the program turned into the machine's axes."""
    if not st.rotation_deg:
        return dx, dy
    t = math.radians(st.rotation_deg)
    return dx * math.cos(t) - dy * math.sin(t), dx * math.sin(t) + dy * math.cos(t)


def target(st, spec, vals, base, machine: bool = False):
    """End point (machine mm) of a block's axis words read from `base`: program units to mm,
    plus the program -> machine offset in G90, relative to `base` in G91, as-is for G53.
    `st` is a ModalState or Staged view, `spec` an ipr.block.BlockSpec, `vals` the values.
    A rotated coordinate system (G10 L2 R) turns the XY words (ipr.offsets); @ and ^ give XY (ipr.polar)."""
    end = list(base)
    unit = st.unit
    if spec.polar is not None:
        p = [c / unit for c in to_program(st, base)]
        p[0], p[1] = polar.end_xy(st, spec, vals, p, st.absolute)
        for k, i in spec.axis_idx:
            p[k] = vals[i] if st.absolute else p[k] + vals[i]
        return to_machine(st, [c * unit for c in p])
    if machine:
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit
    elif st.rotation_deg:
        if st.absolute:
            p = list(to_program(st, base))
            for k, i in spec.axis_idx:
                p[k] = vals[i] * unit
            return to_machine(st, p)
        d = [0.0, 0.0, 0.0]
        for k, i in spec.axis_idx:
            d[k] = vals[i] * unit
        dx, dy = rotate_xy(st, d[0], d[1])
        return (base[0] + dx, base[1] + dy, base[2] + d[2])
    elif st.absolute:
        off = st.offset
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit + off[k]
    else:
        for k, i in spec.axis_idx:
            end[k] = base[k] + vals[i] * unit
    return tuple(end)
