"""Where task stops the motion and how long the machine then stands (emctaskmain.cc).

Task executes a spindle, coolant, tool, message, dwell, program stop or end, "immediate" I/O
or user M-code block only once the motion queue is empty (emcTaskCheckPreconditions:
WAITING_FOR_MOTION), so the motion stops there; synchronized I/O (M62, M63, M67), the
override switches (M48-M53) and M61 go with the motion. The machine then stands until task
has done the block and sent the next move: a few task cycles, and for coolant and tool blocks
iocontrol's loop as well ([EMCIO]CYCLE_TIME: it reads task's command once a cycle and reports
back on a later one). These waits are task's wall-clock timing, not the planner's: they vary
from run to run; the figures below are the medians measured on LinuxCNC's simulator with a 1 ms
task cycle and a 100 ms iocontrol cycle (tests/data/linuxcnc_twin/README.md: waits_random,
12-24 of each), in units of those cycles.
"""
from __future__ import annotations

from ipo.linuxcnc_ini import LinuxcncSettings
from ipr.entities import Auxiliary, Coolant, Dwell, Message, Spindle, ToolChange

# codes task sends without waiting for the motion (synced I/O, override switches, tool number)
INLINE_CODES = frozenset({"M62", "M63", "M67", "M48", "M49", "M50", "M51", "M52", "M53", "M61"})
TASK_WAIT_CYCLES = 7  # spindle, S, message, dwell, M64-M66, M68, user M-codes: 5-12 ms measured
IO_CYCLES_COOLANT_ON = 0.8  # M7 or M8 turning a coolant on: 70-80 ms measured
IO_CYCLES_COOLANT_OFF = 1.7  # per coolant M9 turns off: 160-170 ms measured (both: 365 ms)
IO_CYCLES_TOOL_CHANGE = 3.8  # M6: 300-465 ms measured


def stops_motion(e) -> bool:
    """Task waits for the motion queue to empty before this event."""
    return not (isinstance(e, Auxiliary) and e.code in INLINE_CODES)


class TaskWaits:
    """How long the machine stands at each event; keeps the coolant state it needs."""

    def __init__(self, s: LinuxcncSettings):
        self.s = s
        self.mist = self.flood = False

    def seconds(self, e) -> float:
        s = self.s
        if isinstance(e, Coolant):
            on = (e.mist and not self.mist) + (e.flood and not self.flood)
            off = (self.mist and not e.mist) + (self.flood and not e.flood)
            self.mist, self.flood = e.mist, e.flood
            return max(s.io_cycle_s * (IO_CYCLES_COOLANT_ON * on + IO_CYCLES_COOLANT_OFF * off),
                       TASK_WAIT_CYCLES * s.task_cycle_s)
        if isinstance(e, ToolChange):
            return IO_CYCLES_TOOL_CHANGE * s.io_cycle_s
        if isinstance(e, (Spindle, Message, Dwell, Auxiliary)):
            return TASK_WAIT_CYCLES * s.task_cycle_s + (e.seconds if isinstance(e, Dwell) else 0.0)
        return 0.0  # a program stop waits for the operator; the end is the end
