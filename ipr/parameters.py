"""The parameter table (RS274NGC §3.2, LinuxCNC's "Parameters" chapter): numbered #1..#5601,
local and global named parameters, the read-only system values, call scopes and the
`#` substitution of (DEBUG,...) and (PRINT,...) comments.

One table per interpreter, owned by its ModalState. User values live in the dict itself;
anything missing is looked up by `__missing__`: an unset numbered parameter reads 0, a
system parameter is computed from the modal state at the time of reading (the current
position #5420.. and #<_x>.., the G92 offset #5211.., the work origins #5221.., the modes
#<_metric>, #<_motion_mode>, ...), and an unset named parameter is an error.

Scopes: #1..#30 and names without a leading underscore are local to a subroutine call
(`enter_call` hides the caller's and binds the arguments, `leave_call` restores them);
names with a leading underscore are global.
"""
from __future__ import annotations

import re

from ipr.errors import BlockError

MAX_PARAM = 5601   # LinuxCNC: RS274NGC_MAX_PARAMETERS - 1
LOCAL_NUMBERED = 30
INCH_MM = 25.4

# Numbered parameters computed from the modal state (writing them is an error, as in LinuxCNC)
_POSITION = range(5420, 5429)        # current position X Y Z A B C U V W, program units, work coordinates
_G92 = range(5211, 5220)             # G92 offset X..W
_COORD_ORIGINS = range(5221, 5391)   # G54..G59.3 origins, 20 numbers each: X..W, R (rotation)
_COORD_NAMES = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
_COORD_CODES = (540, 550, 560, 570, 580, 590, 591, 592, 593)
READ_ONLY = (5210, 5220, 5400, 5410, *_POSITION, *_G92, *range(5401, 5410))
_LINEAR = 3   # X, Y, Z: the other axes read 0


def is_local(key) -> bool:
    """#1..#30 and names without a leading underscore belong to the current call."""
    if key.__class__ is int:
        return key <= LOCAL_NUMBERED
    return not key.startswith("_")


class Parameters(dict):
    """Parameter number or lower-case name -> value. `state` is the ipr.modal.ModalState
    the system parameters are read from; `setup` its ipr.modal.Setup."""

    __slots__ = ("state", "setup", "call_level", "line")

    def __init__(self, state, setup):
        super().__init__()
        self.state = state
        self.setup = setup
        self.call_level = 0
        self.line = 0   # the line being executed (#<_line>)

    def __missing__(self, key):
        if key.__class__ is str:
            value = _named_system(self, key)
            if value is None:
                raise BlockError("E-PARAM", f"named parameter #<{key}> is read before it is set")
            return value
        return _numbered_system(self, key)

    def exists(self, key) -> float:
        """EXISTS[#<name>]: 1.0 when the named parameter is set (or a system name)."""
        if key.__class__ is not str:
            raise BlockError("E-EXPR", "EXISTS takes a named parameter, EXISTS[#<name>]")
        return 1.0 if key in self or _named_system(self, key) is not None else 0.0

    def check_writable(self, key) -> None:
        if key.__class__ is int and (key in READ_ONLY or key in _COORD_ORIGINS):
            raise BlockError("E-PARAM", f"parameter #{key} is read-only (set by the interpreter)")
        if key.__class__ is str and key.startswith("_") and _named_system(self, key) is not None \
                and key not in ("_value", "_value_returned"):
            raise BlockError("E-PARAM", f"parameter #<{key}> is read-only (set by the interpreter)")

    # ---- call scopes --------------------------------------------------------------
    def enter_call(self, args: list[float]) -> dict:
        """Hide the caller's local parameters and bind #1..#n to `args`; returns what to restore."""
        saved = {k: v for k, v in self.items() if is_local(k)}
        for k in saved:
            del self[k]
        for i, v in enumerate(args, 1):
            self[i] = v
        self.call_level += 1
        return saved

    def leave_call(self, saved: dict) -> None:
        for k in [k for k in self if is_local(k)]:
            del self[k]
        self.update(saved)
        self.call_level -= 1


def _program_position(st) -> list[float]:
    return [(st.pos[k] - st.offset[k]) / st.unit for k in range(_LINEAR)]


