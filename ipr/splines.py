"""G5 (cubic) and G5.1 (quadratic) splines as exact curves: Bezier segments are NURBS.

LinuxCNC's G5 X Y I J P Q: a cubic Bezier from the current point to X Y whose first
control point is the start + (I, J) and whose second is the end + (P, Q); I J may be left
out on a G5 that follows a G5, then they continue the previous curve smoothly (I J = -P -Q
of the previous block). G5.1 X Y I J: a quadratic Bezier with its control point at the
start + (I, J). Both lie in the XY plane (G17) and keep Z. A Bezier of degree d is the NURBS
with d + 1 control points, unit weights and the clamped knots [0]*(d+1) + [1]*(d+1), so the
IPO interpolates it with its NURBS interpolator, exactly.
"""
from __future__ import annotations

import numpy as np

from ipr.entities import Nurbs
from ipr.errors import BlockError
from ipr.gcodes import SPLINE_CUBIC
from ipr.modal import rotate_xy, target
from ipr.nurbs_groups import _frozen


def spline(st, spec, vals, motion_before: int | None, feed_mm_s: float, line: int) -> Nurbs:
    """The Nurbs of a G5/G5.1 block (ends at the block's X Y)."""
    idx, where = spec.index, spec.where.get("motion")
    cubic = st.motion == SPLINE_CUBIC
    name = "G5" if cubic else "G5.1"
    if st.plane != "XY":
        raise BlockError("E-ARC-FORMAT", f"{name} splines lie in the XY plane (G17 first)", where)
    if "Z" in idx:
        raise BlockError("E-ARC-FORMAT", f"{name} moves in XY only: no Z word", idx["Z"])
    if "X" not in idx and "Y" not in idx:
        raise BlockError("E-WORD-MISSING", f"{name} needs X or Y (the end point)", where)
    u = st.unit
    if cubic:
        if ("I" in idx) != ("J" in idx):
            raise BlockError("E-WORD-MISSING", "G5 needs I and J together", idx.get("I", idx.get("J")))
        if "P" not in idx or "Q" not in idx:
            raise BlockError("E-WORD-MISSING", "G5 needs P and Q (the end's control point)", where)
        if "I" in idx:
            i, j = vals[idx["I"]] * u, vals[idx["J"]] * u
        elif motion_before == SPLINE_CUBIC and st.spline_pq is not None:
            i, j = -st.spline_pq[0], -st.spline_pq[1]
        else:
            raise BlockError("E-WORD-MISSING", "G5 needs I and J unless it follows another G5", where)
        p, q = vals[idx["P"]] * u, vals[idx["Q"]] * u
    else:
        if "I" not in idx and "J" not in idx:
            raise BlockError("E-WORD-MISSING", "G5.1 needs I or J (the control point)", where)
        i, j = (vals[idx[k]] * u if k in idx else 0.0 for k in "IJ")
    start = st.pos
    end = target(st, spec, vals, start)
    i, j = rotate_xy(st, i, j)
    points = [start, (start[0] + i, start[1] + j, start[2])]
    if cubic:
        st.spline_pq = (p, q)   # program frame, for the next G5's I J
        p, q = rotate_xy(st, p, q)
        points.append((end[0] + p, end[1] + q, end[2]))
    points.append(end)
    degree = len(points) - 1
    knots = [0.0] * (degree + 1) + [1.0] * (degree + 1)
    st.pos = end
    return Nurbs(line, degree, _frozen(knots), _frozen(np.ones(degree + 1)), _frozen(points), feed_mm_s, st.path)
