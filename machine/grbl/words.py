"""How numbers and words are written for grbl: as few characters as keep the meaning.

A coordinate gets the fewest decimals that keep it within a tenth of the BLU
(`Format.tol_mm`), without a leading zero (grbl reads `.5` and `-.5`); feeds,
spindle speeds and dwell times get the fewest decimals within their own
tolerances. Lines are written in one work frame: text = machine position - frame
(the WCO grbl applies), except G53 moves, which go out as G53 in machine
coordinates. With `numbered`, every line starts with N<seq> so that grbl's
status reports the executing line (`Ln`, builds with line numbers).
"""
from __future__ import annotations

from dataclasses import dataclass

from ipr.entities import PLANE_AXES

PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}
OFFSET_LETTERS = "IJK"
AXIS_LETTERS = "XYZ"
FEED_TOL_MM_MIN = 0.05
RPM_TOL = 0.5
DWELL_TOL_S = 0.0005
MAX_DECIMALS = 9


def fmt(v: float, tol: float) -> str:
    """`v` with the fewest decimals that stay within `tol` of it; '.5' for 0.5, '0' for -0.0."""
    for d in range(MAX_DECIMALS + 1):
        s = f"{v:.{d}f}"
        if abs(float(s) - v) <= tol:
            break
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s in ("-0", ""):
        s = "0"
    if s.startswith("0."):
        s = s[1:]
    elif s.startswith("-0."):
        s = "-" + s[2:]
    return s


@dataclass(frozen=True, slots=True)
class Format:
    """The frame and precision every line of one stream is written in."""

    frame_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # work = machine - frame
    tol_mm: float = 1e-4  # a tenth of the BLU
    numbered: bool = False

    def coord(self, machine_mm: float, axis: int) -> str:
        return fmt(machine_mm - self.frame_mm[axis], self.tol_mm)

    def work(self, machine_mm, axis: int) -> float:
        """The work coordinate grbl holds after receiving coord(machine_mm, axis)."""
        return float(self.coord(machine_mm, axis))

    def feed(self, feed_mm_min: float) -> str:
        return fmt(feed_mm_min, FEED_TOL_MM_MIN)

    @property
    def written_rounding_mm(self) -> float:
        """How far writing a vertex can move it (all three axes rounded)."""
        return self.tol_mm * 3 ** 0.5


def arc_words(fmt_: Format, start_work: tuple, end_mm, center_mm, plane: str, changed: str) -> str:
    """An arc's end words and IJK (centre - start, from the start grbl holds): the axes
    in `changed`, and at least one in-plane axis (grbl's error:32 otherwise)."""
    a, b, _ = PLANE_AXES[plane]
    axes = changed or AXIS_LETTERS[a]
    if AXIS_LETTERS[a] not in axes and AXIS_LETTERS[b] not in axes:
        axes = AXIS_LETTERS[a] + axes
    words = "".join(f"{AXIS_LETTERS[k]}{fmt_.coord(end_mm[k], k)}" for k in range(3) if AXIS_LETTERS[k] in axes)
    offs = [(k, fmt(center_mm[k] - fmt_.frame_mm[k] - start_work[k], fmt_.tol_mm)) for k in sorted((a, b))]
    offs_text = "".join(f"{OFFSET_LETTERS[k]}{v}" for k, v in offs if v != "0") or f"{OFFSET_LETTERS[a]}0"
    return words + offs_text
