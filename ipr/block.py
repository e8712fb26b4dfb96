"""The static check of a block: which codes of which modal groups, which words.

Everything here depends only on the block's *signature* — its letters and its G/M
values, not the other numbers — so the result is cached per signature and a program
of 200,000 "G1 X Y Z F" lines checks its one shape once. Codes are kept as
int(round(10 * value)): G1 -> 10, G6.2 -> 62, G90.1 -> 901.
"""
from __future__ import annotations

from functools import lru_cache

from ipr.dialect import EXTRA_G, EXTRA_M
from ipr.errors import BlockError, code_name
from ipr.gcodes import (BLEND, CANNED_CYCLES, COMP_LEFT, COMP_LEFT_DYNAMIC, COMP_RIGHT, COMP_RIGHT_DYNAMIC,
                        CYCLE_BORE_DWELL, CYCLE_BORE_MANUAL, CYCLE_BORE_STOP, CYCLE_DRILL_DWELL, CYCLE_PECK,
                        CYCLE_PECK_CHIPBREAK, CYCLE_TAP, CYCLE_TAP_LEFT, DATA_SET, DWELL, IO_WAIT,
                        LOCAL_OFFSET, MACHINE_COORDS, MOTION_ARC_CCW, MOTION_ARC_CW, MOTION_CANCEL,
                        MOTION_LINEAR, MOTION_RAPID, NURBS_FANUC, NURBS_LINUXCNC, NURBS_LINUXCNC_END,
                        NURBS_MOTIONS, OFFSET_SET, SPINDLE_CSS, SPINDLE_ORIENT, SPLINE_CUBIC,
                        SPLINE_QUADRATIC, SUBPROGRAM_CALL, TOOL_LENGTH_ADD, TOOL_LENGTH_DYNAMIC,
                        TOOL_LENGTH_ON, TOOL_NUMBER_SET)

CYCLES = CANNED_CYCLES   # canned cycles (ipr.cycles)
G_GROUPS: dict[int, str] = {
    0: "motion", 10: "motion", 20: "motion", 30: "motion", 52: "motion", 53: "motion",
    62: "motion", 800: "motion", 50: "motion", 51: "motion", **{c: "motion" for c in CYCLES},
    170: "plane", 180: "plane", 190: "plane",
    900: "distance", 910: "distance",
    901: "arc_distance", 911: "arc_distance",
    200: "units", 210: "units",
    930: "feed_mode", 940: "feed_mode", 950: "feed_mode",
    610: "path", 611: "path", 640: "path",
    540: "coord", 550: "coord", 560: "coord", 570: "coord", 580: "coord", 590: "coord",
    591: "coord", 592: "coord", 593: "coord",
    40: "nonmodal", 530: "nonmodal", 920: "nonmodal", 520: "nonmodal", 100: "nonmodal",
    280: "nonmodal", 281: "nonmodal", 300: "nonmodal", 301: "nonmodal",
    921: "g92_apply", 922: "g92_apply", 923: "g92_apply",
    400: "comp", 410: "comp", 420: "comp", 411: "comp", 421: "comp",
    430: "tool_length", 431: "tool_length", 432: "tool_length", 490: "tool_length",
    980: "retract", 990: "retract",
    960: "spindle_mode", 970: "spindle_mode",
    80: "lathe",
}
# LinuxCNC's M groups (interp_array.cc): M19 and M70..M73 share the spindle group 7
M_GROUPS: dict[int, str] = {0: "stop", 10: "stop", 20: "stop", 300: "stop", 600: "stop",
                            30: "spindle", 40: "spindle", 50: "spindle", 190: "spindle",
                            700: "spindle", 710: "spindle", 720: "spindle", 730: "spindle",
                            70: "coolant", 80: "coolant", 90: "coolant", 60: "toolchange", 610: "toolchange",
                            **{c: "override" for c in range(480, 540, 10)},
                            **{c: "io" for c in range(620, 690, 10)},
                            **{c: "user" for c in range(1000, 2000, 10)},
                            980: "subprogram", 990: "subprogram"}
