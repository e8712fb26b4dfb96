"""The grbl link's lines as the grbl twin takes them (ipo.feed.grbl_twin.wire.WireLine):
each stream line with its bytes on the wire (text and newline), what grbl does with it,
and the program's entity it carries out.
"""
from __future__ import annotations

from typing import Iterable, Iterator

from ipo.feed.grbl_twin.wire import MODAL, NOTHING, STOP, WireLine, event_line, kind_of, motion_line
from ipr.entities import MOTION_TYPES, Stop
from machine.grbl.program import StreamLine


def wire_lines(groups: Iterable[tuple[object, list[StreamLine]]]) -> Iterator[WireLine]:
    """WireLines of stream_groups' (entity, lines): a motion's lines move (a too-long line's
    modal half does not), an event's first line carries the event out (grbl 1.1 ignores M1:
    no wait), and an event that sends nothing is a line of no bytes."""
    for entity, lines in groups:
        if entity is None or isinstance(entity, MOTION_TYPES):
            for l in lines:
                n = len(l.text) + 1
                yield motion_line(entity, n, l.end_mm, l.feed_mm_min) if l.motion else WireLine(n, l.source_line, MODAL)
            continue
        if not lines:
            yield WireLine(0, entity.line, NOTHING, event=entity)
            continue
        kind = MODAL if isinstance(entity, Stop) and entity.optional else kind_of(entity)
        first = event_line(entity, len(lines[0].text) + 1)
        yield first if kind == first.kind else WireLine(first.n_bytes, entity.line, kind, event=entity)
        for l in lines[1:]:
            yield WireLine(len(l.text) + 1, l.source_line, kind if kind != STOP else MODAL)
