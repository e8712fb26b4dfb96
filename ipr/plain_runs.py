"""Runs of plain G0..G3 lines, read and executed by compiled kernels (the bulk of CAM output).

A CAM program is mostly lines like `G1 X12.5 Y-3.25 Z0.1 F1200` or ` X3.2040 Z-0.1539`, with an
arc now and then (`G3 X3.094 Y4.858 Z-0.154 I0.0013 K0.0205`). Per line, the Python path
(ipr.shapes, ipr.plain) costs a regular expression, a dictionary look-up and a generated step
function; here a chunk of lines is read at once (`scan`) and a run of them is executed at once
(`execute`), in numba, and Python only builds the entities.

`scan` marks a line *plain* only when it is, character for character, of this form (anything
else is left to the Python path, which reads it as it always does):

    [blanks] [N digits] words [blanks] [\\r]     word: G0..G3 / G00..G03, or X Y Z F I J K R and a number
    number: [+|-] digits [. digits] | [+|-] . digits, at most 15 significant digits and 22 decimals

with blanks between words, each letter at most once, either case. Such a number is read as its
digits (an integer, exact below 2**53) divided by a power of ten (exact up to 10**22): one
correctly rounded division, so the value is exactly Python's float() of the text.

`execute` does what ipr.plain's step functions do with each line, with the same arithmetic in
the same order (F * unit / 60; axis * unit + offset in G90, position + axis * unit in G91; an
arc's centre as the start plus I/J/K * unit), and stops at the first line that a step would
hand back to the general path (another motion mode, a negative F, a G1 with axes at feed zero,
an arc at feed zero, in G90.1 or with offsets the plane does not take), at a radius-format arc
(its centre goes through math.hypot, whose last bit numba need not share with Python) and at an
arc whose end is not well inside the tolerances of ipr.arcs.center_from_offsets (its
decisions go through hypot too; the margin, 1e-12 of the radius, is thousands of times the
rounding of either hypot): the Python path then reads that line, moves its centre or reports
its error. Lines keep their numbers; results are identical, bit for bit, to the Python path's
(tests/ipr/test_ipr_plain_runs.py and tests/ipr/test_ipr_paths.py compare them).
"""
from __future__ import annotations

import math
from itertools import compress, repeat

import numba as nb
import numpy as np

from ipr.arcs import ARC_TOL_REL, unit_tolerances_mm
from ipr.entities import PLANE_AXES, Arc, Line, Rapid, build_many
from ipr.gcodes import MOTION_ARC_CCW, MOTION_ARC_CW, MOTION_LINEAR, MOTION_RAPID

# columns of the scanned values (I, J, K: OFFSET + axis) and bits of `words` (1 << column, and G)
X, Y, Z, F, OFFSET, R = 0, 1, 2, 3, 4, 7
AXIS_BITS, OFFSET_BITS = 7, 7 << OFFSET
HAS_G = 1 << 8
_COLUMN = np.full(256, -1, np.int8)   # a lower-case letter's column
_COLUMN[[ord(c) for c in "xyzfijkr"]] = np.arange(8)
_MAX_DIGITS = 15
_MAX_DECIMALS = 22
_POW10 = np.array([10.0 ** k for k in range(_MAX_DECIMALS + 1)])


@nb.njit(cache=True)
def _blank(c: int) -> bool:
    return c == 32 or c == 9


@nb.njit(cache=True)
def scan(data: np.ndarray, n_lines: int):
    """Per line of `data` (the chunk's lines joined by \\n, UTF-8): plain (bool), its motion code
    (0 / 10 / 20 / 30, -1 without G), which words it has (bit 1 << column of X Y Z F I J K R, and
    HAS_G) and their values."""
    plain = np.zeros(n_lines, np.bool_)
    motion = np.full(n_lines, -1, np.int8)
    words = np.zeros(n_lines, np.int16)
    values = np.zeros((n_lines, 8), np.float64)
    pos, n, size = 0, 0, len(data)
    while n < n_lines:
        end = pos
        while end < size and data[end] != 10:
            end += 1
        plain[n] = _scan_line(data, pos, end, n, motion, words, values)
        pos = end + 1
        n += 1
    return plain, motion, words, values


