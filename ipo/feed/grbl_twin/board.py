"""The board in time: the serial link, grbl's main loop, its planner and its stepper, run as
one discrete-event simulation on grbl's own clock.

- Link: the sender (vcnc's streamer) keeps the bytes of the lines grbl has not answered
  within grbl's RX buffer (127 of 128 bytes) and sends a line as soon as it fits; bytes
  take 10 bit times each on the wire; an `ok` takes its 4 bytes back.
- Main loop (protocol.c, gcode.c, motion_control.c): takes a line once its newline has
  arrived, and only when it is not busy: a motion waits in mc_line for a free planner block
  (an arc's chords one after the other), G4 and spindle or coolant changes wait until the
  machine stands (protocol_buffer_synchronize), G4 then sleeps in 50 ms steps. It answers
  `ok` when the line is done. It is taken as infinitely fast against the motion (grbl-sim's
  main loop runs at host speed), so the stepper always has its segments prepared.
- Cycle start: as soon as a block is planned and the main loop waits for anything.
- Stepper: up to SEGMENT_BUFFER_SIZE - 1 segments are prepared (the running one among
  them); a segment's time is its steps times its tick period; with none left the cycle stops.

`Board.run(lines)` yields, in time order, ("segment", t_start_s, Segment, t_end_s) as each
segment ends, ("event", t_s, entity, moving) where grbl carries a line's entity out
(`moving`: a segment is running then, not yet yielded), and ("stand", t_from_s, t_to_s,
line) for a dwell.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Iterable, Iterator

from ipo.feed.grbl_twin.arcs import arc_targets
from ipo.feed.grbl_twin.numbers import f32, read_float
from ipo.feed.grbl_twin.planner import Planner
from ipo.feed.grbl_twin.stepper import F_CPU_HZ, SEGMENT_BUFFER_SIZE, Prep
from ipo.feed.grbl_twin.wire import ARC, DWELL, END, MOVE, RAPID, STOP, SYNC, WireLine

RX_BUFFER_BYTES = 128  # serial.h; the sender keeps one byte free, as vcnc's streamer does
DWELL_TIME_STEP_S = 0.050  # config.h DWELL_TIME_STEP
OK_BYTES = 4  # "ok\r\n"
_WAITS = (DWELL, SYNC, STOP, END)


class Board:
    """One grbl 1.1 board: see the module docstring."""

    def __init__(self, settings, *, start_mm=(0.0, 0.0, 0.0), baud: float | None = None, feed_override: float = 1.0,
                 answer_s: float | None = None):
        self.settings = settings
        start_steps = [round(p * s) for p, s in zip(start_mm, settings.steps_per_mm)]
        self.planner = Planner(settings.steps_per_mm, settings.max_rate_mm_min,
                               [a * 3600.0 for a in settings.accel_mm_s2], settings.junction_deviation_mm,
                               start_steps)
        self.planner.override = feed_override
        self.prep = Prep(self.planner)
        self.byte_s = 0.0 if baud is None else 10.0 / baud
        # from grbl's `ok` to the sender's next byte: the answer's bytes on the wire (a simulator
        # with no wire time on its answers gives its client's latency instead)
        self.reply_s = OK_BYTES * self.byte_s if answer_s is None else answer_s
        self.position_mm = [f32(c) for c in start_mm]  # the parser's position (gc_state.position), floats
        self.idle_lock_s = settings.idle_lock_s

    def run(self, lines: Iterable[WireLine]) -> Iterator[tuple]:
        self._link = _Link(iter(lines), self.byte_s)
        self._segq: deque = deque()  # prepared segments; the first runs while `_seg_end` is set
        self._seg_end = None  # tick at which the running segment ends
        self._pending: deque = deque()  # chords of the line in hand not yet planned
        self._line: WireLine | None = None  # the line in hand
        self._wait_until = None  # the end of a dwell in hand
        self._isr_busy_until = 0.0  # st_go_idle's $1 wait: the main loop stands still until then
        t = 0.0
        while True:
            # 1. at time t: the main loop, then the stepper's preparation (which may free a
            # planner block for a motion waiting in mc_line: then the main loop again)
            while t >= self._isr_busy_until:
                yield from self._main_loop(t)
                self._prepare(t)
                if not (self._pending and not self.planner.full()):
                    break
            # 2. the next moment anything happens
            t_seg = None if self._seg_end is None else self._seg_end / F_CPU_HZ
            t_line = self._link.next_arrival() if self._line is None else None
            cand = [c for c in (t_seg, self._wait_until, t_line) if c is not None]
            if self._isr_busy_until > t:  # the stepper stands (that is why it waits): nothing before
                cand = [self._isr_busy_until]
            if not cand:
                if self._line is None and self._link.done():
                    return
                raise RuntimeError("the grbl twin stalled with nothing left to happen")  # a bug, not the program
            t = max(t, min(cand))
            if t_seg is not None and t >= t_seg:
                seg = self._segq.popleft()
                yield ("segment", (self._seg_end - seg.n_tick) / F_CPU_HZ, seg, t_seg)
                self._seg_end = self._seg_end + self._segq[0].n_tick if self._segq else None
                if self._seg_end is None:  # the interrupt finds no segment: st_go_idle waits $1 ms in it
                    self._isr_busy_until = t + self.idle_lock_s

    def _main_loop(self, t: float) -> Iterator[tuple]:
        """grbl's main loop at time t, until it must wait (for a block, the stop, a dwell or a line)."""
        pl, link = self.planner, self._link
        while True:
            line = self._line
            if line is not None and self._pending:
                while self._pending and not pl.full():
                    target, feed = self._pending.popleft()
                    pl.add(target, feed, line.kind == RAPID, line.source_line)
                if self._pending:
                    return  # mc_line waits for the stepper to free a block
            if line is not None and line.kind in _WAITS:
                if not pl.empty() or self._segq:
                    return  # protocol_buffer_synchronize
                if self._wait_until is None:
                    if line.event is not None:
                        yield ("event", t, line.event, False)
                    self._wait_until = t
                    if line.kind == DWELL:
                        self._wait_until += math.ceil(line.dwell_s / DWELL_TIME_STEP_S - 1e-9) * DWELL_TIME_STEP_S
                        yield ("stand", t, self._wait_until, line.source_line)
                if self._wait_until > t:
                    return
                self._wait_until = None
            if line is not None:
                link.answered(t + self.reply_s)
                self._line = None
            line = link.arrived(t)
            if line is None:
                return
            self._line = line
            if line.kind in (MOVE, RAPID, ARC):
                self._pending.extend(self._targets(line))
            elif line.event is not None and line.kind not in _WAITS:
                yield ("event", t, line.event, self._seg_end is not None)

    def _prepare(self, t: float) -> None:
        """st_prep_buffer, and the cycle start when the stepper stands with segments ready."""
        while len(self._segq) < SEGMENT_BUFFER_SIZE - 1:
            seg = self.prep.cut()
            if seg is None:
                break
            self._segq.append(seg)
        if self._seg_end is None and self._segq:
            self._seg_end = _ticks(t) + self._segq[0].n_tick

    def _targets(self, line: WireLine) -> list:
        """The planner moves of a motion line (machine mm), with its feed. The parser's position
        follows the programmed end as grbl reads it: the written numbers in single precision plus
        the frame (gcode.c), an axis not written keeping its value."""
        if line.words is None:
            end = [f32(c) for c in line.end_mm]
        else:
            end = [self.position_mm[k] if w is None else f32(read_float(w) + f32(line.frame_mm[k]))
                   for k, w in enumerate(line.words)]
        if line.kind == ARC:
            center, plane, ccw = line.arc
            chords = arc_targets([float(c) for c in self.position_mm], [float(c) for c in end], center, plane,
                                 ccw, self.settings.arc_tolerance_mm)
            chords[-1] = end
        else:
            chords = [end]
        self.position_mm = end
        return [(c, line.feed_mm_min) for c in chords]


