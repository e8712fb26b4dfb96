"""Named G- and M-codes, in the interpreter's integer form: the code times ten.

The interpreter keys its modal groups by code x 10 so that decimal codes stay integers
(G5.2 -> 52, G6.2 -> 62, G53 -> 530, G64 -> 640). This module names them once; code that
compares a block's code writes `motion == NURBS_FANUC`, not `motion == 62`. It imports
nothing, so ipr, ipo and machine may all use it.
"""
from __future__ import annotations

# motion (modal group 1)
MOTION_RAPID = 0  # G0
MOTION_LINEAR = 10  # G1
MOTION_ARC_CW = 20  # G2
MOTION_ARC_CCW = 30  # G3
NURBS_LINUXCNC = 52  # G5.2: LinuxCNC's NURBS group, current position is control point 0
NURBS_LINUXCNC_END = 53  # G5.3: closes a G5.2 group
NURBS_FANUC = 62  # G6.2: Fanuc's NURBS group (and LinuxCNC's G6.2 form)
MOTION_CANCEL = 800  # G80

# non-modal (group 0)
DWELL = 40  # G4
MACHINE_COORDS = 530  # G53
OFFSET_SET = 920  # G92
OFFSET_CANCEL = 921  # G92.1

# planes, units, distance modes, tool length, path control
PLANE_XY, PLANE_XZ, PLANE_YZ = 170, 180, 190  # G17, G18, G19
UNITS_INCH, UNITS_MM = 200, 210  # G20, G21
TOOL_LENGTH_ON, TOOL_LENGTH_OFF = 430, 490  # G43, G49
WORK_OFFSETS = (540, 550, 560, 570, 580, 590)  # G54..G59
EXACT_PATH, EXACT_STOP, BLEND = 610, 611, 640  # G61, G61.1, G64
FEED_PER_MINUTE = 940  # G94
COMPENSATION_OFF = 400  # G40
ABSOLUTE, INCREMENTAL = 900, 910  # G90, G91
ARC_ABSOLUTE, ARC_INCREMENTAL = 901, 911  # G90.1, G91.1

# M-codes, also x 10
PROGRAM_STOP, OPTIONAL_STOP, PROGRAM_END, PROGRAM_END_RESET = 0, 10, 20, 300  # M0, M1, M2, M30
SPINDLE_CW, SPINDLE_CCW, SPINDLE_STOP = 30, 40, 50  # M3, M4, M5
TOOL_CHANGE = 60  # M6
MIST_ON, FLOOD_ON, COOLANT_OFF = 70, 80, 90  # M7, M8, M9

NURBS_MOTIONS = (NURBS_LINUXCNC, NURBS_FANUC)
