"""The program's text around what vcnc fit writes: the motion mode (G1/G2/G3), feed and plane a block
after a group or a written arc relies on, restored on that block or on one of its own.

A G06.2 group leaves no motion mode active and may leave another feed; a G2/G3 arc written for a run of
G1 moves leaves G2/G3 active. The next block that relies on the modal motion (axis words without a
motion code of their own) gets the code the program had there. An arc written in a plane other than
the program's (ipo.fit.arcs) leaves that plane active: the next block gets the program's plane code.
"""
from __future__ import annotations

import re

from ipr import parse_line
from ipr.entities import Line

AXIS_LETTERS = frozenset("XYZ")
PLANE_G = frozenset({17.0, 18.0, 19.0})
# G codes that use axis words without needing a motion mode (they carry their own meaning)
OWN_AXIS_G = frozenset({0.0, 1.0, 2.0, 3.0, 5.2, 6.2, 10.0, 28.0, 30.0, 92.0})
_N_WORD = re.compile(r"^\s*(N\s*\d+)\s*", re.IGNORECASE)


def needs_motion_mode(lines: list[str], start: int) -> bool:
    """Does the first line from index `start` on that uses axis words rely on the modal motion?"""
    for text in lines[start:]:
        block = parse_line(text)
        letters = {l for l, _ in block.words}
        gs = {v for l, v in block.words if l == "G" and isinstance(v, float)}
        if gs & OWN_AXIS_G:
            return False
        if letters & AXIS_LETTERS:
            return True
    return False


def motion_code(move) -> str:
    return "G1" if isinstance(move, Line) else ("G3" if move.ccw else "G2")


def with_motion(text: str, code: str) -> str | None:
    """The same block with an explicit motion code (a G06.2 group leaves no motion mode active);
    the block itself if it has a G word of its own, None if it has G words but none of motion."""
    gs = [v for l, v in parse_line(text).words if l == "G"]
    if gs:
        return text if set(gs) & OWN_AXIS_G else None
    m = _N_WORD.match(text)
    return f"{m.group(1)} {code} {text[m.end():]}" if m else f"{code} {text.lstrip()}"


def restored(text: str, code: str, feed: str | None) -> str:
    return with_feed(with_motion(text, code), feed)


def with_feed(text: str, feed: str | None) -> str:
    """The block with an F word appended where it needs one (a group before it left another feed)."""
    if feed is None or any(l == "F" for l, _ in parse_line(text).words):
        return text
    return f"{text.rstrip()} F{feed}"


def _next_takes_motion(lines: list[str], last: int) -> bool:
    """Can the block right after source line `last` carry the restored motion code on itself?
    (with_motion refuses a block by its own G words, whatever the code.)"""
    nxt = lines[last] if last < len(lines) else ""
    return bool({l for l, _ in parse_line(nxt).words} & AXIS_LETTERS) and with_motion(nxt, "G1") is not None


def restore_cost(lines: list[str], last: int) -> int:
    """Blocks restore_motion adds after a group or arc ending on source line `last`."""
    return 0 if not needs_motion_mode(lines, last) or _next_takes_motion(lines, last) else 1


def restore_motion(lines: list[str], last: int, code: str, feed: str | None, after: dict, prefix: dict) -> None:
    """After a group or written arc that ends a chain: the next block that relies on the modal motion gets the code
    the program had there, on itself where it is the very next block, else as a block of its own;
    feed: the program's feed there where the group left another (restored the same way, or alone)."""
    if not needs_motion_mode(lines, last):
        if feed is not None:
            after[last] = [f"F{feed}"]
        return
    if _next_takes_motion(lines, last):
        prefix[last + 1] = (code, feed)
    else:
        after[last] = [code if feed is None else f"{code} F{feed}"]


def with_plane(text: str, code: str) -> str | None:
    """The block with the plane code `code` (after its N word); the block itself where it sets a plane of
    its own; None where it cannot carry one (no words, an O word, an assignment, block delete, '%')."""
    block = parse_line(text)
    if not block.words or block.assigns or block.delete or block.percent or any(l == "O" for l, _ in block.words):
        return None
    if any(l == "G" and v in PLANE_G for l, v in block.words):
        return text
    m = _N_WORD.match(text)
    return f"{m.group(1)} {code} {text[m.end():]}" if m else f"{code} {text.lstrip()}"


def restore_plane(lines: list[str], last: int, code: str, after: dict, planes: dict) -> None:
    """After a chain that ends with the program's plane not in force: the next block (past lines without
    words: comments, blank lines) gets its code `code` (planes: source line -> code), or where it cannot
    carry it, a block of its own right after source line `last`."""
    for k in range(last, len(lines)):
        block = parse_line(lines[k])
        if block.words or block.assigns or block.delete or block.percent:
            if with_plane(lines[k], code) is not None:
                planes[k + 1] = code
                return
            break
    after.setdefault(last, []).insert(0, code)
