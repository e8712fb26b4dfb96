"""The static check of a block: which codes of which modal groups, which words.

Everything here depends only on the block's *signature* — its letters and its G/M
values, not the other numbers — so the result is cached per signature and a program
of 200,000 "G1 X Y Z F" lines checks its one shape once. Codes are kept as
int(round(10 * value)): G1 -> 10, G6.2 -> 62, G90.1 -> 901.
"""
from __future__ import annotations

from functools import lru_cache

from ipr.errors import BlockError, code_name

G_GROUPS: dict[int, str] = {
    0: "motion", 10: "motion", 20: "motion", 30: "motion", 52: "motion", 53: "motion",
    62: "motion", 800: "motion",
    170: "plane", 180: "plane", 190: "plane",
    900: "distance", 910: "distance",
    901: "arc_distance", 911: "arc_distance",
    200: "units", 210: "units",
    940: "feed_mode",
    610: "path", 640: "path",
    540: "coord", 550: "coord", 560: "coord", 570: "coord", 580: "coord", 590: "coord",
    40: "nonmodal", 530: "nonmodal", 920: "nonmodal", 921: "nonmodal",
    400: "comp",
    430: "tool_length", 490: "tool_length",
}
M_GROUPS: dict[int, str] = {0: "stop", 10: "stop", 20: "stop", 300: "stop",
                            30: "spindle", 40: "spindle", 50: "spindle",
                            70: "coolant", 80: "coolant", 90: "coolant", 60: "toolchange",
                            980: "subprogram", 990: "subprogram"}
_WHY_NOT = {
    280: "return to a stored home position", 281: "storing a home position",
    300: "return to a stored position", 301: "storing a position",
    410: "cutter radius compensation", 420: "cutter radius compensation",
    411: "cutter radius compensation", 421: "cutter radius compensation",
    930: "inverse time feed", 950: "feed per revolution", 100: "setting offsets from the program",
}
LETTERS = frozenset("GMXYZIJKRFPQSTHLNO")
AXES = "XYZ"
_LINEAR_LETTERS = frozenset("XYZFN")
_ARC_LETTERS = frozenset("XYZIJKRFN")
NURBS_MOTIONS = (52, 62)


class BlockSpec:
    """The checked structure of one block signature.

    g: modal group -> code; m: M group -> code; index: letter -> word index for every
    letter but G/M; where: group -> word index of its code (for error columns);
    axes: the axis letters present, in XYZ order.
    """

    __slots__ = ("g", "m", "index", "where", "axes", "usage", "motion", "f_index", "axis_idx", "linear",
                 "plain_arc")

    def __init__(self, g, m, index, where, axes):
        self.g = g
        self.m = m
        self.index = index
        self.where = where
        self.axes = axes
        self.usage: dict[int | None, BlockError | None] = {}
        self.motion = g.get("motion")
        self.f_index = index.get("F")
        self.axis_idx = tuple((k, index[a]) for k, a in enumerate(AXES) if a in index)
        # a plain G0/G1 block: the interpreter's short path
        self.linear = (g.keys() <= {"motion"} and self.motion in (None, 0, 10) and not m
                       and index.keys() <= _LINEAR_LETTERS)
        # a G2/G3 block with only axis words, one arc format, F and N: ipr.plain's short path
        self.plain_arc = (g.keys() <= {"motion"} and self.motion in (None, 20, 30) and not m
                          and index.keys() <= _ARC_LETTERS and (self.motion is not None or bool(axes))
                          and ("R" in index) != any(k in index for k in "IJK"))

    def moves(self, motion: int | None) -> bool:
        """Does the block execute its (modal) motion?"""
        code = self.g.get("motion")
        if code is not None:
            if code in (0, 10):
                return bool(self.axes)   # a bare G0/G1 only sets the mode
            return code != 800
        if self.axes and self.g.get("nonmodal") != 920:
            return True
        if motion in NURBS_MOTIONS:
            return any(k in self.index for k in ("K", "R", "P"))
        return False

    def check_usage(self, motion: int | None) -> BlockError | None:
        """E-WORD-UNUSED / E-NO-MOTION-MODE for this block under modal `motion`."""
        if motion not in self.usage:
            self.usage[motion] = _usage_error(self, self.g.get("motion", motion))
        return self.usage[motion]


