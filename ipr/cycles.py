"""Canned cycles G73, G74, G81..G86, G88, G89 expanded into rapids, lines, dwells and spindle events.

The expansion is LinuxCNC's (interp_cycles.cc, convert_cycle_xy and CYCLE_MACRO), in every
plane: the cycle's "Z" is the plane's normal axis (G17 Z, G18 Y, G19 X) and its "X Y" the
two in-plane axes in ipr.entities.PLANE_AXES order. The arithmetic runs in program units and
program coordinates, as rs274 does (so a peck lands on the same side of the bottom), and
each point goes to machine mm at the end. The moves run in exact path, G61 (LinuxCNC switches
to CANON_EXACT_PATH for the cycle and back after it).

Sticky values (RS274NGC): R, the normal-axis word, P and Q are remembered while the same
cycle stays active; the initial level (G98's return height) is the normal-axis position when
the first cycle block after another motion ran. In G91 X/Y are increments per repeat (L),
R is relative to the initial level and Z to R.
"""
from __future__ import annotations

from typing import NamedTuple

from ipr import polar
from ipr.dialect import dwell_seconds
from ipr.entities import EXACT_PATH, PLANE_AXES, Dwell, Line, Rapid, Spindle, Stop
from ipr.errors import BlockError, code_name
from ipr.gcodes import (CANNED_CYCLES, CYCLE_BORE, CYCLE_BORE_DWELL, CYCLE_BORE_MANUAL, CYCLE_BORE_STOP,
                        CYCLE_DRILL, CYCLE_DRILL_DWELL, CYCLE_PECK, CYCLE_PECK_CHIPBREAK, CYCLE_TAP,
                        CYCLE_TAP_LEFT, INVERSE_TIME)
from ipr.modal import to_machine, to_program
from ipr.modes import move_feed_mm_s

PECK_CLEARANCE_INCH = 0.010   # LinuxCNC's G73/G83 back-off (parameter_g7x_peck_clearance)
_AXES = "XYZ"
# a P word (dwell) is required when the cycle starts
_P_CYCLES = (CYCLE_DRILL_DWELL, CYCLE_BORE_STOP, CYCLE_BORE_MANUAL, CYCLE_BORE_DWELL)
_Q_CYCLES = (CYCLE_PECK_CHIPBREAK, CYCLE_PECK)
_TAPPING = {CYCLE_TAP: "cw", CYCLE_TAP_LEFT: "ccw"}


class CycleMemory(NamedTuple):
    """What a cycle block leaves for the next one (program units)."""

    motion: int
    r: float
    cc: float            # the normal-axis word as written (G91: relative to R)
    p: float
    q: float
    initial: float       # G98 level, program units of the normal axis


class _Emitter:
    """Moves of one cycle block, from program-unit points (a, b, cc) to machine entities."""

    def __init__(self, st, line: int, out: list, plane: str, feed_mm_s: float):
        self.st, self.line, self.out, self.feed = st, line, out, feed_mm_s
        self.a, self.b, self.n = PLANE_AXES[plane]
        self.pos = st.pos

    def _point(self, aa: float, bb: float, cc: float):
        p = list(to_program(self.st, self.pos))
        u = self.st.unit
        p[self.a], p[self.b], p[self.n] = aa * u, bb * u, cc * u
        return to_machine(self.st, p)

    def traverse(self, aa, bb, cc, path=EXACT_PATH) -> None:
        end = self._point(aa, bb, cc)
        self.out.append(Rapid(self.line, self.pos, end, path))
        self.pos = end

    def feed_to(self, aa, bb, cc) -> None:
        end = self._point(aa, bb, cc)
        self.out.append(Line(self.line, self.pos, end, self.feed, EXACT_PATH))
        self.pos = end

    def dwell(self, seconds: float) -> None:
        if seconds > 0.0:
            self.out.append(Dwell(self.line, seconds))

    def spindle(self, direction) -> None:
        self.out.append(Spindle(self.line, self.st.spindle_rpm, direction))


def _word(spec, vals, letter: str):
    i = spec.index.get(letter)
    return None if i is None else vals[i]