_WHY_NOT = {
    330: "spindle-synchronised motion (threading)", 331: "rigid tapping (spindle-synchronised)",
    760: "threading cycle (spindle-synchronised)", 870: "back boring cycle",
    382: "probing (a virtual machine has no workpiece to touch)", 383: "probing", 384: "probing",
    385: "probing", 70: "lathe diameter mode",
 171: "UV plane", 181: "UW plane", 191: "VW plane",
}
# the item-7 constructs: axes a 3-axis machine does not have
ABSENT_AXES = frozenset("ABCUVW")
# non-modal codes that take the axis words (no motion may share the block)
AXIS_NONMODAL = frozenset((920, 520, 100, 280, 300))
AXES = "XYZ"
POLAR = ("@", "^")   # ipr.polar
_LINEAR_LETTERS = frozenset("XYZFN")
_ARC_LETTERS = frozenset("XYZIJKRFN")
_IJ_MOTIONS = (MOTION_ARC_CW, MOTION_ARC_CCW, SPLINE_CUBIC, SPLINE_QUADRATIC)   # I and J are read
# cycles that read P (dwell seconds)
DWELL_CYCLES = (CYCLE_TAP_LEFT, CYCLE_DRILL_DWELL, CYCLE_TAP, CYCLE_BORE_STOP, CYCLE_BORE_MANUAL, CYCLE_BORE_DWELL)


class BlockSpec:
    """The checked structure of one block signature.

    g: modal group -> code; m: M group -> code; index: letter -> word index for every
    letter but G/M; where: group -> word index of its code (for error columns);
    axes: the axis letters present, in XYZ order.
    """

    __slots__ = ("g", "m", "index", "where", "axes", "usage", "motion", "f_index", "axis_idx", "linear",
                 "plain_arc", "polar")

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
        # the word index of the first polar word (ipr.polar), None without one
        self.polar = min((index[w] for w in POLAR if w in index), default=None)
        # a plain G0/G1 block: the interpreter's short path
        self.linear = (g.keys() <= {"motion"} and self.motion in (None, MOTION_RAPID, MOTION_LINEAR) and not m
                       and index.keys() <= _LINEAR_LETTERS)
        # a G2/G3 block with only axis words, one arc format, F and N: ipr.plain's short path
        self.plain_arc = (g.keys() <= {"motion"} and self.motion in (None, MOTION_ARC_CW, MOTION_ARC_CCW) and not m
                          and index.keys() <= _ARC_LETTERS and (self.motion is not None or bool(axes))
                          and ("R" in index) != any(k in index for k in "IJK"))

    def moves(self, motion: int | None) -> bool:
        """Does the block execute its (modal) motion?"""
        if self.g.get("nonmodal") in AXIS_NONMODAL or self.g.get("tool_length") == TOOL_LENGTH_DYNAMIC:
            return False   # G10, G28, G30, G52, G92 and G43.1 take the axis words
        code = self.g.get("motion")
        if code is not None:
            if code in (MOTION_RAPID, MOTION_LINEAR):
                return bool(self.axes) or self.polar is not None   # a bare G0/G1 only sets the mode
            return code != MOTION_CANCEL
        if self.axes or self.polar is not None:
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
    g, mc = spec.g, spec.m
    moving = spec.moves(motion)
    nonmodal = g.get("nonmodal")
    takes_axes = nonmodal in AXIS_NONMODAL or g.get("tool_length") == TOOL_LENGTH_DYNAMIC
    if spec.polar is not None and (takes_axes or nonmodal == MACHINE_COORDS):
        what = "G53" if nonmodal == MACHINE_COORDS else "a code that takes axis words"
        return BlockError("E-POLAR", f"polar coordinates (@, ^) only in motion, not with {what}", spec.polar)
    if (spec.axes or spec.polar is not None) and not takes_axes and motion in (None, MOTION_CANCEL, NURBS_LINUXCNC_END):
        raise_at = spec.index[spec.axes[0]] if spec.axes else spec.polar
        letter = spec.axes[0] if spec.axes else next(w for w in POLAR if spec.index.get(w) == spec.polar)
        what = "G80 cancels motion" if motion == MOTION_CANCEL else "no motion mode is active"
        return BlockError("E-NO-MOTION-MODE", f"axis word {letter} but {what}", raise_at)
    m = motion if moving else None
    m98 = spec.m.get("subprogram") == SUBPROGRAM_CALL
    if m98 and "P" not in spec.index:
        return BlockError("E-WORD-MISSING", "M98 needs a P word (the subprogram number)", spec.where["subprogram"])
    cycle = m in CYCLES
    io = (mc.get("io") is not None or mc.get("override") is not None or mc.get("user") is not None
          or mc.get("spindle") == SPINDLE_ORIENT or "dialect_g" in g)   # M19 R (angle) Q (timeout) P (direction)
    users = {
        "I": m in _IJ_MOTIONS, "J": m in _IJ_MOTIONS, "K": m in (MOTION_ARC_CW, MOTION_ARC_CCW, NURBS_FANUC),
        "R": m in (MOTION_ARC_CW, MOTION_ARC_CCW, NURBS_FANUC) or cycle or nonmodal == DATA_SET
             or mc.get("spindle") == SPINDLE_ORIENT,
        "E": mc.get("io") is not None or mc.get("user") is not None or "dialect_g" in g,
        "P": (nonmodal in (DWELL, DATA_SET) or g.get("path") == BLEND
              or m in (MOTION_ARC_CW, MOTION_ARC_CCW, SPLINE_CUBIC, NURBS_LINUXCNC, NURBS_FANUC)
              or m in DWELL_CYCLES or io or m98),
        "Q": (g.get("path") == BLEND or m in (SPLINE_CUBIC, NURBS_FANUC, CYCLE_PECK_CHIPBREAK, CYCLE_PECK) or io
              or mc.get("toolchange") == TOOL_NUMBER_SET),
        "L": m == NURBS_LINUXCNC or cycle or nonmodal == DATA_SET or mc.get("io") == IO_WAIT or m98,
        "H": g.get("tool_length") in (TOOL_LENGTH_ON, TOOL_LENGTH_ADD),
        "D": (g.get("comp") in (COMP_LEFT, COMP_RIGHT, COMP_LEFT_DYNAMIC, COMP_RIGHT_DYNAMIC)
          or g.get("spindle_mode") == SPINDLE_CSS),
    }
    for letter, used in users.items():
        if letter in spec.index and not used:
            return BlockError("E-WORD-UNUSED", f"{letter} word is not used by any code in this block",
                              spec.index[letter])
    if nonmodal == DWELL and "P" not in spec.index:
        return BlockError("E-WORD-MISSING", "G4 dwell needs a P word (seconds)", spec.where["nonmodal"])
    if nonmodal in (OFFSET_SET, LOCAL_OFFSET) and not spec.axes:
        return BlockError("E-WORD-MISSING", f"G{nonmodal // 10} needs at least one axis word",
                          spec.where["nonmodal"])
    if nonmodal == MACHINE_COORDS and motion not in (MOTION_RAPID, MOTION_LINEAR):
        return BlockError("E-G53", "G53 needs G0 or G1 motion", spec.where["nonmodal"])
    return None


