"""Dialects: what posts for other controls write that LinuxCNC refuses or reads otherwise.

The machine file's `dialect` (ipo.config) picks one: `linuxcnc` (the default: rs274's rules),
`fanuc`, `haas`, `mach3`, `grbl`. Each difference is listed in docs/gcode-notes.md with the
dialects that have it; nothing is accepted silently (every extra code is an Auxiliary event
and a N-RECORDED notice).

- bookkeeping codes (`EXTRA_M`, `EXTRA_G`): Haas M31 parts counter, M33 chip conveyor stop,
  M88/M89 through-spindle coolant, G187 smoothness, G103 look-ahead; Fanuc M29 rigid-tap mode,
  G05.1 Q AI contour control, G08 P look-ahead; Mach3 G50 scaling off; they change nothing in
  the simulation;
- a zero offset of the plane's normal axis on an arc (FreeCAD's `K0` in G17), accepted by
  every dialect but linuxcnc;
- Fanuc reads a dwell's P (G4, G82, G86, G88, G89) in milliseconds;
- grbl's `$` lines are sender commands in every dialect: refused with E-DIALECT.
"""
from __future__ import annotations

DIALECTS = ("linuxcnc", "fanuc", "haas", "mach3", "grbl")

# M code (x10) -> what it does, per dialect
EXTRA_M: dict[str, dict[int, str]] = {
    "linuxcnc": {},
    "fanuc": {290: "rigid tapping mode (the tap cycle runs as LinuxCNC's G84)"},
    "haas": {310: "parts counter", 330: "chip conveyor stop", 880: "through-spindle coolant on",
             890: "through-spindle coolant off", 290: "rigid tapping mode (the tap cycle runs as LinuxCNC's G84)"},
    "mach3": {},
    "grbl": {},
}
# G code (x10) -> what it does, per dialect (they take P, Q or E words and no axis words)
EXTRA_G: dict[str, dict[int, str]] = {
    "linuxcnc": {},
    "fanuc": {51: "AI contour control (G05.1 Q)", 80: "look-ahead control (G08 P)"},
    "haas": {1870: "smoothness/accuracy setting (G187)", 1030: "block look-ahead limit (G103)",
             51: "AI contour control (G05.1 Q)", 80: "look-ahead control (G08 P)"},
    "mach3": {500: "scaling off (G50)"},
    "grbl": {},
}


def dwell_seconds(dialect: str, p: float) -> float:
    """A dwell's P in seconds (Fanuc writes milliseconds)."""
    return p / 1000.0 if dialect == "fanuc" else p


def allows_zero_normal_offset(dialect: str) -> bool:
    """K0 on a G17 arc (I0 on G19, J0 on G18): refused by LinuxCNC, read as absent elsewhere."""
    return dialect != "linuxcnc"


def sender_command(text: str) -> bool:
    """A grbl system command line ($H, $X, $$, $J=...)."""
    return text.lstrip().startswith("$")