@nb.njit(cache=True)
def _scan_line(data, i, end, n, motion, words, values) -> bool:
    if end > i and data[end - 1] == 13:   # \r is a blank at the end of a line
        end -= 1
    while i < end and _blank(data[i]):
        i += 1
    if i < end and (data[i] == 78 or data[i] == 110):   # N: a line number, digits only
        i += 1
        if i >= end or not 48 <= data[i] <= 57:
            return False
        while i < end and 48 <= data[i] <= 57:
            i += 1
        if i < end and not _blank(data[i]):
            return False
    seen = 0
    while True:
        while i < end and _blank(data[i]):
            i += 1
        if i >= end:
            words[n] = seen
            return seen != 0
        c = data[i] | 32   # lower case
        i += 1
        if c == 103:   # g
            if seen & HAS_G or i >= end:
                return False
            digits = 0
            code = 0
            while i < end and 48 <= data[i] <= 57 and digits < 3:
                code = code * 10 + data[i] - 48
                digits += 1
                i += 1
            if digits == 0 or digits > 2 or code > 3 or (i < end and not _blank(data[i]) and (data[i] == 46 or 48 <= data[i] <= 57)):
                return False
            motion[n] = 10 * code
            seen |= HAS_G
            continue
        column = _COLUMN[c]
        if column < 0 or seen & (1 << column):
            return False
        i = _number(data, i, end, n, column, values)
        if i < 0:
            return False
        seen |= 1 << column


@nb.njit(cache=True)
def _number(data, i, end, n, column, values) -> int:
    """Read the number at i into values[n, column]; the index after it, or -1 if it is not plain."""
    negative = False
    if i < end and (data[i] == 45 or data[i] == 43):
        negative = data[i] == 45
        i += 1
    mantissa = 0
    significant = 0
    decimals = 0
    digits = 0
    point = False
    while i < end:
        c = data[i]
        if 48 <= c <= 57:
            digits += 1
            if significant > 0 or c != 48:
                significant += 1
            if significant > _MAX_DIGITS:
                return -1
            mantissa = mantissa * 10 + (c - 48)
            if point:
                decimals += 1
                if decimals > _MAX_DECIMALS:
                    return -1
        elif c == 46 and not point:
            point = True
        else:
            break
        i += 1
    if digits == 0:
        return -1
    if i < end and not _blank(data[i]) and not (65 <= (data[i] | 32) - 32 <= 90):
        return -1   # e.g. a second point, a bracket, a comment: the grammar decides
    value = mantissa / _POW10[decimals]
    values[n, column] = -value if negative else value
    return i


ALL_MOVED, ALL_G1, ALL_G0, ANY_ARC = 1, 2, 4, 8   # what execute says of the lines it ran


@nb.njit(cache=True)
def _coordinate(k, p0, p1, p2):
    return p0 if k == 0 else p1 if k == 1 else p2


@nb.njit(cache=True)
def _arc_centre(w, row, unit, plane, start, end, tolerances):
    """The in-plane centre (ca, cb) of a plain I/J/K arc as ipr.plain's step makes it, and
    whether this path takes the arc: offsets the plane takes, and an end well inside the
    tolerances (ipr.arcs.center_from_offsets would neither move the centre nor refuse it)."""
    a, b, n = plane
    if w & (1 << (OFFSET + n)) or not w & ((1 << (OFFSET + a)) | (1 << (OFFSET + b))):
        return False, 0.0, 0.0
    sa, sb = _coordinate(a, *start), _coordinate(b, *start)
    ca = sa + (row[OFFSET + a] * unit if w & (1 << (OFFSET + a)) else 0.0)
    cb = sb + (row[OFFSET + b] * unit if w & (1 << (OFFSET + b)) else 0.0)
    r0 = math.hypot(sa - ca, sb - cb)
    r1 = math.hypot(_coordinate(a, *end) - ca, _coordinate(b, *end) - cb)
    tolerance_abs, spiral_limit = tolerances
    margin = 1e-12 * (r0 + r1)
    err = abs(r1 - r0) + margin
    ok = r0 > 1.000001e-9 and err <= spiral_limit and err <= max(tolerance_abs, ARC_TOL_REL * r0) - margin
    return ok, ca, cb


