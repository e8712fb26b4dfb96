"""Feed modes G93/G94/G95 and spindle speed modes G96/G97.

IPR hands the IPO a feed in mm/s for every move, so the modes end here:
- G94 (units per minute): F * unit / 60, the modal `feed_mm_s`.
- G93 (inverse time): F is 1/minutes for this move, and every feed move must carry F; the
  move's feed is its length / (60 / F) (rs274: SET_FEED_RATE(F * length)).
- G95 (units per revolution): F * unit * S / 60 with the programmed spindle speed S.
A G93/G94/G95 word sets the feed rate to zero, even the active mode's, as LinuxCNC does (an F
in the same block then applies). G96 (constant surface speed, S in m/min or ft/min, D max rpm) and G97 are
carried as Auxiliary events: the spindle model does not simulate CSS.
"""
from __future__ import annotations

import math

from ipr.entities import PLANE_AXES, Auxiliary
from ipr.errors import BlockError
from ipr.gcodes import FEED_PER_MINUTE, FEED_PER_REV, SPINDLE_CSS


def set_feed_mode(st, spec, code: int) -> None:
    st.feed_mode = code
    st.feed_mm_s = 0.0   # LinuxCNC's convert_feed_mode: every G93/G94/G95, even the active one


def set_spindle_mode(st, spec, vals, out: list, line: int, code: int) -> None:
    idx = spec.index
    if code == SPINDLE_CSS:
        if "S" not in idx:
            raise BlockError("E-WORD-MISSING", "G96 needs an S word (surface speed)", spec.where["spindle_mode"])
        max_rpm = vals[idx["D"]] if "D" in idx else 0.0
        per = "ft/min" if st.unit != 1.0 else "m/min"
        st.css = (vals[idx["S"]], max_rpm)
        limit = f", at most {max_rpm:g} rpm" if max_rpm else ""
        out.append(Auxiliary(line, "G96", f"constant surface speed {vals[idx['S']]:g} {per}{limit}"))
    else:
        if st.css is not None:
            out.append(Auxiliary(line, "G97", "spindle speed in rpm"))
        st.css = None


def move_feed_mm_s(st, spec, vals, where, start, end, arc=None) -> float:
    """The feed of one feed move under the active feed mode (mm/s)."""
    if st.feed_mode == FEED_PER_MINUTE:
        return st.feed_mm_s
    if st.feed_mode == FEED_PER_REV:
        if st.css is not None:
            raise BlockError("E-FEED-MODE", "feed per revolution (G95) under constant surface speed "
                             "(G96): the spindle speed depends on the radius, which vcnc does not simulate",
                             where)
        if st.spindle_rpm <= 0.0:
            raise BlockError("E-FEED-MODE", "feed per revolution (G95) with spindle speed zero", where)
        return st.feed_mm_s * st.spindle_rpm
    if "F" not in spec.index:
        raise BlockError("E-FEED-MODE", "inverse time feed (G93): every feed move needs an F word", where)
    return vals[spec.index["F"]] / 60.0 * path_length_mm(start, end, arc)


def path_length_mm(start, end, arc=None) -> float:
    """Length of a line, or of an ipr.entities.Arc (helix included)."""
    if arc is None:
        return math.dist(start, end)
    a, b, n = PLANE_AXES[arc.plane]
    planar = abs(arc.sweep_rad) * arc.radius_mm
    return math.hypot(planar, end[n] - start[n])
