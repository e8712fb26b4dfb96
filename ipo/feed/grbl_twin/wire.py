"""What grbl receives: one `WireLine` per line on the serial link, in stream order.

The grbl link (machine.grbl.program) writes the lines; machine hands them to the twin as
WireLines (ipo does not import machine), each with its byte count on the wire, so the twin
sees exactly what the board would: arcs as G2/G3 (grbl cuts them by $12), NURBS as the
G1 segments vcnc's IPO planned, modal-only lines, dwells and spindle changes (which make
grbl wait for the machine to stop). `from_entities` makes the lines of a program without
NURBS for a caller that has no link (the serial link is then left out: `n_bytes` 0).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Iterator

from ipo.errors import TWIN_INPUT, IpoError
from ipr.entities import (Arc, Auxiliary, Coolant, Dwell, Line, Message, Nurbs, ProgramEnd, Rapid, Spindle, Stop,
                          ToolChange)

# what grbl does with a line
MOVE = "move"  # G1: one planner block
RAPID = "rapid"  # G0: one block at the axes' max rates
ARC = "arc"  # G2/G3: mc_arc's chords
DWELL = "dwell"  # G4: wait until the machine stands, then wait P seconds
SYNC = "sync"  # M3/M4/M5/S, M7/M8/M9: wait until the machine stands
STOP = "stop"  # M0/M1 (and vcnc's tool change pause): wait until it stands, then the operator
END = "end"  # M2/M30: wait until it stands
MODAL = "modal"  # only modal words: no motion, no wait
NOTHING = "nothing"  # nothing goes on the wire (a message, an M100): the event only


@dataclass(frozen=True, slots=True)
class WireLine:
    n_bytes: int  # on the wire, newline included (0: nothing sent)
    source_line: int
    kind: str
    end_mm: tuple[float, float, float] | None = None  # machine coordinates after a motion
    feed_mm_min: float | None = None  # G1/G2/G3
    arc: tuple | None = None  # (center_mm, plane, ccw) of a G2/G3
    dwell_s: float = 0.0
    event: object = None  # the program's entity this line carries out, yielded when grbl runs it
    words: tuple | None = None  # the X, Y, Z numbers as written on the line (None: not written)
    frame_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # what grbl adds to them (G54...; 0 under G53)


def kind_of(entity) -> str:
    """What grbl does with the line an event entity becomes."""
    if isinstance(entity, Dwell):
        return DWELL
    if isinstance(entity, (Spindle, Coolant)):
        return SYNC
    if isinstance(entity, (Stop, ToolChange)):
        return STOP
    if isinstance(entity, ProgramEnd):
        return END
    if isinstance(entity, (Message, Auxiliary)):
        return NOTHING
    raise TypeError(f"the grbl twin cannot run {type(entity).__name__}")


def motion_line(entity, n_bytes: int = 0, end_mm=None, feed_mm_min=None, words=None,
                frame_mm=(0.0, 0.0, 0.0)) -> WireLine:
    """The line of a G0/G1/G2/G3 entity (end and feed: the entity's unless given; `words`
    and `frame_mm`: the numbers as written, see WireLine)."""
    end = tuple(float(c) for c in (entity.end if end_mm is None else end_mm))
    if isinstance(entity, Rapid):
        return WireLine(n_bytes, entity.line, RAPID, end, words=words, frame_mm=frame_mm)
    feed = entity.feed_mm_s * 60.0 if feed_mm_min is None else feed_mm_min
    arc = None
    if isinstance(entity, Arc):
        arc = (tuple(float(c) for c in entity.center), entity.plane, bool(entity.ccw))
    return WireLine(n_bytes, entity.line, ARC if arc else MOVE, end, feed, arc, words=words, frame_mm=frame_mm)


def event_line(entity, n_bytes: int = 0) -> WireLine:
    kind = kind_of(entity)
    return WireLine(n_bytes, entity.line, kind, dwell_s=entity.seconds if kind == DWELL else 0.0, event=entity)


def from_entities(entities: Iterable) -> Iterator[WireLine]:
    """The lines of a program of lines, arcs and events, with no serial link (n_bytes 0)."""
    for e in entities:
        if isinstance(e, (Line, Rapid, Arc)):
            if e.start != e.end or isinstance(e, Arc):
                yield motion_line(e)
        elif isinstance(e, Nurbs):
            raise IpoError(TWIN_INPUT, "grbl cannot run a NURBS block; vcnc's grbl link sends it as G1 segments "
                                         "planned by vcnc's IPO: give the twin the link's lines (vcnc run --planner "
                                         "grbl does)", e.line)
        else:
            yield event_line(e)
