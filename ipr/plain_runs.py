"""Runs of plain G0/G1 lines, read and executed by compiled kernels (the bulk of CAM output).

A CAM program is mostly lines like `G1 X12.5 Y-3.25 Z0.1 F1200` or ` X3.2040 Z-0.1539`. Per line,
the Python path (ipr.shapes, ipr.plain) costs a regular expression, a dictionary look-up and a
generated step function; here a chunk of lines is read at once (`scan`) and a run of them is
executed at once (`execute`), in numba, and Python only builds the entities.

`scan` marks a line *plain* only when it is, character for character, of this form (anything
else is left to the Python path, which reads it as it always does):

    [blanks] [N digits] words [blanks] [\\r]     word: G0 / G00 / G1 / G01, or X Y Z F and a number
    number: [+|-] digits [. digits] | [+|-] . digits, at most 15 significant digits and 22 decimals

with blanks between words, each letter at most once, either case. Such a number is read as its
digits (an integer, exact below 2**53) divided by a power of ten (exact up to 10**22): one
correctly rounded division, so the value is exactly Python's float() of the text.

`execute` does what ipr.plain's step function does with each line, with the same arithmetic in
the same order (F * unit / 60; axis * unit + offset in G90, position + axis * unit in G91), and
stops at the first line that step would hand back to the general path (a motion mode other than
G0/G1, a negative F, a G1 with axes at feed zero): the Python path then reads that line and
reports its error. Lines keep their numbers; results are identical, bit for bit, to the Python
path's (tests/ipr/test_ipr_paths.py compares them).
"""
from __future__ import annotations

from itertools import repeat

import numba as nb
import numpy as np

from ipr.entities import Line, Rapid, build_many
from ipr.gcodes import MOTION_LINEAR, MOTION_RAPID

# columns of the scanned values and bits of `words`
X, Y, Z, F = 0, 1, 2, 3
HAS_G = 16
_MAX_DIGITS = 15
_MAX_DECIMALS = 22
_POW10 = np.array([10.0 ** k for k in range(_MAX_DECIMALS + 1)])


@nb.njit(cache=True)
def _blank(c: int) -> bool:
    return c == 32 or c == 9


@nb.njit(cache=True)
def scan(data: np.ndarray, n_lines: int):
    """Per line of `data` (the chunk's lines joined by \\n, UTF-8): plain (bool), its motion code
    (0 / 10, -1 without G), which words it has (bits 1 X, 2 Y, 4 Z, 8 F, 16 G) and their values."""
    plain = np.zeros(n_lines, np.bool_)
    motion = np.full(n_lines, -1, np.int8)
    words = np.zeros(n_lines, np.int8)
    values = np.zeros((n_lines, 4), np.float64)
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
            if digits == 0 or digits > 2 or code > 1 or (i < end and not _blank(data[i]) and (data[i] == 46 or 48 <= data[i] <= 57)):
                return False
            motion[n] = 10 * code
            seen |= HAS_G
            continue
        column = 0 if c == 120 else 1 if c == 121 else 2 if c == 122 else 3 if c == 102 else -1
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


ALL_MOVED, ALL_G1, ALL_G0 = 1, 2, 4   # what execute says of the lines it ran


@nb.njit(cache=True)
def execute(read, made, i0, start):
    """Run the plain lines from i0 on; stop at the first line that is not plain or that
    ipr.plain's step would refuse. read: what `scan` read (plain, motion, words, values); start:
    the modal state, (absolute, unit, offset (3,), position (3,), motion (-1: none), feed).
    Writes each line's end, feed, motion and whether it made an entity at its index into made
    (ends, feeds, motions, moved); returns the lines done and ALL_* flags. The records are
    plain tuples: numba types a NamedTuple argument in Python on every call."""
    plain, motion, words, values = read
    ends, feeds, motions, moved = made
    absolute, unit, (o0, o1, o2), (p0, p1, p2), m, f = start
    flags = ALL_MOVED | ALL_G1 | ALL_G0
    i = i0
    while i < len(plain) and plain[i]:
        w = words[i]
        mk = motion[i] if w & HAS_G else m
        if mk != MOTION_LINEAR and mk != MOTION_RAPID:
            break
        fk = f
        if w & 8:
            fk = values[i, F] * unit / 60.0
            if fk < 0.0:
                break
        has_axes = (w & 7) != 0
        if has_axes and mk == MOTION_LINEAR and fk == 0.0:
            break
        if has_axes:
            if absolute:
                if w & 1:
                    p0 = values[i, X] * unit + o0
                if w & 2:
                    p1 = values[i, Y] * unit + o1
                if w & 4:
                    p2 = values[i, Z] * unit + o2
            else:
                if w & 1:
                    p0 = p0 + values[i, X] * unit
                if w & 2:
                    p1 = p1 + values[i, Y] * unit
                if w & 4:
                    p2 = p2 + values[i, Z] * unit
            flags &= ~(ALL_G0 if mk == MOTION_LINEAR else ALL_G1)
        else:
            flags &= ~ALL_MOVED
        moved[i] = has_axes
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

    __slots__ = ("usable", "plain", "motion", "words", "values", "ends", "feeds", "motions", "moved")

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


def run(scanned: Scanned, i: int, line: int, state, out: list) -> int:
    """Execute the plain lines from index i (numbered from `line`) on `state` (an
    ipr.modal.ModalState without a NURBS group or detour), appending their entities to `out`;
    returns how many lines it executed (0: line i is for the Python path)."""
    s = scanned
    pos = state.pos
    done, flags = execute((s.plain, s.motion, s.words, s.values), (s.ends, s.feeds, s.motions, s.moved), i,
                          (state.absolute, state.unit, state.offset, pos, -1 if state.motion is None else state.motion,
                           state.feed_mm_s))
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
            out.extend(Line(n, a, b, f, path) if k == MOTION_LINEAR else Rapid(n, a, b, path) for n, a, b, f, k in
                       zip(numbers, start, end, s.feeds[rows].tolist(), s.motions[rows].tolist()))
        state.pos = end[-1]
    state.feed_mm_s = float(s.feeds[j - 1])
    state.motion = int(s.motions[j - 1])
    return done
