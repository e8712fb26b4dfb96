"""What vcnc streams to grbl: entities -> numbered text lines, each at most 79 characters.

G0/G1 pass through in absolute coordinates; G2/G3 pass through as arcs (incremental
IJK from the position grbl holds; extra full turns become separate arcs). Lines are
compact: a modal word (G0-G3, plane, F) only where it changes, an axis word only
where the axis moves, numbers as short as `words.Format` allows. That is exact
because the interpreter starts where the machine stands (`machine.grbl.state`): an
axis the program has not moved is where grbl's parser already holds it. G53 moves
(source lines in `g53_lines`) go out as G53 in machine coordinates.
NURBS, which grbl cannot run, go through vcnc's IPO (`ipo.feed.planner.plan_periods`): the
per-period path is merged into G1 segments within `merge_tol_mm` of the period
points, and each segment carries the IPO's planned feed (the mean of the planned path
speed over its periods), so grbl runs the curve at the speed vcnc planned.
Positions of a StreamLine are machine coordinates (grbl's MPos); the text is in the
work frame `Format.frame_mm` (the WCO grbl applies at the stream's start).

Lines are numbered 1.. in stream order (`seq`); `source_line` is the program line.
Numbering is deterministic, so a resumed stream regenerates the same lines.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

import numpy as np
from numba import njit

from ipr.entities import (PLANE_AXES, Arc, Auxiliary, Coolant, Dwell, Line, Message, Nurbs, ProgramEnd, Rapid,
                          Spindle, Stop, ToolChange)
from machine.grbl.protocol import MAX_LINE_CHARS
from machine.grbl.words import AXIS_LETTERS, DWELL_TOL_S, PLANE_CODE, RPM_TOL, Format, arc_words, fmt

RESET_MODES = "G21G90G94"  # mm, absolute, units/min: what vcnc writes in (grbl's arcs are always G91.1)
VERTEX_BLU_MM = 1e-7  # the IPO's resolution for the vertices sent (far below the numbers written)


class StreamProgramError(ValueError):
    """The program cannot be expressed in lines grbl accepts."""


@dataclass(frozen=True, slots=True)
class StreamLine:
    """One line on the wire (without its newline)."""

    seq: int  # 1-based position in the stream
    source_line: int  # program line (0 for the stream's own set-up)
    text: str
    start_mm: tuple[float, float, float]  # commanded machine position before the line
    end_mm: tuple[float, float, float]  # after it
    motion: bool  # moves the machine
    restore: tuple[str, ...]  # lines that set up the modal state (units, motion, plane, F, spindle, coolant) after a reset
    arc: tuple | None = None  # (center_mm, plane, ccw, feed_mm_min) to re-emit the arc from elsewhere
    fmt: Format = Format()
    feed_mm_min: float | None = None  # the feed a feed move runs at (None for rapids and non-motion)


@njit(cache=True)
def _merge_kernel(pts, tol):  # greedy: extend each G1 while every period point stays within tol of it
    n = pts.shape[0]
    keep = np.empty(n, np.int64)
    keep[0] = 0
    m = 1
    a = 0
    e = 1
    while e < n - 1:
        ok = True
        ax, ay, az = pts[a, 0], pts[a, 1], pts[a, 2]
        dx, dy, dz = pts[e + 1, 0] - ax, pts[e + 1, 1] - ay, pts[e + 1, 2] - az
        ll = dx * dx + dy * dy + dz * dz
        for i in range(a + 1, e + 1):
            px, py, pz = pts[i, 0] - ax, pts[i, 1] - ay, pts[i, 2] - az
            t = 0.0
            if ll > 0.0:
                t = min(1.0, max(0.0, (px * dx + py * dy + pz * dz) / ll))
            qx, qy, qz = px - t * dx, py - t * dy, pz - t * dz
            if qx * qx + qy * qy + qz * qz > tol * tol:
                ok = False
                break
        if ok:
            e += 1
        else:
            keep[m] = e
            m += 1
            a = e
            e = a + 1
    keep[m] = n - 1
    return keep[: m + 1]


def merge_polyline(points_mm: np.ndarray, tol_mm: float) -> np.ndarray:
    """Indices of the points kept so that every dropped point lies within tol_mm of its
    G1 segment; the first and last points are always kept."""
    pts = np.ascontiguousarray(points_mm, dtype=float)
    if len(pts) < 2:
        raise StreamProgramError("a polyline needs at least two points")
    if not tol_mm > 0:
        raise StreamProgramError(f"merge tolerance must be > 0, got {tol_mm}")
    return _merge_kernel(pts, float(tol_mm))


class _PeriodCursor:
    """The IPO's period batches, read in step with the entities (lines never decrease)."""

    def __init__(self, batches: Iterator):
        self._it = batches
        self._pos = np.empty((0, 3))
        self._feed = np.empty(0)
        self._line = np.empty(0, np.int64)

    def _fill(self) -> bool:
        for item in self._it:
            if hasattr(item, "inc_blu"):
                self._pos = np.concatenate((self._pos, item.pos_mm))
                self._feed = np.concatenate((self._feed, item.feed_mm_s))
                self._line = np.concatenate((self._line, np.asarray(item.line, np.int64)))
                return True
        return False

    def take(self, line: int) -> tuple[np.ndarray, np.ndarray]:
        """(positions, planned feeds) of the periods of program line `line`; earlier periods are dropped."""
        pos, feed = [], []
        while True:
            lo = np.searchsorted(self._line, line, side="left")
            hi = np.searchsorted(self._line, line, side="right")
            pos.append(self._pos[lo:hi])
            feed.append(self._feed[lo:hi])
            self._pos, self._feed, self._line = self._pos[hi:], self._feed[hi:], self._line[hi:]
            if len(self._line) or not self._fill():
                return np.concatenate(pos), np.concatenate(feed)


