"""What vcnc streams to grbl: entities -> numbered text lines, each at most 79 characters.

G0/G1 pass through in absolute coordinates with the motion code, every axis and F
written out on every line; G2/G3 pass through as arcs (incremental IJK from the
line's start, the plane code on the line; extra full turns become separate arcs).
NURBS, which grbl cannot run, go through vcnc's IPO (`ipo.feed.planner.plan_periods`): the
per-period path is merged into G1 segments within `merge_tol_mm` of the period
points, and each segment carries the IPO's planned feed (the mean of the planned path
speed over its periods), so grbl runs the curve at the speed vcnc planned.
Numbers have 4 decimals in mm, feeds in mm/min. Positions are vcnc's (the program's,
with the machine file's work offsets and tool lengths applied); grbl reads them in its
own active work coordinate system, so with the default machine file (no offsets) the
part sits where grbl's G54 zero is.

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

PREAMBLE = "G21G90G91.1G94"  # mm, absolute, incremental IJK (grbl's only arc mode), units/min
PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}
OFFSET_LETTERS = "IJK"
DIGITS = 4  # decimals of every number sent (mm)
WRITTEN_ROUNDING_MM = 0.5 * 10.0**-DIGITS * math.sqrt(3.0)  # how far rounding a vertex can move it
VERTEX_BLU_MM = 1e-7  # the IPO's resolution for the vertices sent (far below DIGITS)


class StreamProgramError(ValueError):
    """The program cannot be expressed in lines grbl accepts."""


@dataclass(frozen=True, slots=True)
class StreamLine:
    """One line on the wire (without its newline)."""

    seq: int  # 1-based position in the stream
    source_line: int  # program line (0 for the stream's own set-up)
    text: str
    start_mm: tuple[float, float, float]  # commanded position before the line
    end_mm: tuple[float, float, float]  # after it
    motion: bool  # moves the machine
    restore: tuple[str, ...]  # lines that set up the modal state (plane, F, spindle, coolant) this line runs in
    arc: tuple | None = None  # (center_mm, plane, ccw, feed_mm_min) to re-emit the arc from elsewhere


def num(v: float) -> str:
    s = f"{v:.{DIGITS}f}"
    return "0.0000" if s == "-0.0000" else s


def _xyz(p) -> str:
    return f"X{num(p[0])}Y{num(p[1])}Z{num(p[2])}"


def arc_text(start, end, center, plane: str, ccw: bool, feed_mm_min: float) -> tuple[str, str]:
    """(modal words, motion words) of an arc from `start`; IJK are centre - start in the plane."""
    a, b, _ = PLANE_AXES[plane]
    offs = "".join(f"{OFFSET_LETTERS[k]}{num(center[k] - start[k])}" for k in sorted((a, b)))
    return f"{PLANE_CODE[plane]}F{num(feed_mm_min)}", f"{'G3' if ccw else 'G2'}{_xyz(end)}{offs}"


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
    def __init__(self, start_mm, merge_tol_mm: float):
        self.seq = 0
        self.pos = tuple(float(c) for c in start_mm)
        self.tol = merge_tol_mm
        self.plane, self.feed, self.spindle, self.coolant = "XY", None, "M5", ("M9",)
        self.notices: list[str] = []

    def restore(self) -> tuple[str, ...]:
        head = PREAMBLE + PLANE_CODE[self.plane] + (f"F{num(self.feed)}" if self.feed else "")
        return (head, self.spindle, *self.coolant)

    def emit(self, source: int, text: str, end=None, arc=None) -> StreamLine:
        if len(text) > MAX_LINE_CHARS:
            raise StreamProgramError(f"line {source}: {text!r} has {len(text)} characters; grbl takes at "
                                     f"most {MAX_LINE_CHARS} (its 80-byte line buffer)")
        end = self.pos if end is None else tuple(float(c) for c in end)
        self.seq += 1
        sl = StreamLine(self.seq, source, text, self.pos, end, end != self.pos or arc is not None,
                        self.restore(), arc)
        self.pos = end
        return sl

    def motion(self, source: int, modal: str, words: str, end, arc=None) -> list[StreamLine]:
        """A motion line with its modal words; split in two where one line would be too long."""
        if len(modal) + len(words) <= MAX_LINE_CHARS:
            return [self.emit(source, modal + words, end, arc)]
        return [self.emit(source, modal), self.emit(source, words, end, arc)]

    def arc(self, e: Arc) -> list[StreamLine]:
        a, b, n = PLANE_AXES[e.plane]
        parts = e.turns + 1  # grbl has no P word for turns: equal pieces, each at most one revolution
        c = np.asarray(e.center, float)
        s = np.asarray(e.start, float)
        r0 = np.array([s[a] - c[a], s[b] - c[b]])
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
            self.plane, self.feed = e.plane, e.feed_mm_s * 60.0
            center = tuple(float(v) for v in c)
            modal, words = arc_text(self.pos, end, center, e.plane, e.ccw, self.feed)
            out += self.motion(e.line, modal, words, end, (center, e.plane, e.ccw, self.feed))
        return out

    def nurbs(self, e: Nurbs, pos_mm: np.ndarray, feed_mm_s: np.ndarray) -> list[StreamLine]:
        if len(pos_mm) == 0:
            raise StreamProgramError(f"line {e.line}: the IPO planned no periods for this NURBS")
        pts = np.vstack((np.asarray(self.pos, float)[None, :], pos_mm))
        if np.linalg.norm(pts[-1] - np.asarray(e.end)) > 1e-9:  # the last period may have been carried on
            pts = np.vstack((pts, np.asarray(e.end, float)[None, :]))
            feed_mm_s = np.r_[feed_mm_s, feed_mm_s[-1]]
        keep = merge_polyline(pts, self.tol - WRITTEN_ROUNDING_MM)
        out = []
        for i0, i1 in zip(keep[:-1], keep[1:]):
            if not np.any(pts[i1] != pts[i0]):
                continue
            self.feed = 60.0 * float(np.mean(feed_mm_s[i0:i1]))  # the IPO's planned speed over these periods
            end = tuple(float(v) for v in pts[i1])
            out += self.motion(e.line, "G1", f"{_xyz(end)}F{num(self.feed)}", end)
        return out


def stream_lines(entities: Iterable, config, *, start_mm=(0.0, 0.0, 0.0), merge_tol_mm: float | None = None,
                 plan: Callable[[Iterable, tuple], Iterator] | None = None,
                 notices: list[str] | None = None, ipo_from_start: bool = False) -> Iterator[StreamLine]:
    """The stream for a program's entities. `plan(entities, start_mm)` replaces the IPO
    (tests only); `notices` collects what grbl cannot do and vcnc did instead.

    The IPO runs in step with the stream, so its look-ahead sees every later entity, and
    memory stays bounded. It starts at the first NURBS, from standstill there, unless
    `ipo_from_start` (for a program known to hold a NURBS): then it plans from the
    program's start and the first NURBS is entered at the speed the IPO carries into it."""
    tol = config.chord_tol_mm if merge_tol_mm is None else merge_tol_mm
    if not tol > WRITTEN_ROUNDING_MM:
        raise StreamProgramError(f"merge tolerance {tol} mm must exceed what writing the vertices with "
                                 f"{DIGITS} decimals can move them ({WRITTEN_ROUNDING_MM:.2g} mm)")
    b = _Builder(start_mm, tol)
    ents, for_ipo = itertools.tee(entities)
    cursor = _PeriodCursor(iter((plan or _plan_with_ipo(config))(for_ipo, b.pos))) if ipo_from_start else None
    yield b.emit(0, PREAMBLE + "G17")
    for e in ents:
        if cursor is None and isinstance(e, Nurbs):
            cursor = _PeriodCursor(iter((plan or _plan_with_ipo(config))(for_ipo, b.pos)))
        if isinstance(e, Rapid):
            yield from b.motion(e.line, "G0", _xyz(e.end), e.end)
        elif isinstance(e, Line):
            b.feed = e.feed_mm_s * 60.0
            yield from b.motion(e.line, "G1", f"{_xyz(e.end)}F{num(b.feed)}", e.end)
        elif isinstance(e, Arc):
            yield from b.arc(e)
        elif isinstance(e, Nurbs):
            yield from b.nurbs(e, *cursor.take(e.line))
        elif isinstance(e, Dwell):
            yield b.emit(e.line, f"G4P{num(e.seconds)}")
        elif isinstance(e, Spindle):
            b.spindle = "M5" if e.direction is None else f"{'M3' if e.direction == 'cw' else 'M4'}S{num(e.rpm)}"
            yield b.emit(e.line, b.spindle)
        elif isinstance(e, Coolant):
            b.coolant = tuple(c for c, on in (("M7", e.mist), ("M8", e.flood)) if on) or ("M9",)
            for code in (("M9",) + b.coolant if b.coolant != ("M9",) else b.coolant):
                yield b.emit(e.line, code)
        elif isinstance(e, ToolChange):
            (notices if notices is not None else b.notices).append(
                f"line {e.line}: grbl has no tool changer: the stream pauses (M0) for T{e.tool}; resume with ~")
            yield b.emit(e.line, "M0")
        elif isinstance(e, Auxiliary):
            (notices if notices is not None else b.notices).append(
                f"line {e.line}: {e.code} ({e.text}) is not sent; grbl has no such function")
        elif isinstance(e, Message):
            (notices if notices is not None else b.notices).append(
                f"line {e.line}: message {e.text!r} shown here only; grbl does not display messages")
        elif isinstance(e, Stop):
            yield b.emit(e.line, "M1" if e.optional else "M0")
        elif isinstance(e, ProgramEnd):
            yield b.emit(e.line, "M2")
        else:
            raise StreamProgramError(f"line {getattr(e, 'line', '?')}: cannot stream {type(e).__name__}")
        if cursor is None:
            next(for_ipo, None)  # keep the tee's buffer empty while the IPO is not running
        else:
            cursor.take(e.line)


def resume_text(line: StreamLine, at_mm) -> str:
    """The text of `line` sent from `at_mm` instead of its own start (resume mid-line):
    absolute G0/G1 need no change; an arc gets its IJK from the new start."""
    if line.arc is None:
        return line.text
    center, plane, ccw, feed = line.arc
    modal, words = arc_text(at_mm, line.end_mm, center, plane, ccw, feed)
    return modal + words if len(modal) + len(words) <= MAX_LINE_CHARS else words
