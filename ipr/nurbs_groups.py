"""NURBS block groups: Fanuc G06.2 (and LinuxCNC's G6.2 form) and LinuxCNC G5.2/G5.3.

A group spans several blocks; each block's contribution (a control point, a weight, a
knot) is checked first and appended only when the whole block is accepted, so an
erroneous block leaves the group as it was. A complete group becomes one
ipr.entities.Nurbs with read-only arrays.
"""
from __future__ import annotations

import numpy as np

from ipr.entities import Nurbs, PathControl
from ipr.errors import BlockError
from ipr.gcodes import NURBS_FANUC, NURBS_LINUXCNC

START_TOL_MM = 0.001   # gcode.md: a NURBS never starts with a jump
MIN_ORDER, MAX_ORDER = 2, 6
FANUC_DEFAULT_ORDER = 4
G5_DEFAULT_ORDER = 3


class NurbsGroup:
    """The blocks of one NURBS group read so far. `kind` is NURBS_FANUC (G6.2) or NURBS_LINUXCNC (G5.2)."""

    __slots__ = ("kind", "line", "order", "points", "weights", "knots", "closing", "feed_mm_s", "path")

    def __init__(self, kind: int, line: int, order: int, feed_mm_s: float, path: PathControl):
        self.kind = kind
        self.line = line
        self.order = order
        self.points: list[tuple[float, float, float]] = []
        self.weights: list[float] = []
        self.knots: list[float] = []
        self.closing = 0           # knot-only blocks read (G6.2)
        self.feed_mm_s = feed_mm_s
        self.path = path

    @property
    def name(self) -> str:
        return "G6.2" if self.kind == NURBS_FANUC else "G5.2"

    def complete(self) -> bool:
        return self.kind == NURBS_FANUC and self.points and self.closing == self.order


def check_order(order: float, word: int | None) -> int:
    if order != round(order) or not MIN_ORDER <= order <= MAX_ORDER:
        raise BlockError("E-NURBS-ORDER", f"NURBS order {order:g} is not an integer in "
                         f"{MIN_ORDER}..{MAX_ORDER}", word)
    return int(order)


def check_weight(weight: float, word: int | None) -> float:
    if not weight > 0.0:
        raise BlockError("E-NURBS-WEIGHT", f"NURBS weight {weight:g} is not > 0", word)
    return weight


def check_start(point, position, word: int | None) -> None:
    gap = float(np.max(np.abs(np.subtract(point, position))))
    if gap > START_TOL_MM:
        raise BlockError("E-NURBS-START", f"first control point is {gap:.4f} mm away from the current "
                         "position: a NURBS must start where the tool is", word)


def check_knot(group: NurbsGroup, knot: float, word: int | None) -> None:
    if group.knots and knot < group.knots[-1]:
        raise BlockError("E-NURBS-KNOT-ORDER", f"knot {knot:g} is smaller than the knot before it "
                         f"({group.knots[-1]:g})", word)


def validate_knots(knots: np.ndarray, n_points: int, order: int, group_line: int, word: int | None):
    """The whole knot vector: count, clamped ends, interior multiplicity."""
    if n_points < order:
        raise BlockError("E-NURBS-POINTS", f"NURBS of order {order} needs at least {order} control "
                         f"points, the group begun at line {group_line} has {n_points}", word)
    if len(knots) != n_points + order:
        raise BlockError("E-NURBS-KNOT-COUNT", f"{len(knots)} knots for {n_points} control points of "
                         f"order {order}: need {n_points + order}", word)
    if np.any(knots[:order] != knots[0]) or np.any(knots[-order:] != knots[-1]):
        raise BlockError("E-NURBS-KNOT-CLAMP", f"the first {order} and the last {order} knots must each "
                         "be equal (a clamped curve starts and ends on its end control points)", word)
    if knots[-1] <= knots[0]:
        raise BlockError("E-NURBS-KNOT-CLAMP", "the knot vector spans no parameter range", word)
    interior = knots[order:-order]
    if np.any(interior <= knots[0]) or np.any(interior >= knots[-1]):
        raise BlockError("E-NURBS-KNOT-CLAMP", f"the first and last knot values may each be repeated only {order} "
                         "times (more leaves an end control point with no influence on the curve)", word)
    if len(interior):
        _, counts = np.unique(interior, return_counts=True)
        if counts.max() >= order:
            raise BlockError("E-NURBS-KNOT-MULT", f"an interior knot is repeated {counts.max()} times; "
                             f"order {order} allows at most {order - 1}", word)


def g5_knots(n_points: int, order: int) -> np.ndarray:
    """LinuxCNC's G5.2 knot vector (nurbs_G5_knot_vector_creator), scaled to 0..1:
    `order` zeros, then 1, 2, ..., then `order` times n - order + 2 (n = points - 1)."""
    n = n_points - 1
    umax = n - order + 2
    k = [0 if i < order else (i - order + 1 if i <= n else umax) for i in range(n + order + 1)]
    return np.asarray(k, dtype=float) / umax


def _frozen(a) -> np.ndarray:
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


def finish(group: NurbsGroup, word: int | None) -> Nurbs:
    """The Nurbs of a finished group (raises BlockError on an invalid knot vector)."""
    n = len(group.points)
    if group.kind == NURBS_LINUXCNC:
        if n < group.order:
            raise BlockError("E-NURBS-POINTS", f"G5.2 of order {group.order} needs at least "
                             f"{group.order} control points (the current position counts), the group "
                             f"begun at line {group.line} has {n}", word)
        knots = g5_knots(n, group.order)
    else:
        knots = np.asarray(group.knots, dtype=float)
        validate_knots(knots, n, group.order, group.line, word)
    return Nurbs(group.line, group.order - 1, _frozen(knots), _frozen(group.weights),
                 _frozen(group.points).reshape(n, 3), group.feed_mm_s, group.path)