def _plan_with_ipo(config) -> Callable[[Iterable, tuple], Iterator]:
    from ipo.feed.planner import plan_periods  # the feed stage; imported only when a program has a NURBS

    # grbl rounds to its own steps: the vertices sent are the IPO's period points on the curve,
    # not rounded to the drive's BLU first (that added up to half a BLU per axis to the deviation)
    exact = dataclasses.replace(config, blu_mm=VERTEX_BLU_MM)
    return lambda ents, start_mm: plan_periods(ents, exact, start_mm=start_mm)


class _Builder:
    """grbl's parser state as the stream leaves it: motion mode, plane, F, the work
    coordinates it holds; lines are written against it."""

    def __init__(self, start_mm, merge_tol_mm: float, fmt_: Format, plane: str):
        self.seq = 0
        self.fmt = fmt_
        self.pos = tuple(float(c) for c in start_mm)  # machine mm
        self.held = [fmt_.coord(self.pos[k], k) for k in range(3)]  # work-coordinate text grbl holds
        self.tol = merge_tol_mm
        self.motion: str | None = None  # grbl's motion mode as far as the stream set it
        self.plane, self.feed = plane, None  # feed: the F text grbl holds (None: not set by the stream)
        self.spindle, self.coolant = "M5", ("M9",)
        self._restore: tuple[str, ...] | None = None

    def restore(self) -> tuple[str, ...]:
        if self._restore is None:
            head = RESET_MODES + PLANE_CODE[self.plane] + (self.motion or "") + (f"F{self.feed}" if self.feed else "")
            self._restore = (head, self.spindle, *self.coolant)
        return self._restore

    def _modal(self, motion: str, feed_mm_min: float | None, plane: str | None = None) -> str:
        words = ""
        if plane is not None and plane != self.plane:
            self.plane = plane
            words += PLANE_CODE[plane]
        if motion != self.motion:
            self.motion = motion
            words += motion
        if feed_mm_min is not None and (f := self.fmt.feed(feed_mm_min)) != self.feed:
            self.feed = f
            words += f"F{f}"
        if words:
            self._restore = None
        return words

    def emit(self, source: int, text: str, end=None, arc=None, feed_mm_min=None) -> StreamLine:
        self.seq += 1
        if self.fmt.numbered:
            text = f"N{self.seq}{text}"
        if len(text) > MAX_LINE_CHARS:
            raise StreamProgramError(f"line {source}: {text!r} has {len(text)} characters; grbl takes at "
                                     f"most {MAX_LINE_CHARS} (its 80-byte line buffer)")
        end = self.pos if end is None else tuple(float(c) for c in end)
        sl = StreamLine(self.seq, source, text, self.pos, end, end != self.pos or arc is not None,
                        self.restore(), arc, self.fmt, feed_mm_min)
        self.pos = end
        return sl

    def _changed(self, end) -> str:
        """The axes whose written coordinate differs from what grbl holds; updates what it holds."""
        axes = ""
        for k in range(3):
            t = self.fmt.coord(end[k], k)
            if t != self.held[k]:
                axes += AXIS_LETTERS[k]
                self.held[k] = t
        return axes

    def straight(self, source: int, motion: str, end, feed_mm_min=None, g53=False) -> list[StreamLine]:
        """A G0/G1 with the axis words that change (G53: in machine coordinates)."""
        if g53:
            axes = "".join(AXIS_LETTERS[k] for k in range(3) if fmt(end[k], self.fmt.tol_mm)
                           != fmt(self.pos[k], self.fmt.tol_mm))
            self._changed(end)
            if not axes:
                return []
            modal = self._modal(motion, feed_mm_min)
            words = "".join(f"{a}{fmt(end['XYZ'.index(a)], self.fmt.tol_mm)}" for a in axes)
            return [self.emit(source, f"G53{motion}{modal.replace(motion, '', 1)}{words}", end, None, feed_mm_min)]
        axes = self._changed(end)
        if not axes:
            return []
        modal = self._modal(motion, feed_mm_min)
        words = "".join(f"{a}{self.held['XYZ'.index(a)]}" for a in axes)
        return self._split(source, modal, words, end, None, feed_mm_min)

    def _split(self, source, modal, words, end, arc, feed_mm_min) -> list[StreamLine]:
        """One line, or the modal words and the motion on two where one would be too long."""
        n = len(f"N{self.seq + 1}") if self.fmt.numbered else 0
        if n + len(modal) + len(words) <= MAX_LINE_CHARS or not modal:
            return [self.emit(source, modal + words, end, arc, feed_mm_min)]
        return [self.emit(source, modal), self.emit(source, words, end, arc, feed_mm_min)]

    def arc(self, e: Arc) -> list[StreamLine]:
        a, b, n = PLANE_AXES[e.plane]
        parts = e.turns + 1  # grbl has no P word for turns: equal pieces, each at most one revolution
        c = np.asarray(e.center, float)
        s = np.asarray(e.start, float)
        r0 = np.array([s[a] - c[a], s[b] - c[b]])
        center = tuple(float(v) for v in c)
        out = []
        for k in range(1, parts + 1):
            if k == parts:
                end = e.end
            else:
                th = e.sweep_rad * k / parts
                p = s.copy()
                p[a] = c[a] + r0[0] * math.cos(th) - r0[1] * math.sin(th)
                p[b] = c[b] + r0[0] * math.sin(th) + r0[1] * math.cos(th)
                p[n] = s[n] + (e.end[n] - s[n]) * k / parts
                end = tuple(p)
            start_work = tuple(float(t) for t in self.held)
            feed = e.feed_mm_s * 60.0
            modal = self._modal("G3" if e.ccw else "G2", feed, e.plane)
            words = arc_words(self.fmt, start_work, end, center, e.plane, self._changed(end))
            out += self._split(e.line, modal, words, end, (center, e.plane, e.ccw, feed), feed)
        return out

    def nurbs(self, e: Nurbs, pos_mm: np.ndarray, feed_mm_s: np.ndarray) -> list[StreamLine]:
        if len(pos_mm) == 0:
            raise StreamProgramError(f"line {e.line}: the IPO planned no periods for this NURBS")
        pts = np.vstack((np.asarray(self.pos, float)[None, :], pos_mm))
        if np.linalg.norm(pts[-1] - np.asarray(e.end)) > 1e-9:  # the last period may have been carried on
            pts = np.vstack((pts, np.asarray(e.end, float)[None, :]))
            feed_mm_s = np.r_[feed_mm_s, feed_mm_s[-1]]
        keep = merge_polyline(pts, self.tol - self.fmt.written_rounding_mm)
        out = []
        for i0, i1 in zip(keep[:-1], keep[1:]):
            # the IPO's planned speed over these periods
            out += self.straight(e.line, "G1", tuple(float(v) for v in pts[i1]),
                                 60.0 * float(np.mean(feed_mm_s[i0:i1])))
        return out

    def event(self, e, notices: list[str]) -> list[StreamLine]:
        """A non-motion entity's lines."""
        if isinstance(e, Dwell):
            return [self.emit(e.line, f"G4P{fmt(e.seconds, DWELL_TOL_S)}")]
        if isinstance(e, Spindle):
            self.spindle = "M5" if e.direction is None else \
                f"{'M3' if e.direction == 'cw' else 'M4'}S{fmt(e.rpm, RPM_TOL)}"
            self._restore = None
            return [self.emit(e.line, self.spindle)]
        if isinstance(e, Coolant):
            self.coolant = tuple(c for c, on in (("M7", e.mist), ("M8", e.flood)) if on) or ("M9",)
            self._restore = None
            return [self.emit(e.line, code)
                    for code in (("M9",) + self.coolant if self.coolant != ("M9",) else self.coolant)]
        if isinstance(e, ToolChange):
            notices.append(f"line {e.line}: grbl has no tool changer: the stream pauses (M0) for T{e.tool}; "
                           f"resume with ~")
            return [self.emit(e.line, "M0")]
        if isinstance(e, Auxiliary):
            notices.append(f"line {e.line}: {e.code} ({e.text}) is not sent; grbl has no such function")
            return []
        if isinstance(e, Message):
            notices.append(f"line {e.line}: message {e.text!r} shown here only; grbl does not display messages")
            return []
        if isinstance(e, Stop):
            return [self.emit(e.line, "M1" if e.optional else "M0")]
        if isinstance(e, ProgramEnd):
            return [self.emit(e.line, "M2")]
        raise StreamProgramError(f"line {getattr(e, 'line', '?')}: cannot stream {type(e).__name__}")


