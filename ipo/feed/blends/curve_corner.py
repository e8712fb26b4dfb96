"""G64 corner blends next to a curve: where an arc or a NURBS meets a line, an arc or a NURBS
non-tangentially.

The blend is sized by the rule of the line and arc corners (ipo.feed.pieces): a circular arc of
radius R tangent to both tangents at the corner, R (sec(theta/2) - 1) <= P, whose tangent
points lie d = R tan(theta/2) from the corner, within what either move may give up. The
moves are trimmed back by d along their arc length, and a cubic joins the trimmed ends,
tangent to both, with the handles of the circular arc through them. Because an arc or a
NURBS bends within d, the cubic is then checked against the programmed corner (its largest
distance from the two moves, its distance from the corner point) and shrunk until both
are within P.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ipo.feed.blends.compiled import blend_deviation, cubic_points, polyline_distance
from ipo.numpy_kernels import dot3

_CHECK_BLEND = 33  # points checked along the cubic (its midpoint among them)
_CHECK_SIDE = 65  # points of each move's trimmed stretch (a polyline far finer than P)
_TRIES = 12
_SLACK = 1e-9  # relative: a deviation of P to float rounding passes


class Side(NamedTuple):
    """One move next to the corner, by the distance x (mm of arc length) from the corner:
    at(x) -> (point, unit tangent in the direction of travel) and polyline(x, n) -> (n, 3)
    points of the move from the corner to x (only dense, not evenly spaced); kv(x) -> its
    curvature vector (for the G2 joints of ipo.feed.blends.g2_joints)."""

    at: Callable[[float], tuple[np.ndarray, np.ndarray]]
    polyline: Callable[[float, int], np.ndarray]
    kv: Callable[[float], np.ndarray]


def arc_cubic(a: np.ndarray, ta: np.ndarray, b: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """Control points (4, 3) of the cubic from a to b tangent to ta and tb, with the handles
    h = 4/3 tan(phi/4) R of the circular arc of turn phi through a and b, which with the chord
    |b - a| = 2 R sin(phi/2) is h = |b - a| / (3 cos^2(phi/4))."""
    # the dot products as dot3 forms them, not numpy's: numpy's BLAS sums 3-vectors in an order that differs
    # from one CPU to another, and the batched blends (ipo.feed.arc_corners) must make the same bits
    phi = np.arccos(min(max(dot3(ta, tb), -1.0), 1.0))  # np.clip of one float, without its overhead
    chord = b - a
    h = math.sqrt(dot3(chord, chord)) / (3.0 * np.cos(0.25 * phi) ** 2)
    return np.array([a, a + h * ta, b - h * tb, b])


def _bernstein3(u: np.ndarray) -> np.ndarray:
    """The cubic Bernstein values (M, 4) at parameters u (M,)."""
    v = 1.0 - u[:, None]
    uu = u[:, None]
    return np.hstack([v**3, 3 * v * v * uu, 3 * v * uu * uu, uu**3])


_CHECK_BASIS = _bernstein3(np.linspace(0.0, 1.0, _CHECK_BLEND))


def deviation(q: np.ndarray, before: Side, after: Side, d_before: float, d_after: float, corner: np.ndarray,
              side_points: int = _CHECK_SIDE, q_fine: np.ndarray | None = None) -> float:
    """The larger of the largest distance of a blend's points q from the two moves' last
    d_before and first d_after (polylines of side_points points each) and the blend's
    distance from the corner point; with q_fine (the blend densely), also the largest
    distance of those stretches' points from it (a move that bends within the stretch must
    not be cut across)."""
    side_a, side_b = before.polyline(d_before, side_points), after.polyline(d_after, side_points)
    worst = blend_deviation(q, side_a, side_b, np.asarray(corner, dtype=np.float64))
    if q_fine is None:
        return worst
    return max(worst, float(polyline_distance(side_a, q_fine).max()), float(polyline_distance(side_b, q_fine).max()))


def corner_blend(before: Side, after: Side, corner: np.ndarray, theta: float, tol_mm: float, d_max: float
                 ) -> tuple[float, np.ndarray] | None:
    """(d, cubic control points) for the corner point `corner` of turn theta between `before`
    and `after`, or None where no blend within tol_mm was found (the planner then crosses
    the corner at its cap)."""
    half = 0.5 * theta
    radius = tol_mm / (1.0 / np.cos(half) - 1.0)  # R (sec(theta/2) - 1) <= P, as in ipo.feed.pieces
    d = min(radius * np.tan(half), d_max)
    for _ in range(_TRIES):
        if not d > 0:
            return None
        ctrl = arc_cubic(*before.at(d), *after.at(d))
        worst = deviation(cubic_points(_CHECK_BASIS, ctrl), before, after, d, d, corner) / tol_mm
        if worst <= 1.0 + _SLACK:
            return d, ctrl
        d *= min(0.99, 0.995 / worst)  # the deviation grows about linearly with d
    return None