def _numbered_system(p: Parameters, key: int) -> float:
    st = p.state
    if key in _POSITION:
        i = key - _POSITION.start
        return _program_position(st)[i] if i < _LINEAR else 0.0
    if key in _G92:
        i = key - _G92.start
        return st.g92[i] / st.unit if i < _LINEAR else 0.0
    if key == 5210:
        return 1.0 if any(st.g92) else 0.0
    if key == 5220:
        return float(_COORD_CODES.index(st.coord) + 1) if st.coord in _COORD_CODES else 1.0
    if key in _COORD_ORIGINS:
        system, i = divmod(key - _COORD_ORIGINS.start, 20)
        if i >= _LINEAR:
            return 0.0
        origin = p.setup.work_offsets_mm.get(_COORD_NAMES[system], (0.0, 0.0, 0.0))
        return float(origin[i]) / st.unit
    if key == 5400:
        return float(st.tool_in_spindle)
    if key == 5403:
        return st.tool_offset / st.unit
    return 0.0   # an unset numbered parameter reads 0 (RS274NGC)


def _named_system(p: Parameters, key: str) -> float | None:
    """The value of a predefined `#<_name>` (LinuxCNC's list), None for any other name."""
    if not key.startswith("_"):
        return None
    st = p.state
    axis = "xyzabcuvw".find(key[1:]) if len(key) == 2 else -1
    if axis >= 0:
        return _program_position(st)[axis] if axis < _LINEAR else 0.0
    if key.startswith("_abs_") and len(key) == 6 and key[5] in "xyzabcuvw":
        i = "xyzabcuvw".index(key[5])
        return st.pos[i] / st.unit if i < _LINEAR else 0.0
    f = _FLAGS.get(key)
    return None if f is None else float(f(st, p))


_FLAGS = {
    "_metric": lambda st, p: st.unit == 1.0,
    "_imperial": lambda st, p: st.unit != 1.0,
    "_absolute": lambda st, p: st.absolute,
    "_incremental": lambda st, p: not st.absolute,
    "_inverse_time": lambda st, p: 0,
    "_units_per_minute": lambda st, p: 1,
    "_units_per_rev": lambda st, p: 0,
    "_coord_system": lambda st, p: st.coord,
    "_tool_offset": lambda st, p: st.tool_offset != 0.0,
    "_ijk_absolute_mode": lambda st, p: st.arc_absolute,
    "_plane": lambda st, p: {"XY": 170, "ZX": 180, "YZ": 190}[st.plane],
    "_motion_mode": lambda st, p: 800 if st.motion is None else st.motion,
    "_feed": lambda st, p: st.feed_mm_s * 60.0 / st.unit,
    "_rpm": lambda st, p: st.spindle_rpm,
    "_spindle_on": lambda st, p: st.spindle_dir is not None,
    "_spindle_cw": lambda st, p: st.spindle_dir == "cw",
    "_mist": lambda st, p: st.mist,
    "_flood": lambda st, p: st.flood,
    "_current_tool": lambda st, p: st.tool_in_spindle,
    "_selected_tool": lambda st, p: -1 if st.tool_selected is None else st.tool_selected,
    "_current_pocket": lambda st, p: st.tool_in_spindle,
    "_selected_pocket": lambda st, p: -1 if st.tool_selected is None else st.tool_selected,
    "_speed_override": lambda st, p: 1,
    "_feed_override": lambda st, p: 1,
    "_adaptive_feed": lambda st, p: 0,
    "_feed_hold": lambda st, p: 0,
    "_call_level": lambda st, p: p.call_level,
    "_remap_level": lambda st, p: 0,
    "_task": lambda st, p: 0,
    "_line": lambda st, p: p.line,
    "_value": lambda st, p: 0,
    "_value_returned": lambda st, p: 0,
    "_vmajor": lambda st, p: 2.9,
    "_vminor": lambda st, p: 0,
}

_SUBST = re.compile(r"#\s*(<[^>]*>|[0-9]+)")


def substitute(text: str, params: Parameters) -> str:
    """(DEBUG,...) text with each #n / #<name> replaced by its value ("%f", as LinuxCNC prints)."""
    def value(m: re.Match) -> str:
        ref = m.group(1)
        key = re.sub(r"[ \t]", "", ref[1:-1]).lower() if ref.startswith("<") else int(ref)
        if key.__class__ is int and not 1 <= key <= MAX_PARAM:
            return m.group(0)
        try:
            return f"{params[key]:f}"
        except BlockError:
            return "######"   # LinuxCNC prints an unset name this way
    return _SUBST.sub(value, text)