@lru_cache(maxsize=4096)
def analyse(signature: tuple, dialect: str = "linuxcnc") -> BlockSpec | BlockError:
    """Check a signature: ((letter, G/M value or None), ...) in text order; a dialect's own
    codes (ipr.dialect) are groups "dialect_g" / "dialect_m"."""
    g: dict[str, int] = {}
    m: dict[str, int] = {}
    where: dict[str, int] = {}
    index: dict[str, int] = {}
    for i, (letter, value) in enumerate(signature):
        if letter in ABSENT_AXES:   # every other letter of the grammar is read
            return BlockError("E-AXIS-ABSENT", f"axis {letter}: this machine has only X, Y and Z "
                              "(rotary and parallel axes are not simulated)", i)
        if letter in "GM":
            code = round(value * 10)
            table = G_GROUPS if letter == "G" else M_GROUPS
            extra = (EXTRA_G if letter == "G" else EXTRA_M)[dialect]
            exact = abs(value * 10 - code) < 1e-6
            group = (f"dialect_{letter.lower()}" if code in extra else table.get(code)) if exact else None
            if group is None:
                why = _WHY_NOT.get(code) if letter == "G" and exact else None
                kind = "E-GCODE-UNSUPPORTED" if letter == "G" else "E-MCODE-UNSUPPORTED"
                what = "G-code" if letter == "G" else "M-code"
                suffix = f" ({why})" if why else ""
                return BlockError(kind, f"unsupported {what} {code_name(letter, value)}{suffix}", i)
            seen = g if letter == "G" else m
            if group == "motion" and group in seen and MOTION_CANCEL in (code, seen[group]):
                # LinuxCNC (read_g): G80 gives way to another motion code of the block
                if code == MOTION_CANCEL:
                    continue
                del seen[group]
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
    if any(w in index for w in POLAR) and ("X" in index or "Y" in index):
        letter = "X" if "X" in index else "Y"
        return BlockError("E-POLAR", f"polar coordinates (@, ^) and a word {letter} in one block",
                          index[letter])
    nonmodal = g.get("nonmodal")
    if axes and nonmodal in AXIS_NONMODAL and g.get("motion", MOTION_CANCEL) != MOTION_CANCEL:
        return BlockError("E-AXIS-CONFLICT", f"{code_name('G', nonmodal / 10)} and "
                          f"{code_name('G', g['motion'] / 10)} both use the axis words", where["motion"])
    return BlockSpec(g, m, index, where, axes)
