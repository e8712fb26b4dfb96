"""M-codes beyond spindle, coolant, tool change and stops: what the virtual machine records.

M19 (orient), M48..M53 (override switches), M61 (set the tool number without a change),
M62..M68 (digital and analog outputs, input waits) become ipr.entities.Auxiliary events: a
virtual machine has no I/O, so it carries them to the receivers and the run's notices and
does nothing else. M70..M73 save and restore the modal state (LinuxCNC's "modal state
save/restore": units, distance modes, plane, feed mode and rate, path control, spindle
mode, coolant, G98/G99, tool length offset). M100..M199 run only when the machine file's
`user_mcodes` table names them (an Auxiliary event with that name), else E-MCODE-USER.
"""
from __future__ import annotations

from ipr.dialect import EXTRA_G, EXTRA_M
from ipr.entities import Auxiliary
from ipr.errors import BlockError, code_name
from ipr.gcodes import (IO_OFF, IO_ON, IO_SYNC_OFF, IO_SYNC_ON, MODAL_AUTORESTORE, MODAL_INVALIDATE,
                        MODAL_RESTORE, MODAL_SAVE, SPINDLE_ORIENT, TOOL_NUMBER_SET)

_IO = {620: "synchronised digital output on", 630: "synchronised digital output off",
       640: "digital output on", 650: "digital output off", 660: "wait on input",
       670: "synchronised analog output", 680: "analog output"}
_OVERRIDE = {480: "feed and speed overrides on", 490: "feed and speed overrides off",
             500: "feed override switch", 510: "spindle override switch", 520: "adaptive feed switch",
             530: "feed stop switch"}
# the state M70/M73 save and M72 restores (LinuxCNC's save_settings)
SAVED = ("unit", "absolute", "arc_absolute", "plane", "feed_mode", "feed_mm_s", "path", "css", "mist",
         "flood", "retract_r", "spindle_rpm", "spindle_dir")


def _words(spec, vals) -> str:
    return " ".join(f"{k}{vals[i]:g}" for k, i in spec.index.items() if k in "PQELRD")


def execute_mcodes(st, spec, vals, out: list, line: int, setup) -> None:
    """The recorded M-codes of a block (a dialect's G-codes too) and M70..M73, in LinuxCNC's
    order (before motion)."""
    m = spec.m
    for letter in "GM":
        code = (spec.g if letter == "G" else m).get(f"dialect_{letter.lower()}")
        if code is not None:
            what = (EXTRA_G if letter == "G" else EXTRA_M)[setup.dialect][code]
            out.append(Auxiliary(line, code_name(letter, code / 10), f"{what} ({setup.dialect}) "
                                 f"{_words(spec, vals)}".strip()))
    io = m.get("io")
    if io is not None:
        if io in (IO_SYNC_ON, IO_SYNC_OFF, IO_ON, IO_OFF) and "P" not in spec.index:
            raise BlockError("E-WORD-MISSING", f"{code_name('M', io / 10)} needs a P word (output number)",
                             spec.where["io"])
        out.append(Auxiliary(line, code_name("M", io / 10), f"{_IO[io]} {_words(spec, vals)}".strip()))
    over = m.get("override")
    if over is not None:
        out.append(Auxiliary(line, code_name("M", over / 10), f"{_OVERRIDE[over]} {_words(spec, vals)}".strip()))
    user = m.get("user")
    if user is not None:
        number = user // 10
        if number not in setup.user_mcodes:
            raise BlockError("E-MCODE-USER", f"M{number} is a user M-code that the machine file does not "
                             "name (add it to user_mcodes)", spec.where["user"])
        out.append(Auxiliary(line, f"M{number}", f"{setup.user_mcodes[number]} {_words(spec, vals)}".strip()))
    if m.get("toolchange") == TOOL_NUMBER_SET:
        q = vals[spec.index["Q"]] if "Q" in spec.index else None
        if q is None or q != round(q) or q < 0:
            raise BlockError("E-WORD-MISSING", "M61 needs a whole Q word (the tool in the spindle)",
                             spec.where["toolchange"])
        st.tool_in_spindle = st.tool_selected = int(q)
        out.append(Auxiliary(line, "M61", f"tool T{int(q)} is in the spindle (no change)"))
    spindle = m.get("spindle")
    if spindle == SPINDLE_ORIENT:
        out.append(Auxiliary(line, "M19", f"orient the spindle {_words(spec, vals)}".strip()))
    elif spindle in (MODAL_SAVE, MODAL_AUTORESTORE):
        st.saved_modes = tuple(getattr(st, name) for name in SAVED) + (st.tool_offset,)
    elif spindle == MODAL_RESTORE:
        if st.saved_modes is None:
            raise BlockError("E-WORD-MISSING", "M72 restores a modal state that no M70 saved",
                             spec.where["spindle"])
        *values, tool_offset = st.saved_modes
        for name, value in zip(SAVED, values):
            setattr(st, name, value)
        st.tool_offset = tool_offset
        st.set_offsets()
    elif spindle == MODAL_INVALIDATE:
        st.saved_modes = None
