"""The check before motion: the whole program, every reason to refuse it, in bounded memory.

`check_program` reads the program's text once (ipr.ProgramText) and interprets all of it with
every error collected, checking each batch of entities as it comes:

1. the interpreter's errors (any refuses the run; they alone are reported, as a later check
   of a program that does not read as written would only repeat them);
2. the travel of every motion (machine.extents: a straight move by its end point, an arc
   exactly, a NURBS by branch and bound) and of the start position;
3. every NURBS the planner cannot walk (ipo.feed.split.planning_problem, the tables the
   planner builds first).

Of a batch only small facts stay: where the first motion starts, the number of motions, the
lines of the rapids, the last line, and each travel violation once per line, axis and side
(the farthest point: a loop that crosses a limit a million times is one reason). So the
check's memory is the program's text plus one batch, never the number of executed blocks.

The run interprets the same text again (`CheckedProgram.entities`, each iteration a fresh
interpretation): the same characters (subroutine files included) and the same set-up give
the same entities, so what runs is what was checked. Interpreting twice costs time, not
memory; holding every entity of a ten-million-iteration loop would cost gigabytes. A program
of at most KEEP_UNITS entities (a NURBS counts its control points too), ~60 MB of them, is
the exception: the check keeps its entities and the run takes them as they are, so a CAM
program of an ordinary size is interpreted once (g1_stellabee1, 169k entities: 0.11 s of its
2.7 s of CPU); past the bound the check drops what it kept, and its memory is as above.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from itertools import chain
from operator import attrgetter

import numpy as np

from ipo.feed.planner import nurbs_end_gap_mm
from ipo.feed.split import planning_problem
from ipr import GCodeError, Program, ProgramText, Setup
from ipr.entities import MOTION_TYPES, Nurbs, Rapid, group_by_type
from machine.extents import Excursion, excursions_of

KEEP_UNITS = 1 << 18   # entities the check keeps for the run (~230 bytes each), NURBS points counted


class ProgramRejected(Exception):
    """The program may not run; `reasons` holds one line per problem, each naming its line."""

    def __init__(self, reasons: list[str]):
        self.reasons = reasons
        super().__init__("\n".join(reasons))


def first_motion_start(entities) -> tuple[float, float, float] | None:
    """The start of the first motion among `entities`, None if there is none."""
    for e in entities:
        if isinstance(e, MOTION_TYPES):
            return tuple(float(c) for c in e.start)
    return None


class _Replay:
    """A checked program's entities: every iteration interprets its text again."""

    def __init__(self, text: ProgramText, setup: Setup):
        self.text, self.setup = text, setup

    def __iter__(self):
        return chain.from_iterable(self.text.interpret(self.setup))


@dataclass(slots=True)
class CheckedProgram:
    """A program that passed the check; `entities` iterates its entities (again) in order."""

    file: str
    entities: object   # an iterable of ipr entities (a _Replay, or a list for a ready Program)
    warnings: list = field(default_factory=list)
    program_number: int | None = None
    start_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)   # where the first motion starts
    motion_count: int = 0
    last_line: int = 0
    rapid_lines: frozenset[int] = frozenset()

    def motions(self) -> list:
        return [e for e in self.entities if isinstance(e, MOTION_TYPES)]

    @classmethod
    def of(cls, program: Program) -> CheckedProgram:
        """The facts of an interpreted Program held whole (no check is made)."""
        facts = _Facts()
        facts.add(program.entities)
        return cls(program.file, program.entities, program.warnings, program.program_number,
                   *facts.summary())


class _Facts:
    """What the run needs to know of the whole program, gathered a batch at a time."""

    def __init__(self):
        self.start: tuple[float, float, float] | None = None
        self.motions = 0
        self.last_line = 0
        self.rapid_lines: set[int] = set()

    def add(self, batch: list) -> dict[type, list]:
        groups = group_by_type(batch)
        if self.start is None:
            self.start = first_motion_start(batch)
        self.motions += sum(len(groups.get(cls, ())) for cls in MOTION_TYPES)
        self.last_line = max(self.last_line, max(map(attrgetter("line"), batch), default=0))
        self.rapid_lines.update(map(attrgetter("line"), groups.get(Rapid, ())))
        return groups

    def summary(self) -> tuple:
        return (self.start or (0.0, 0.0, 0.0), self.motions, self.last_line, frozenset(self.rapid_lines))


class _Travel:
    """Travel excursions, one per (line, axis, side): the farthest point reached there."""

    def __init__(self, lo_mm: np.ndarray, hi_mm: np.ndarray):
        self.lo_mm, self.hi_mm = lo_mm, hi_mm
        self.worst: dict[tuple[int, int, int], Excursion] = {}

    def add(self, groups: dict[type, list]) -> None:
        for x in excursions_of(groups, self.lo_mm, self.hi_mm):
            key = (x.line, x.axis, x.side)
            known = self.worst.get(key)
            if known is None or x.side * (x.reach_mm - known.reach_mm) > 0:
                self.worst[key] = x

    def reasons(self, file: str) -> list[str]:
        return [f"{file}:{x.line}:1: error[E-TRAVEL]: {x.reason(self.lo_mm, self.hi_mm)}"
                for _, x in sorted(self.worst.items())]


def check_program(path, config, lo_mm: np.ndarray, hi_mm: np.ndarray) -> tuple[CheckedProgram, float]:
    """The checked program and the seconds the check took; raises ProgramRejected with every
    reason (nothing has moved)."""
    t0 = time.perf_counter()
    try:
        text = ProgramText.read(path)
    except OSError as err:
        raise ProgramRejected([f"{path}: cannot read the program: {err.strerror or err}"]) from None
    setup = Setup.from_machine(config)
    run = text.interpret(setup, all_errors=True)
    facts, travel, end_gap = _Facts(), _Travel(lo_mm, hi_mm), nurbs_end_gap_mm(config)
    unwalkable: dict[int, str] = {}   # line -> why the planner cannot walk its NURBS
    kept: list | None = []   # the entities so far, while within KEEP_UNITS
    kept_units = 0
    try:
        for batch in run:
            groups = facts.add(batch)
            travel.add(groups)
            for e in groups.get(Nurbs, ()):
                if e.line not in unwalkable and (why := planning_problem(e, end_gap)) is not None:
                    unwalkable[e.line] = why
            if kept is not None:
                kept.extend(batch)
                kept_units += len(batch) + sum(len(e.points) for e in groups.get(Nurbs, ()))
                if kept_units > KEEP_UNITS:
                    kept = None
    except GCodeError as err:
        raise ProgramRejected([str(d) for d in err.diagnostics]) from None
    start = np.array(facts.summary()[0])
    reasons = travel.reasons(text.file) + [f"{text.file}:{line}:1: error[E-NURBS-PATH]: {why}"
                                           for line, why in sorted(unwalkable.items())]
    if ((start < lo_mm) | (start > hi_mm)).any():
        reasons.insert(0, f"{text.file}:0:1: error[E-TRAVEL]: the start position {start.tolist()} mm "
                          f"is outside the travel")
    if reasons:
        raise ProgramRejected(reasons)
    entities = kept if kept is not None else _Replay(text, setup)
    checked = CheckedProgram(text.file, entities, run.warnings, run.program_number, *facts.summary())
    return checked, time.perf_counter() - t0
