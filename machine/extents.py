"""Axis-aligned extents of motion entities, for the travel-limit check before a run.

Lines and rapids span their end points. Arcs are exact: the in-plane extremes are
the end points plus every quarter point (0°, 90°, 180°, 270° about the centre) the
sweep passes, and the helix axis spans its start and end. A NURBS curve lies in the
box of its control points (convex hull property, weights > 0); where that box leaves
the travel, the extreme on that side is bounded exactly, not sampled: each knot span
whose own control points leave the travel is a rational Bezier segment, whose control
points bound it and whose end points lie on it, and the segment with the highest bound
is halved (de Casteljau in homogeneous coordinates) until the attained extreme and the
bound agree to EXTREME_TOL_MM or the limit lies outside them (branch and bound). A
sharp peak between any samples is found; a curve that takes more than
MAX_SUBDIVISIONS halvings to decide is reported by its bound (refused, not risked).
"""
from __future__ import annotations

import heapq
import math
from itertools import count
from typing import NamedTuple

import numpy as np

from ipo.nurbs.subcurve import sub_curve
from ipr.arc_arrays import arc_sweeps, coordinates
from ipr.entities import Arc, Line, Nurbs, Rapid

# the extreme of a NURBS is decided to this (far below any BLU; well above rounding at 1e4 mm)
EXTREME_TOL_MM = 1e-9
# halvings per curve side before the check gives up and takes the bound (a degenerate weight set)
MAX_SUBDIVISIONS = 20000


_QUARTERS = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))   # cos, sin of 0, 90, 180, 270 degrees


def arc_boxes(arcs: list[Arc]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) exact low and high corners of arcs: in the plane the end points and every quarter
    point (0, 90, 180, 270 degrees about the centre) the sweep passes; along the normal (the
    helix) the start and the end."""
    g = arc_sweeps(arcs)
    lo, hi = np.minimum(g.start, g.end), np.maximum(g.start, g.end)
    rows, r = np.arange(len(arcs)), np.maximum(g.r_start_mm, g.r_end_mm)
    for q, cos_sin in enumerate(_QUARTERS):
        theta = q * np.pi / 2
        ahead = np.where(g.sweep_rad >= 0, np.mod(theta - g.a0_rad, 2 * np.pi), np.mod(g.a0_rad - theta, 2 * np.pi))
        passed = rows[ahead <= np.abs(g.sweep_rad)]
        for k in (0, 1):
            axis = g.axes[passed, k]
            coord = g.centre[passed, axis] + r[passed] * cos_sin[k]
            lo[passed, axis] = np.minimum(lo[passed, axis], coord)
            hi[passed, axis] = np.maximum(hi[passed, axis], coord)
    return lo, hi


def _halves(pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A rational Bezier segment's homogeneous control points split at t = 1/2 (de Casteljau)."""
    rows, left, right = pw, [pw[0]], [pw[-1]]
    while len(rows) > 1:
        rows = 0.5 * (rows[:-1] + rows[1:])
        left.append(rows[0])
        right.append(rows[-1])
    return np.array(left), np.array(right[::-1])


def _bezier_segments(curve: Nurbs, axis: int, sign: float, limit: float) -> list[np.ndarray]:
    """Homogeneous control points of the knot spans whose own control points pass `limit`
    on the side `sign` of `axis` (only they can: each span lies in the hull of its p+1 points)."""
    p, knots = int(curve.degree), np.asarray(curve.knots, dtype=float)
    spans = [k for k in range(p, len(knots) - p - 1) if knots[k] < knots[k + 1]]
    out = []
    for k in spans:
        if np.max(sign * curve.points[k - p:k + 1, axis]) <= sign * limit:
            continue
        seg = sub_curve(curve, float(knots[k]), float(knots[k + 1]))
        out.append(np.column_stack([seg.points * seg.weights[:, None], seg.weights]))
    return out


