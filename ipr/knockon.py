"""Knock-on errors: a refused block must not be reported again through the blocks after it.

A refused block changes no state (ipr.modal.Staged), so with --all-errors the blocks after
it run without its effects: a refused `G0 G17 G41 X0 Y0` leaves no motion mode, and every
later bare `X.. Y..` would fail with E-NO-MOTION-MODE. This module remembers what a refused
block would have set (its motion mode, feed, position) and leaves out the later errors that
follow only from that, until a block sets the same state again; `summary` then says once
how many errors were left out after each root cause (notice N-KNOCK-ON).
"""
from __future__ import annotations

from ipr.gcodes import MOTION_RAPID

# error code -> the doubted state it follows from
_FOLLOWS = {
    "E-NO-MOTION-MODE": "motion", "E-CYCLE": "motion",
    "E-FEED-ZERO": "feed", "E-FEED-MODE": "feed",
    "E-ARC-RADIUS": "position", "E-ARC-R-SMALL": "position", "E-ARC-R-FULL": "position",
    "E-NURBS-START": "position",
}
_ALL = ("motion", "feed", "position")
MOTION_G = frozenset((0, 1, 2, 3, 5, 5.1, 5.2, 6.2, 33, 33.1, 38.2, 38.3, 38.4, 38.5, 73, 74, 76, 80, 81, 82, 83,
                      84, 85, 86, 87, 88, 89))


class KnockOn:
    def __init__(self):
        self.doubt: dict[str, int] = {}       # state -> line of the refused block
        self.left_out: dict[int, int] = {}    # root line -> errors left out

    def refused(self, words, line: int) -> None:
        """A block was refused; `words` are its (letter, value) pairs, None if its line does not
        parse (then all of its state is in doubt)."""
        if words is None:
            for what in _ALL:
                self.doubt.setdefault(what, line)
            return
        for letter, value in words:
            if letter == "G" and (value in MOTION_G or value in (93, 94, 95)):
                self.doubt.setdefault("motion" if value in MOTION_G else "feed", line)
            elif letter == "F":
                self.doubt.setdefault("feed", line)
            elif letter in "XYZ@^":
                self.doubt.setdefault("position", line)

    def follows(self, code: str) -> bool:
        """Is an error of this code a consequence of an earlier refusal? (counted if so)"""
        root = self.doubt.get(_FOLLOWS.get(code, ""))
        if root is None:
            return False
        self.left_out[root] = self.left_out.get(root, 0) + 1
        return True

    def settled(self, spec) -> None:
        """A block ran: what it set is no longer in doubt."""
        if "motion" in spec.g:
            self.doubt.pop("motion", None)
            if spec.g["motion"] == MOTION_RAPID and spec.axes:
                self.doubt.pop("position", None)
        if "F" in spec.index:
            self.doubt.pop("feed", None)

    def summary(self) -> list[tuple[int, str]]:
        return [(root, f"{n} later error{'s' if n > 1 else ''} left out: they follow from the refused "
                 f"block at line {root}") for root, n in sorted(self.left_out.items())]
