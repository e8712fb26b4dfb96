"""The machine's real state as grbl reports it, and the program's start taken from it.

A program starts where the machine stands, in the modes grbl's parser is in: an
axis the program never names stays where the machine is (RS274NGC semantics; sending
it as 0 would move the machine where the program never said). `MachineState` holds
what `?`, `$G` and `$#` report; `program_setup` turns it into the interpreter's
start (machine position, G54-G59 offsets, G92, tool length offset, G20, G91, plane),
so the interpreter's machine coordinates are grbl's machine coordinates.

`unset_axes` finds the program's first moves that depend on a position the program
never set, by interpreting the start of the program twice from two different start
positions: an axis whose coordinate differs between the two runs still carries the
start position (never named, or only moved incrementally).
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from itertools import islice
from typing import Iterable

from ipr.entities import MOTION_TYPES

COORD_CODES = ("G54", "G55", "G56", "G57", "G58", "G59")
PLANE_OF = {"G17": "XY", "G18": "ZX", "G19": "YZ"}
PROBE_SHIFT_MM = (1.25, -2.5, 3.75)  # the second start position's offset; any non-zero per axis
UNSET_SCAN_MOTIONS = 200  # how far into the program the unset-axis check looks


class StateError(ValueError):
    """grbl's $G / $# answer does not follow the 1.1 format."""


@dataclass(frozen=True, slots=True)
class MachineState:
    mpos_mm: tuple[float, float, float]
    wco_mm: tuple[float, float, float]  # G5x + G92 + TLO, as grbl applies it to work coordinates
    coord: str  # active G54..G59
    offsets_mm: dict  # G54..G59 -> (x, y, z) machine position of the work zero
    g92_mm: tuple[float, float, float]
    tlo_mm: float
    inch: bool
    incremental: bool
    plane: str
    tool: int
    modal: tuple[str, ...]  # every word of $G, for the record
    g28_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # grbl's stored G28 / G30 positions (machine)
    g30_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def as_json(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_json(cls, d: dict) -> MachineState:
        tup = lambda v: tuple(float(x) for x in v)  # noqa: E731
        return cls(tup(d["mpos_mm"]), tup(d["wco_mm"]), d["coord"],
                   {k: tup(v) for k, v in d["offsets_mm"].items()}, tup(d["g92_mm"]), float(d["tlo_mm"]),
                   bool(d["inch"]), bool(d["incremental"]), d["plane"], int(d["tool"]), tuple(d["modal"]),
                   tup(d["g28_mm"]), tup(d["g30_mm"]))


def parse_modal(lines: list[str]) -> tuple[str, ...]:
    """`$G` answer `[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]` -> its words."""
    for line in lines:
        line = line.strip()
        if line.startswith("[GC:") and line.endswith("]"):
            return tuple(line[4:-1].split())
    raise StateError(f"no [GC:...] line in the $G answer {lines!r}")


_PARAM_RE = re.compile(r"^\[(G5[4-9]|G28|G30|G92|TLO|PRB):([-0-9.,:]+)\]$")


def parse_params(lines: list[str]) -> dict[str, tuple[float, ...]]:
    """`$#` answer -> {"G54": (x, y, z), ..., "G92": (...), "TLO": (z,)}."""
    out = {}
    for line in lines:
        if m := _PARAM_RE.match(line.strip()):
            out[m.group(1)] = tuple(float(v) for v in m.group(2).split(":")[0].split(","))
    missing = [k for k in (*COORD_CODES, "G92", "TLO") if k not in out]
    if missing:
        raise StateError(f"the $# answer lacks {', '.join(missing)}: {lines!r}")
    return out


def machine_state(mpos_mm, wco_mm, modal: tuple[str, ...], params: dict) -> MachineState:
    coord = next((w for w in modal if w in COORD_CODES), "G54")
    tool = next((int(float(w[1:])) for w in modal if w.startswith("T")), 0)
    return MachineState(tuple(float(v) for v in mpos_mm), tuple(float(v) for v in wco_mm), coord,
                        {k: tuple(params[k][:3]) for k in COORD_CODES}, tuple(params["G92"][:3]),
                        float(params["TLO"][0]), "G20" in modal, "G91" in modal,
                        next((PLANE_OF[w] for w in modal if w in PLANE_OF), "XY"), tool, tuple(modal),
                        tuple(params.get("G28", (0.0, 0.0, 0.0))[:3]), tuple(params.get("G30", (0.0, 0.0, 0.0))[:3]))


def program_setup(state: MachineState, config):
    """The interpreter's Setup for a program started on this machine: grbl's offsets,
    stored G28/G30 positions and modes, the start at the machine position; the rest
    (tools, dialect, subroutines) from the machine file."""
    from ipr import Setup

    return dataclasses.replace(
        Setup.from_machine(config), work_offsets_mm=dict(state.offsets_mm), g28_mm=state.g28_mm,
        g30_mm=state.g30_mm, start_mm=tuple(state.mpos_mm), start_coord=int(state.coord[1:]) * 10,
        start_g92_mm=state.g92_mm, start_tool_offset_mm=state.tlo_mm, start_inch=state.inch,
        start_incremental=state.incremental, start_plane=state.plane)


def unset_axes(entities_from, setup) -> list[tuple[int, str]]:
    """[(program line, axes)] of the first moves that leave an axis where the machine
    happens to stand (the program has not set it yet), until every axis is set or
    UNSET_SCAN_MOTIONS moves have been looked at. `entities_from(setup)` interprets
    the program from a Setup."""
    shifted = dataclasses.replace(setup, start_mm=tuple(a + d for a, d in zip(setup.start_mm, PROBE_SHIFT_MM)))
    out = []
    pairs = zip(_motions(entities_from(setup)), _motions(entities_from(shifted)))
    for a, b in islice(pairs, UNSET_SCAN_MOTIONS):
        unset = "".join(ax for k, ax in enumerate("XYZ") if a.end[k] != b.end[k])
        if not unset:
            break
        if a.end != a.start:
            out.append((a.line, unset))
    return out


def _motions(entities: Iterable):
    return (e for e in entities if isinstance(e, MOTION_TYPES))
