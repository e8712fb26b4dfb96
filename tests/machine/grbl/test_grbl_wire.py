"""What the grbl twin is told grbl does with each line: grbl 1.1 waits for the machine to stand
only where a spindle or coolant line changes its state (gcode.c spindle_sync, coolant_sync), at
G4, M0 and M2, and never at M1."""
from __future__ import annotations

from ipo.config import default_config
from ipo.feed.grbl_twin.wire import DWELL, END, MODAL, MOVE, STOP, SYNC
from ipr import parse_text
from machine.grbl.program import stream_groups
from machine.grbl.wire import wire_lines


def _wire(text: str):
    program = parse_text(text, "t.nc")
    return [(w.kind, w.n_bytes, w.source_line) for w in wire_lines(stream_groups(program.entities, default_config()))]


def test_only_changes_of_spindle_and_coolant_wait():
    kinds = [k for k, _, _ in _wire("G21 G90\nM3 S1000\nG1 X10 F600\nM3 S1000\nG1 X20\nM3 S2000\nM5\nM8\nM8\nM9\n"
                                    "M1\nG4 P0.2\nM0\nM2\n")]
    # M3 S1000 (from M5 S0: waits), G1, M3 S1000 again (nothing changes), G1, S2000 (spindle on: waits),
    # M5 (waits); M8: the link writes M9 (coolant already off: no wait) then M8 (waits); M8 again: M9
    # (off: waits) and M8 (on: waits); M9 (waits); M1 (grbl 1.1 ignores it); G4; M0; M2
    assert kinds == [SYNC, MOVE, MODAL, MOVE, SYNC, SYNC, MODAL, SYNC, SYNC, SYNC, SYNC, MODAL, DWELL, STOP, END]


def test_bytes_are_the_lines_on_the_wire():
    wire = _wire("G21 G90\nG1 X10 F600\nG1 Y5\nM2\n")
    assert [(n, line) for _, n, line in wire] == [(len("G1F600X10\n"), 2), (len("Y5\n"), 3), (len("M2\n"), 4)]
