"""Where a stopped stream continues: the machine position decides.

After a stop (error, alarm, lost connection) grbl's `ok`s say what was planned, not
what ran: a soft reset drops planned blocks, and acknowledgements can be lost with
the connection. The position grbl reports lies on the streamed path, so the first
line of the window that has the position at its start or inside it is where the
program continues; lines whose end the machine has reached are done. Non-motion
lines (spindle, coolant, dwell) just before that line are sent again: their effect
is idempotent and the machine cannot tell whether they ran.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ipr.entities import PLANE_AXES
from machine.grbl.program import StreamLine

POSITION_TOL_MM = 0.002  # grbl reports 3 decimals; the stream writes 4


class ResumeError(RuntimeError):
    """The machine is not where any line of the window starts or passes."""


@dataclass(frozen=True, slots=True)
class ResumePoint:
    seq: int  # first line to send
    partial: bool  # the machine stopped inside this line: send it from the machine position
    at_mm: tuple[float, float, float]


def _on_path(line: StreamLine, p: np.ndarray, tol: float) -> str:
    """'start', 'end', 'inside' or 'off' for position p against one motion line. A line
    that ends where it starts (a full circle) counts as not started."""
    s, e = np.asarray(line.start_mm), np.asarray(line.end_mm)
    if np.linalg.norm(p - s) <= tol and (np.linalg.norm(s - e) <= tol or np.linalg.norm(p - e) > tol):
        return "start"
    if np.linalg.norm(p - e) <= tol:
        return "end"
    if line.arc is None:
        d = e - s
        t = float(np.dot(p - s, d) / np.dot(d, d))
        return "inside" if 0.0 < t < 1.0 and np.linalg.norm(s + t * d - p) <= tol else "off"
    center, plane, ccw, _ = line.arc
    a, b, n = PLANE_AXES[plane]
    c = np.asarray(center)
    r_s = np.hypot(s[a] - c[a], s[b] - c[b])
    r_p = np.hypot(p[a] - c[a], p[b] - c[b])
    lo, hi = sorted((s[n], e[n]))
    if not (abs(r_p - r_s) <= tol and lo - tol <= p[n] <= hi + tol):
        return "off"
    # on the circle is not enough: near where two tangent arcs meet, the point is on both circles
    turn = 1.0 if ccw else -1.0

    def swept(q):  # angle from the start to q in the direction of travel, 0..2 pi
        return (turn * (np.arctan2(q[b] - c[b], q[a] - c[a]) - np.arctan2(s[b] - c[b], s[a] - c[a]))) % (2 * np.pi)

    sweep = swept(e) if np.linalg.norm(s - e) > tol else 2 * np.pi
    return "inside" if swept(p) <= sweep + tol / max(r_s, tol) else "off"


def find_resume(window: Sequence[StreamLine], at_mm, tol_mm: float = POSITION_TOL_MM) -> ResumePoint:
    """The resume point for a machine standing at `at_mm`, among the lines of `window`
    (in stream order, starting no later than the first line that may not have run).
    The earliest match wins: a path that passes the same point twice within the window
    repeats lines rather than skipping any."""
    if not window:
        raise ResumeError("no stream lines to resume from")
    p = np.asarray(at_mm, float)
    pending = None  # first of the non-motion lines since the last motion line
    ended = False  # the last motion line seen ends at p
    for line in window:
        if not line.motion:
            pending = line.seq if pending is None else pending
            continue
        where = _on_path(line, p, tol_mm)
        if where == "start":
            return ResumePoint(pending or line.seq, False, tuple(float(v) for v in p))
        if where == "inside":
            return ResumePoint(line.seq, True, tuple(float(v) for v in p))
        ended = where == "end"
        pending = None
    if ended or not any(l.motion for l in window):
        return ResumePoint(pending or window[-1].seq + 1, False, tuple(float(v) for v in p))
    raise ResumeError(f"the machine stands at X{p[0]:.3f} Y{p[1]:.3f} Z{p[2]:.3f}, which is on none of "
                      f"stream lines {window[0].seq}..{window[-1].seq}; move it to the start of the line "
                      f"to resume from, or pick another line")
