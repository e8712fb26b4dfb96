"""The interpreter's modal state, the machine set-up it reads, block staging, and the
conversion of axis words to machine coordinates.

A block is executed against a `Staged` view of the state: reads fall through to the
state, writes are kept aside and applied by `commit()` only when the whole block has
been accepted (grbl's discipline: an erroneous block changes nothing). Values are
replaced, never mutated in place (positions are tuples).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ipr.entities import CONTINUOUS, PathControl
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
    """

    work_offsets_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    tool_lengths_mm: dict[int, float] = field(default_factory=dict)
    block_delete: bool = True
    subroutine_path: tuple[str, ...] = ()
    max_loop_iterations: int = 10_000_000
    max_call_depth: int = 9
    m99_repeat: bool = False

    @classmethod
    def from_machine(cls, config) -> Setup:
        """The Setup of a machine configuration (ipo.config.MachineConfig, duck-typed:
        `work_offsets_mm` and `tools` with `length_mm`; the interpreter keys if it has them)."""
        return cls(work_offsets_mm=dict(config.work_offsets_mm),
                   tool_lengths_mm={n: t.length_mm for n, t in config.tools.items()},
                   subroutine_path=tuple(getattr(config, "subroutine_path", ())),
                   max_loop_iterations=getattr(config, "max_loop_iterations", 10_000_000),
                   m99_repeat=getattr(config, "m99_repeat", False))

    def work_offset(self, code10: int) -> tuple[float, float, float]:
        name = f"G{code10 // 10}"
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
                 "params", "ended", "program_number")

    def __init__(self, setup: Setup):
        self.pos = ZERO3
        self.unit = 1.0
        self.absolute = True
        self.arc_absolute = False
        self.plane = "XY"
        self.motion: int | None = None
        self.feed_mm_s = 0.0
        self.path: PathControl = CONTINUOUS
        self.coord = 540
        self.coord_offset = setup.work_offset(540)
        self.g92 = ZERO3
        self.tool_offset = 0.0
        self.offset = self.coord_offset
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
        for action in self.after_commit:
            action()


def target(st, spec, vals, base, machine: bool = False):
    """End point (machine mm) of a block's axis words read from `base`: program units to mm,
    plus the program -> machine offset in G90, relative to `base` in G91, as-is for G53.
    `st` is a ModalState or Staged view, `spec` an ipr.block.BlockSpec, `vals` the values."""
    end = list(base)
    unit = st.unit
    if machine:
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit
    elif st.absolute:
        off = st.offset
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit + off[k]
    else:
        for k, i in spec.axis_idx:
            end[k] = base[k] + vals[i] * unit
    return tuple(end)