def preamble(modal: tuple[str, ...]) -> str:
    """The words that bring grbl's parser (its `$G` words) to what vcnc writes in: mm,
    absolute, units per minute; empty when it is there already."""
    have = set(modal)
    return "".join(w for w, other in (("G21", "G20"), ("G90", "G91"), ("G94", "G93")) if other in have)


GRBL_RESET_MODAL = ("G0", "G54", "G17", "G21", "G90", "G94", "M5", "M9", "T0", "F0", "S0")


def stream_lines(entities: Iterable, config, **options) -> Iterator[StreamLine]:
    """The stream for a program's entities (stream_groups' lines, one after the other)."""
    for _, lines in stream_groups(entities, config, **options):
        yield from lines


def stream_groups(entities: Iterable, config, *, start_mm=(0.0, 0.0, 0.0), fmt_: Format | None = None,
                  modal: tuple[str, ...] = GRBL_RESET_MODAL, g53_lines: frozenset = frozenset(),
                  merge_tol_mm: float | None = None,
                  plan: Callable[[Iterable, tuple], Iterator] | None = None,
                  notices: list[str] | None = None, ipo_from_start: bool = False
                  ) -> Iterator[tuple[object, list[StreamLine]]]:
    """(entity, its lines) in stream order (entity None for the preamble): the stream for a
    program's entities, interpreted from `start_mm` (machine coordinates, where grbl stands)
    with grbl's parser in the `modal` state ($G words). `fmt_` says the work frame and
    precision; `g53_lines` the (file, line) of the source lines that are G53 moves (file
    None for the program itself, as in the entities). `plan(entities, start_mm)` replaces the
    IPO (tests only); `notices` collects what grbl cannot do and vcnc did instead.

    The IPO runs in step with the stream, so its look-ahead sees every later entity, and
    memory stays bounded. It starts at the first NURBS, from standstill there, unless
    `ipo_from_start` (for a program known to hold a NURBS): then it plans from the
    program's start and the first NURBS is entered at the speed the IPO carries into it."""
    fmt_ = fmt_ or Format(tol_mm=config.blu_mm / 10.0)
    tol = config.chord_tol_mm if merge_tol_mm is None else merge_tol_mm
    if not tol > fmt_.written_rounding_mm:
        raise StreamProgramError(f"merge tolerance {tol} mm must exceed what writing the vertices can move "
                                 f"them ({fmt_.written_rounding_mm:.2g} mm)")
    notices = [] if notices is None else notices
    plane = next((p for w, p in (("G18", "ZX"), ("G19", "YZ")) if w in modal), "XY")
    b = _Builder(start_mm, tol, fmt_, plane)
    ents, for_ipo = itertools.tee(entities)
    cursor = _PeriodCursor(iter((plan or _plan_with_ipo(config))(for_ipo, b.pos))) if ipo_from_start else None
    if pre := preamble(modal):
        yield None, [b.emit(0, pre)]
    for e in ents:
        if cursor is None and isinstance(e, Nurbs):
            cursor = _PeriodCursor(iter((plan or _plan_with_ipo(config))(for_ipo, b.pos)))
        if isinstance(e, Rapid):
            yield e, b.straight(e.line, "G0", e.end, g53=(e.file, e.line) in g53_lines)
        elif isinstance(e, Line):
            yield e, b.straight(e.line, "G1", e.end, e.feed_mm_s * 60.0, g53=(e.file, e.line) in g53_lines)
        elif isinstance(e, Arc):
            yield e, b.arc(e)
        elif isinstance(e, Nurbs):
            yield e, b.nurbs(e, *cursor.take(e.line))
        else:
            yield e, b.event(e, notices)
        if cursor is None:
            next(for_ipo, None)  # keep the tee's buffer empty while the IPO is not running
        else:
            cursor.take(e.line)


def resume_text(line: StreamLine, at_mm) -> str:
    """The text of `line` sent from machine position `at_mm` instead of its own start
    (resume mid-line, after the line's `restore`): its motion word and every axis that
    still moves; an arc gets its IJK from the new start."""
    f = line.fmt
    if line.text.lstrip("N0123456789").startswith("G53"):  # absolute in machine coordinates: from anywhere
        return line.text
    axes = "".join(AXIS_LETTERS[k] for k in range(3) if f.coord(line.end_mm[k], k) != f.coord(at_mm[k], k))
    if line.arc is None:
        words = "G0" if line.feed_mm_min is None else "G1"
        words += "".join(f"{AXIS_LETTERS[k]}{f.coord(line.end_mm[k], k)}" for k in range(3) if AXIS_LETTERS[k] in axes)
    else:
        center, plane, ccw, _ = line.arc
        at_work = tuple(at_mm[k] - f.frame_mm[k] for k in range(3))
        words = ("G3" if ccw else "G2") + arc_words(f, at_work, line.end_mm, center, plane, axes)
    return (f"N{line.seq}" if f.numbered else "") + words