def run_cycle(st, spec, vals, out: list, notices: list, line: int, motion_before: int | None,
              dialect: str = "linuxcnc") -> None:
    """Steps of LinuxCNC's convert_cycle + convert_cycle_xy for the active cycle `st.motion`."""
    motion, where = st.motion, spec.where.get("motion")
    name = code_name("G", motion / 10)
    # 1. the conditions of the whole cycle
    if st.feed_mm_s <= 0.0:
        raise BlockError("E-FEED-ZERO", f"{name} feeds with feed rate zero (program an F word)", where)
    if st.feed_mode == INVERSE_TIME:
        raise BlockError("E-CYCLE", f"{name} cannot run in inverse time feed (G93)", where)
    if st.comp is not None:
        raise BlockError("E-CYCLE", f"{name} cannot run with cutter compensation on (G40 first)", where)
    a, b, n = PLANE_AXES[st.plane]
    same = motion_before == motion and st.cycle is not None and st.cycle.motion == motion
    mem = st.cycle if st.cycle is not None else CycleMemory(motion, 0.0, 0.0, 0.0, 0.0, 0.0)
    # 2. R, the normal-axis word, L, P, Q: given, or remembered while the same cycle is active
    r_word = _word(spec, vals, "R")
    if r_word is None:
        if not same:
            raise BlockError("E-CYCLE", f"{name} needs an R word (retract plane) when it starts", where)
        r_word = mem.r
    cc_word = _word(spec, vals, _AXES[n])
    if cc_word is None:
        if not same:
            raise BlockError("E-CYCLE", f"{name} needs a {_AXES[n]} word (bottom) when it starts in "
                             f"{st.plane}", where)
        cc_word = mem.cc
    repeats = _word(spec, vals, "L")
    if repeats is None:
        repeats = 1
    elif repeats != round(repeats) or repeats < 1:
        raise BlockError("E-CYCLE", f"{name} L{repeats:g}: the repeat count must be a whole number >= 1",
                         spec.index["L"])
    p = _word(spec, vals, "P")
    if p is None:
        if motion in _P_CYCLES and not (motion_before == motion):
            raise BlockError("E-CYCLE", f"{name} needs a P word (dwell seconds) when it starts", where)
        p = mem.p
    elif p < 0.0:
        raise BlockError("E-VALUE", f"negative dwell time P{p:g}", spec.index["P"])
    q = _word(spec, vals, "Q")
    if motion in _Q_CYCLES:
        if q is None:
            if motion_before != motion:
                raise BlockError("E-CYCLE", f"{name} needs a Q word (peck depth) when it starts", where)
            q = mem.q
        if q <= 0.0:
            raise BlockError("E-CYCLE", f"{name} peck depth Q{q:g} must be > 0", spec.index.get("Q", where))
    else:
        q = mem.q
    _check_spindle(st, motion, name, where)
    # 3. the levels, in program units: LinuxCNC keeps the initial level while cycles follow cycles
    u = st.unit
    here = [c / u for c in to_program(st, st.pos)]
    current_cc = here[n]
    old_cc = mem.initial if (st.cycle is not None and motion_before in _ALL) else current_cc
    words = {k: vals[i] for k, i in spec.axis_idx}
    if spec.polar is not None and st.absolute:
        words[a], words[b] = polar.end_xy(st, spec, vals, here, True)
    if st.absolute:
        aa_inc = bb_inc = 0.0
        r, cc = r_word, cc_word
        aa, bb = words.get(a, here[a]), words.get(b, here[b])
    else:
        aa_inc, bb_inc = words.get(a, 0.0), words.get(b, 0.0)
        r = r_word + old_cc
        cc = r + cc_word
        aa, bb = here[a], here[b]
    if r < cc:
        raise BlockError("E-CYCLE", f"{name}: the R plane ({r:g}) is below the bottom ({cc:g})",
                         spec.index.get("R", where))
    em = _Emitter(st, line, out, st.plane, move_feed_mm_s(st, spec, vals, where, st.pos, st.pos))
    # 4. below the R plane: straight up to it first (before LinuxCNC switches to exact stop)
    initial = old_cc
    if old_cc < r:
        em.traverse(here[a], here[b], r, st.path)
        old_cc = current_cc = r
    clear = r if st.retract_r else old_cc
    # 5. CYCLE_MACRO: L repeats, each positioned over its hole, then the cycle's own moves
    for k in range(int(repeats)):
        if spec.polar is not None and not st.absolute:
            # rs274 turns each repeat about the origin again (interp_cycles.cc)
            aa, bb = polar.end_xy(st, spec, vals, (aa, bb), False)
        else:
            aa, bb = aa + aa_inc, bb + bb_inc
        if k == 0 and current_cc > r:
            em.traverse(aa, bb, current_cc)
            em.traverse(aa, bb, r)
        else:
            em.traverse(aa, bb, clear)
            if clear > r:
                em.traverse(aa, bb, r)
        _body(em, motion, aa, bb, r, clear, cc, dwell_seconds(dialect, p), q, st)
    st.pos = em.pos
    st.cycle = CycleMemory(motion, r_word, cc_word, p, q, initial)
    if motion == CYCLE_BORE_MANUAL:
        notices.append(("N-RECORDED", "G88: the operator retracts by hand after the stop; vcnc shows "
                        "that retract as a rapid to the clear level", where))