def curve_extreme(curve: Nurbs, axis: int, sign: float, limit: float) -> float:
    """The curve's extreme of coordinate `axis` (sign +1: max, -1: min), exact to EXTREME_TOL_MM
    where it may pass `limit`, else a value within `limit`. Branch and bound over rational
    Bezier segments (module docstring); undecided after MAX_SUBDIVISIONS, the bound."""
    def bound(pw):  # control points bound the segment, its end points are on it
        v = sign * pw[:, axis] / pw[:, 3]
        return float(v.max()), float(max(v[0], v[-1]))

    order = count()
    heap, best = [], -math.inf
    for pw in _bezier_segments(curve, axis, sign, limit):
        upper, attained = bound(pw)
        best = max(best, attained)
        heapq.heappush(heap, (-upper, next(order), pw))
    if not heap:
        return limit
    for _ in range(MAX_SUBDIVISIONS):
        if heap[0][0] > -best - EXTREME_TOL_MM:  # every remaining bound within the tolerance
            return sign * best
        _, _, pw = heapq.heappop(heap)
        for half in _halves(pw):
            up, att = bound(half)
            best = max(best, att)
            if up > best:
                heapq.heappush(heap, (-up, next(order), half))
        if not heap:
            return sign * best
    upper = -heap[0][0]
    return sign * (best if best > sign * limit else upper)  # undecided near the limit: refused


def nurbs_extent(curve: Nurbs, lo_mm: np.ndarray, hi_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The control-point box, each side that leaves the travel replaced by the curve's exact extreme."""
    lo, hi = curve.points.min(axis=0).copy(), curve.points.max(axis=0).copy()
    for i in range(3):
        if hi[i] > hi_mm[i]:
            hi[i] = curve_extreme(curve, i, 1.0, hi_mm[i])
        if lo[i] < lo_mm[i]:
            lo[i] = curve_extreme(curve, i, -1.0, lo_mm[i])
    return lo, hi


class Excursion(NamedTuple):
    """A motion at `line` reaching `reach_mm` on `axis` (0..2), past the travel on `side`
    (+1: above the upper limit, -1: below the lower)."""

    line: int
    axis: int
    side: int
    reach_mm: float

    def reason(self, lo_mm: np.ndarray, hi_mm: np.ndarray) -> str:
        limit, where = (hi_mm[self.axis], "above") if self.side > 0 else (lo_mm[self.axis], "below")
        return f"{'XYZ'[self.axis]} reaches {self.reach_mm:.4f} mm, {where} the travel limit {limit:.4f} mm"


def excursions_of(groups: dict[type, list], lo_mm: np.ndarray, hi_mm: np.ndarray) -> list[Excursion]:
    """Every motion of groups (motions grouped by type, ipr.entities.group_by_type) that leaves
    the travel, one Excursion per axis and side, in line order.

    A straight move spans its start and end, and its start is the previous motion's
    end (or the start position, which the caller checks), so its end point suffices.
    """
    boxes: list[tuple[int, np.ndarray, np.ndarray]] = []
    straight = groups.get(Line, []) + groups.get(Rapid, [])
    if straight:
        ends = coordinates(straight, "end")
        bad = np.nonzero(((ends < lo_mm) | (ends > hi_mm)).any(axis=1))[0]
        boxes += [(straight[i].line, ends[i], ends[i]) for i in bad]
    arcs = groups.get(Arc)
    if arcs:
        lo, hi = arc_boxes(arcs)
        bad = np.nonzero(((lo < lo_mm) | (hi > hi_mm)).any(axis=1))[0]
        boxes += [(arcs[i].line, lo[i], hi[i]) for i in bad]
    boxes += [(m.line, *nurbs_extent(m, lo_mm, hi_mm)) for m in groups.get(Nurbs, ())]
    out: list[Excursion] = []
    for line, lo, hi in sorted(boxes, key=lambda b: b[0]):
        for i in range(3):
            if lo[i] < lo_mm[i]:
                out.append(Excursion(line, i, -1, float(lo[i])))
            if hi[i] > hi_mm[i]:
                out.append(Excursion(line, i, 1, float(hi[i])))
    return out
