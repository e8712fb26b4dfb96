"""LinuxCNC 2.9's canon layer turns a G5.2 NURBS into biarcs before its planner sees it.

NURBS_FEED (src/emc/task/emccanon.cc) cuts the parameter range of a curve of n + 1 control
points into 4 (n + 1) equal spans and replaces each by a biarc: two tangent arcs from the
span's start point and tangent to its end point and tangent (`biarc`), each sent as an
ARC_FEED (or a straight feed where it is all but straight, `arc`). Tangents are central
differences over 1e-5 of LinuxCNC's parameter (nurbs_additional_functions.cc). LinuxCNC 2.9
takes G5.2 in the XY plane only; the twin does the same in whichever principal plane the
curve lies in (vcnc also reads G5.2 in G18 and G19) and refuses a curve that lies in none.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from ipo.errors import IpoError
from ipo.nurbs.kernel import curve_points
from ipr.entities import PLANE_AXES, Nurbs

UNSUPPORTED = "E-TWIN-UNSUPPORTED"
_DU = 1e-5  # nurbs_tangent's step, in LinuxCNC's parameter (0 .. n - k + 2)
_SMALL = 1e-6  # arc()'s "straight" threshold on the denominator


def nurbs_plane(e: Nurbs) -> str:
    """The principal plane a NURBS lies in (its normal coordinate constant)."""
    for plane, (_, _, c) in PLANE_AXES.items():
        if np.ptp(e.points[:, c]) <= 1e-9:
            return plane
    raise IpoError(UNSUPPORTED, "LinuxCNC 2.9 runs a NURBS only as a G5.2 curve in one plane; this one "
                   "is not planar", e.line)


def biarc_moves(e: Nurbs) -> Iterator[tuple]:
    """The canon calls NURBS_FEED makes, in plane coordinates (a, b of the plane):
    ("arc", (a1, b1), (ca, cb), rotation) or ("line", (a1, b1))."""
    plane = nurbs_plane(e)
    ia, ib, _ = PLANE_AXES[plane]
    k0, k1 = float(e.knots[0]), float(e.knots[-1])
    n_pts = len(e.points)
    u_max_lcnc = n_pts - (e.degree + 1) + 1  # n - k + 2 with n = n_pts - 1, k = degree + 1
    du = _DU / u_max_lcnc * (k1 - k0)
    div = n_pts * 4
    u = k0 + (k1 - k0) * np.arange(div + 1) / div
    lo, hi = np.maximum(k0, u - du), np.minimum(k1, u + du)
    pts = curve_points(e.degree, e.knots, e.weights, e.points, np.concatenate([u, lo, hi]))
    p, p_lo, p_hi = pts[:div + 1], pts[div + 1:2 * div + 2], pts[2 * div + 2:]
    tan = (p_hi - p_lo) / (hi - lo)[:, None]
    P = p[:, [ia, ib]]
    Tn = tan[:, [ia, ib]]
    for i in range(div):
        yield from _biarc(tuple(P[i]), tuple(Tn[i]), tuple(P[i + 1]), tuple(Tn[i + 1]))


def _unit(x: float, y: float) -> tuple[float, float]:
    h = math.hypot(x, y)
    return (x / h, y / h) if h != 0 else (x, y)


def _biarc(p0, ts, p4, te, r: float = 1.0) -> Iterator[tuple]:
    ts, te = _unit(*ts), _unit(*te)
    vx, vy = p0[0] - p4[0], p0[1] - p4[1]
    c = vx * vx + vy * vy
    b = 2 * (vx * (r * ts[0] + te[0]) + vy * (r * ts[1] + te[1]))
    a = 2 * r * (ts[0] * te[0] + ts[1] * te[1] - 1)
    if a == 0.0:  # parallel tangents: LinuxCNC divides by zero here; a straight span is a line
        yield ("line", p4)
        return
    disc = b * b - 4 * a * c
    if disc < 0:
        return  # emccanon's biarc gives up on the span and sends nothing
    sq = math.sqrt(disc)
    beta1, beta2 = (-b - sq) / 2 / a, (-b + sq) / 2 / a
    if beta1 > 0 and beta2 > 0:
        return
    beta = max(beta1, beta2)
    alpha = beta * r
    ab = alpha + beta
    p1 = (p0[0] + alpha * ts[0], p0[1] + alpha * ts[1])
    p3 = (p4[0] - beta * te[0], p4[1] - beta * te[1])
    p2 = ((p1[0] * beta + p3[0] * alpha) / ab, (p1[1] * beta + p3[1] * alpha) / ab)
    tm = _unit(p3[0] - p2[0], p3[1] - p2[1])
    yield _arc(p0, p2, ts)
    yield _arc(p2, p4, tm)


def _arc(p0, p1, d) -> tuple:
    """emccanon's arc(): the arc from p0 to p1 leaving p0 along d."""
    x, y = p1[0] - p0[0], p1[1] - p0[1]
    den = 2 * (y * d[0] - x * d[1])
    if abs(den) <= _SMALL:
        return ("line", p1)
    rad = -(x * x + y * y) / den
    return ("arc", p1, (p0[0] + d[1] * rad, p0[1] - d[0] * rad), 1 if rad < 0 else -1)