def _usage_error(spec: BlockSpec, motion: int | None) -> BlockError | None:
    g = spec.g
    moving = spec.moves(motion)
    nonmodal = g.get("nonmodal")
    if spec.axes and nonmodal != 920 and (motion is None or motion == 800 or motion == 53):
        letter = spec.axes[0]
        what = "G80 cancels motion" if motion == 800 else "no motion mode is active"
        raise_at = spec.index[letter]
        return BlockError("E-NO-MOTION-MODE", f"axis word {letter} but {what}", raise_at)
    m = motion if moving else None
    m98 = spec.m.get("subprogram") == 980
    if m98 and "P" not in spec.index:
        return BlockError("E-WORD-MISSING", "M98 needs a P word (the subprogram number)", spec.where["subprogram"])
    users = {
        "I": m in (20, 30), "J": m in (20, 30), "K": m in (20, 30, 62), "R": m in (20, 30, 62),
        "P": nonmodal == 40 or g.get("path") == 640 or m in (20, 30, 52, 62) or m98,
        "Q": g.get("path") == 640 or m == 62, "L": m == 52 or m98, "H": g.get("tool_length") == 430,
    }
    for letter, used in users.items():
        if letter in spec.index and not used:
            return BlockError("E-WORD-UNUSED", f"{letter} word is not used by any code in this block",
                              spec.index[letter])
    if nonmodal == 40 and "P" not in spec.index:
        return BlockError("E-WORD-MISSING", "G4 dwell needs a P word (seconds)", spec.where["nonmodal"])
    if nonmodal == 920 and not spec.axes:
        return BlockError("E-WORD-MISSING", "G92 needs at least one axis word", spec.where["nonmodal"])
    if nonmodal == 530 and motion not in (0, 10):
        return BlockError("E-G53", "G53 needs G0 or G1 motion", spec.where["nonmodal"])
    return None


@lru_cache(maxsize=4096)
def analyse(signature: tuple) -> BlockSpec | BlockError:
    """Check a signature: ((letter, G/M value or None), ...) in text order."""
    g: dict[str, int] = {}
    m: dict[str, int] = {}
    where: dict[str, int] = {}
    index: dict[str, int] = {}
    for i, (letter, value) in enumerate(signature):
        if letter not in LETTERS:
            return BlockError("E-WORD-UNSUPPORTED", f"unsupported word {letter}", i)
        if letter in "GM":
            code = round(value * 10)
            table = G_GROUPS if letter == "G" else M_GROUPS
            exact = abs(value * 10 - code) < 1e-6
            group = table.get(code) if exact else None
            if group is None:
                why = _WHY_NOT.get(code) if letter == "G" and exact else None
                kind = "E-GCODE-UNSUPPORTED" if letter == "G" else "E-MCODE-UNSUPPORTED"
                what = "G-code" if letter == "G" else "M-code"
                suffix = f" ({why})" if why else ""
                return BlockError(kind, f"unsupported {what} {code_name(letter, value)}{suffix}", i)
            seen = g if letter == "G" else m
            if group in seen:
                first = code_name(letter, seen[group] / 10)
                return BlockError("E-MODAL-GROUP", f"{first} and {code_name(letter, value)} are in the "
                                  f"same modal group ({group})", i)
            seen[group] = code
            where[group] = i
        else:
            if letter in index:
                return BlockError("E-WORD-REPEATED", f"{letter} word appears twice in the block", i)
            index[letter] = i
    axes = tuple(a for a in AXES if a in index)
    if axes and g.get("nonmodal") == 920 and "motion" in g:
        return BlockError("E-AXIS-CONFLICT", f"G92 and {code_name('G', g['motion'] / 10)} both use the "
                          "axis words", where["motion"])
    return BlockSpec(g, m, index, where, axes)