@nb.njit(cache=True)
def execute(read, made, i0, start):
    """Run the plain lines from i0 on; stop at the first line that is not plain or that
    ipr.plain's steps would refuse (or, an arc, leave to the Python path). read: what `scan` read
    (plain, motion, words, values); start: the modal state, (absolute, arc_absolute, unit,
    plane (a, b, normal axis), offset (3,), position (3,), motion (-1: none), feed, tolerances:
    ipr.arcs.unit_tolerances_mm). Writes each line's end, feed, motion, whether it made an
    entity and an arc's centre at its index into made (ends, feeds, motions, moved, centres);
    returns the lines done and ALL_* / ANY_ARC flags. The records are plain tuples: numba types
    a NamedTuple argument in Python on every call."""
    plain, motion, words, values = read
    ends, feeds, motions, moved, centres = made
    absolute, arc_absolute, unit, plane, (o0, o1, o2), (p0, p1, p2), m, f, tolerances = start
    flags = ALL_MOVED | ALL_G1 | ALL_G0
    i = i0
    while i < len(plain) and plain[i]:
        w = words[i]
        mk = motion[i] if w & HAS_G else m
        arc = mk == MOTION_ARC_CW or mk == MOTION_ARC_CCW
        if arc:   # I/J/K format only, and a modal arc needs axis words (ipr.block.plain_arc)
            if arc_absolute or w & (1 << R) or not w & OFFSET_BITS or not w & (HAS_G | AXIS_BITS):
                break
        elif (mk != MOTION_LINEAR and mk != MOTION_RAPID) or w & (OFFSET_BITS | (1 << R)):
            break
        fk = f
        if w & (1 << F):
            fk = values[i, F] * unit / 60.0
            if fk < 0.0:
                break
        has_axes = (w & AXIS_BITS) != 0
        if (arc or has_axes and mk == MOTION_LINEAR) and fk == 0.0:
            break
        e0, e1, e2 = p0, p1, p2
        if absolute:
            if w & 1:
                e0 = values[i, X] * unit + o0
            if w & 2:
                e1 = values[i, Y] * unit + o1
            if w & 4:
                e2 = values[i, Z] * unit + o2
        else:
            if w & 1:
                e0 = p0 + values[i, X] * unit
            if w & 2:
                e1 = p1 + values[i, Y] * unit
            if w & 4:
                e2 = p2 + values[i, Z] * unit
        if arc:
            ok, ca, cb = _arc_centre(w, values[i], unit, plane, (p0, p1, p2), (e0, e1, e2), tolerances)
            if not ok:
                break
            centres[i, plane[0]], centres[i, plane[1]] = ca, cb
            centres[i, plane[2]] = _coordinate(plane[2], p0, p1, p2)
            flags = (flags & ~(ALL_G0 | ALL_G1)) | ANY_ARC
        elif has_axes:
            flags &= ~(ALL_G0 if mk == MOTION_LINEAR else ALL_G1)
        else:
            flags &= ~ALL_MOVED
        moved[i] = arc or has_axes
        p0, p1, p2 = e0, e1, e2
        ends[i, 0], ends[i, 1], ends[i, 2] = p0, p1, p2
        feeds[i] = fk
        motions[i] = mk
        m, f = mk, fk
        i += 1
    return i - i0, flags