def _ticks(t_s: float) -> int:
    return int(round(t_s * F_CPU_HZ))


class _Link:
    """The sender's side of the serial link: which lines are on their way, when each arrives."""

    def __init__(self, lines: Iterator[WireLine], byte_s: float):
        self._lines = lines
        self._next = next(lines, None)
        self.byte_s = byte_s
        self.wire_free = 0.0
        self.budget = RX_BUFFER_BYTES - 1
        self.waiting = 0  # bytes sent, not answered
        self.sent: deque = deque()  # (arrival time, line) sent, not yet taken by grbl
        self.in_hand: deque = deque()  # bytes of the lines taken, not yet answered
        self._send(0.0)

    def _send(self, t: float) -> None:
        while self._next is not None and self.waiting + self._next.n_bytes <= self.budget:
            line = self._next
            start = max(t, self.wire_free)
            self.wire_free = start + line.n_bytes * self.byte_s
            self.sent.append((self.wire_free, line))
            self.waiting += line.n_bytes
            self._next = next(self._lines, None)

    def next_arrival(self) -> float | None:
        return self.sent[0][0] if self.sent else None

    def arrived(self, t: float) -> WireLine | None:
        if self.sent and self.sent[0][0] <= t:
            _, line = self.sent.popleft()
            self.in_hand.append(line.n_bytes)
            return line
        return None

    def answered(self, t_received: float) -> None:
        """grbl answered the oldest line in hand; the sender hears it at t_received."""
        self.waiting -= self.in_hand.popleft()
        self._send(t_received)

    def done(self) -> bool:
        return self._next is None and not self.sent