_ALL = CANNED_CYCLES


def _check_spindle(st, motion: int, name: str, where) -> None:
    if motion in (CYCLE_BORE_STOP, CYCLE_BORE_MANUAL) and st.spindle_dir is None:
        raise BlockError("E-SPINDLE", f"{name} needs the spindle turning (M3 or M4)", where)
    if motion in _TAPPING and st.spindle_dir != _TAPPING[motion]:
        way = "clockwise (M3)" if motion == CYCLE_TAP else "counter-clockwise (M4)"
        raise BlockError("E-SPINDLE", f"{name} taps with the spindle turning {way}", where)


def _body(em: _Emitter, motion: int, aa, bb, r, clear, bottom, p, q, st) -> None:
    """One hole, from the R plane (interp_cycles.cc: convert_cycle_g73 .. g89)."""
    if motion in (CYCLE_PECK_CHIPBREAK, CYCLE_PECK):
        back = PECK_CLEARANCE_INCH * 25.4 / st.unit
        depth = r - q
        while depth > bottom:
            em.feed_to(aa, bb, depth)
            if motion == CYCLE_PECK:
                em.traverse(aa, bb, r)
            em.traverse(aa, bb, depth + back)
            depth = depth - q
        em.feed_to(aa, bb, bottom)
        em.traverse(aa, bb, clear)
    elif motion in (CYCLE_DRILL, CYCLE_DRILL_DWELL):
        em.feed_to(aa, bb, bottom)
        if motion == CYCLE_DRILL_DWELL:
            em.dwell(p)
        em.traverse(aa, bb, clear)
    elif motion == CYCLE_BORE:
        em.feed_to(aa, bb, bottom)
        em.feed_to(aa, bb, r)
        em.traverse(aa, bb, clear)
    elif motion == CYCLE_BORE_DWELL:
        em.feed_to(aa, bb, bottom)
        em.dwell(p)
        em.feed_to(aa, bb, clear)
    elif motion in _TAPPING:
        # floating-chuck tapping: feed in, reverse the spindle, feed out, restore it
        way = _TAPPING[motion]
        other = "ccw" if way == "cw" else "cw"
        em.feed_to(aa, bb, bottom)
        em.spindle(None)
        em.spindle(other)
        em.dwell(p)
        em.feed_to(aa, bb, clear)
        em.spindle(None)
        em.spindle(way)
    else:   # 860 boring with a rapid retract, 880 boring with a manual retract
        way = st.spindle_dir
        em.feed_to(aa, bb, bottom)
        em.dwell(p)
        em.spindle(None)
        if motion == CYCLE_BORE_MANUAL:
            em.out.append(Stop(em.line, optional=False))
        em.traverse(aa, bb, clear)
        em.spindle(way)