class Scanned:
    """A chunk of lines as `scan` read it, and room for what `execute` makes of them. Lines come
    without their "\\n" (str.split) or each with it (a file's iteration); `usable` is False for
    anything else (a line holding a line break), which the Python path then reads."""

    __slots__ = ("usable", "plain", "motion", "words", "values", "ends", "feeds", "motions", "moved", "centres")

    def __init__(self, lines: list[str]):
        n = len(lines)
        text = "".join(lines) if lines[0].endswith("\n") else "\n".join(lines)
        self.usable = text.count("\n") in (n - 1, n)
        if not self.usable:
            return
        data = np.frombuffer(text.encode("utf-8", "surrogatepass"), np.uint8)
        self.plain, self.motion, self.words, self.values = scan(data, n)
        self.ends, self.feeds = np.empty((n, 3)), np.empty(n)
        self.motions, self.moved = np.empty(n, np.int8), np.empty(n, np.bool_)
        self.centres = np.empty((n, 3))


def run(scanned: Scanned, i: int, line: int, state, out: list) -> int:
    """Execute the plain lines from index i (numbered from `line`) on `state` (an
    ipr.modal.ModalState without a NURBS group or detour), appending their entities to `out`;
    returns how many lines it executed (0: line i is for the Python path)."""
    s = scanned
    pos = state.pos
    done, flags = execute((s.plain, s.motion, s.words, s.values), (s.ends, s.feeds, s.motions, s.moved, s.centres),
                          i, (state.absolute, state.arc_absolute, state.unit, PLANE_AXES[state.plane], state.offset,
                              pos, -1 if state.motion is None else state.motion, state.feed_mm_s,
                              unit_tolerances_mm(state.unit)))
    if done == 0:
        return 0
    j, path = i + done, state.path
    if flags & ALL_MOVED:
        rows, numbers = slice(i, j), range(line, line + done)
    else:
        rows = np.flatnonzero(s.moved[i:j]) + i
        numbers = (rows - i + line).tolist()
    end = list(zip(*s.ends[rows].T.tolist()))   # tuples straight from the columns (no row lists)
    if end:
        start = [pos, *end[:-1]]
        if flags & ALL_G1:
            out.extend(build_many(Line, len(end), numbers, start, end, s.feeds[rows].tolist(), repeat(path)))
        elif flags & ALL_G0:
            out.extend(build_many(Rapid, len(end), numbers, start, end, repeat(path)))
        else:
            out.extend(_mixed(s, rows, numbers, start, end, state.plane, path, flags & ANY_ARC))
        state.pos = end[-1]
    state.feed_mm_s = float(s.feeds[j - 1])
    state.motion = int(s.motions[j - 1])
    return done


def _mixed(s: Scanned, rows, numbers, start: list, end: list, plane: str, path, arcs: bool) -> list:
    """The entities of a run of more than one kind, each kind built at once and put in its places."""
    motions = s.motions[rows]
    feeds = s.feeds[rows].tolist()
    made = np.empty(len(end), object)
    for kind in (MOTION_LINEAR, MOTION_RAPID) + ((MOTION_ARC_CW,) if arcs else ()):
        chosen = motions == kind if kind != MOTION_ARC_CW else motions >= kind
        where = np.flatnonzero(chosen)
        if not where.size:
            continue
        mask = chosen.tolist()
        columns = [compress(numbers, mask), compress(start, mask), compress(end, mask)]
        if kind == MOTION_RAPID:
            cls = Rapid
        elif kind == MOTION_LINEAR:
            cls = Line
            columns.append(compress(feeds, mask))
        else:
            cls = Arc
            columns += [zip(*s.centres[rows][chosen].T.tolist()), repeat(plane),
                        (motions[chosen] == MOTION_ARC_CCW).tolist(), compress(feeds, mask), repeat(0)]
        made[where] = build_many(cls, where.size, *columns, repeat(path))
    return made.tolist()
