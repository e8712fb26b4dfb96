"""The grbl link's lines as the grbl twin takes them (ipo.feed.grbl_twin.wire.WireLine):
each stream line with its bytes on the wire (text and newline), what grbl does with it,
and the program's entity it carries out.

grbl waits for the machine to stand only where a spindle or coolant line changes its state
(gcode.c: spindle_sync, coolant_sync), so the spindle and coolant grbl holds are followed
from its state after a reset (M5 S0, M9).
"""
from __future__ import annotations

import re
from typing import Iterable, Iterator

from ipo.feed.grbl_twin.wire import MODAL, NOTHING, SYNC, WireLine, event_line, kind_of, motion_line
from ipr.entities import MOTION_TYPES, Coolant, Spindle, Stop
from machine.grbl.program import StreamLine


class _Modes:
    """grbl's spindle (M3/M4/M5 and S) and coolant (M7, M8) as the lines sent leave them."""

    def __init__(self):
        self.spindle, self.rpm = "M5", 0.0
        self.coolant: set[str] = set()

    def spindle_changes(self, e: Spindle) -> bool:
        mode = "M5" if e.direction is None else "M3" if e.direction == "cw" else "M4"
        rpm = self.rpm if e.direction is None else e.rpm  # the link writes M5 without S
        changes = mode != self.spindle or (mode != "M5" and rpm != self.rpm)
        self.spindle, self.rpm = mode, rpm
        return changes

    def coolant_changes(self, code: str) -> bool:
        new = set() if code == "M9" else self.coolant | {code}
        changes = new != self.coolant
        self.coolant = new
        return changes


def _code(line: StreamLine) -> str:
    return line.text.lstrip("N0123456789")


_AXIS_WORD = re.compile(r"([XYZ])([-+]?[0-9.]+)")


def _words(line: StreamLine) -> tuple[tuple, tuple]:
    """The X, Y, Z numbers written on a motion line, and the frame grbl adds to them (none
    under G53: machine coordinates)."""
    found = dict(_AXIS_WORD.findall(_code(line).split("I")[0].split("J")[0].split("K")[0]))
    frame = (0.0, 0.0, 0.0) if _code(line).startswith("G53") else tuple(line.fmt.frame_mm)
    return tuple(found.get(a) for a in "XYZ"), frame


def wire_lines(groups: Iterable[tuple[object, list[StreamLine]]]) -> Iterator[WireLine]:
    """WireLines of stream_groups' (entity, lines): a motion's lines move (a too-long line's
    modal half does not), an event's first line carries the event out (grbl 1.1 ignores M1:
    no wait; an unchanged spindle or coolant: no wait), and an event that sends nothing is a
    line of no bytes."""
    modes = _Modes()
    for entity, lines in groups:
        if entity is None or isinstance(entity, MOTION_TYPES):
            for l in lines:
                n = len(l.text) + 1
                if l.motion:
                    words, frame = _words(l)
                    yield motion_line(entity, n, l.end_mm, l.feed_mm_min, words, frame)
                else:
                    yield WireLine(n, l.source_line, MODAL)
            continue
        if not lines:
            yield WireLine(0, entity.line, NOTHING, event=entity)
            continue
        if isinstance(entity, Coolant):
            kinds = [SYNC if modes.coolant_changes(_code(l)) else MODAL for l in lines]
        elif isinstance(entity, Spindle):
            kinds = [SYNC if modes.spindle_changes(entity) else MODAL] + [MODAL] * (len(lines) - 1)
        elif isinstance(entity, Stop) and entity.optional:
            kinds = [MODAL] * len(lines)
        else:
            kinds = [kind_of(entity)] + [MODAL] * (len(lines) - 1)
        for i, (l, kind) in enumerate(zip(lines, kinds)):
            line = event_line(entity, len(l.text) + 1) if i == 0 else None
            if line is None or line.kind != kind:
                line = WireLine(len(l.text) + 1, l.source_line, kind, event=entity if i == 0 else None)
            yield line
