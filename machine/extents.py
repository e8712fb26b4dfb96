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
from itertools import chain, count

import numpy as np

from ipo.nurbs.subcurve import sub_curve
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs, Rapid

# the extreme of a NURBS is decided to this (far below any BLU; well above rounding at 1e4 mm)
EXTREME_TOL_MM = 1e-9
# halvings per curve side before the check gives up and takes the bound (a degenerate weight set)
MAX_SUBDIVISIONS = 20000


def arc_extent(arc: Arc) -> tuple[np.ndarray, np.ndarray]:
    a, b, n = PLANE_AXES[arc.plane]
    start, end, c = (np.array(v, dtype=float) for v in (arc.start, arc.end, arc.center))
    r = max(math.hypot(start[a] - c[a], start[b] - c[b]), math.hypot(end[a] - c[a], end[b] - c[b]))
    a0 = math.atan2(start[b] - c[b], start[a] - c[a])
    sweep = arc.sweep_rad
    lo_ang, hi_ang = sorted((a0, a0 + sweep))
    pts = [start, end]
    k = math.ceil(lo_ang / (math.pi / 2))
    while k * math.pi / 2 <= hi_ang:
        p = start.copy()
        p[a] = c[a] + r * round(math.cos(k * math.pi / 2))
        p[b] = c[b] + r * round(math.sin(k * math.pi / 2))
        pts.append(p)
        k += 1
    pts = np.array(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    lo[n], hi[n] = min(start[n], end[n]), max(start[n], end[n])
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


def _arcs_near_the_limits(arcs: list[Arc], lo_mm: np.ndarray, hi_mm: np.ndarray) -> list[Arc]:
    """Arcs whose whole circle (centre ± radius in the plane) is not inside the travel."""
    if not arcs:
        return []
    def coords(attr):
        return np.fromiter(chain.from_iterable(getattr(m, attr) for m in arcs), float, 3 * len(arcs)).reshape(-1, 3)
    start, end, centre = coords("start"), coords("end"), coords("center")
    normal = np.array([PLANE_AXES[m.plane][2] for m in arcs])
    in_plane = np.ones((len(arcs), 3), bool)
    in_plane[np.arange(len(arcs)), normal] = False
    r = np.maximum(np.linalg.norm(np.where(in_plane, start - centre, 0), axis=1),
                   np.linalg.norm(np.where(in_plane, end - centre, 0), axis=1))[:, None]
    lo = np.where(in_plane, centre - r, np.minimum(start, end))
    hi = np.where(in_plane, centre + r, np.maximum(start, end))
    near = np.nonzero(((lo < lo_mm) | (hi > hi_mm)).any(axis=1))[0]
    return [arcs[i] for i in near]


def travel_violations(motions, lo_mm: np.ndarray, hi_mm: np.ndarray) -> list[tuple[int, str]]:
    """(line, reason) for every motion that leaves the travel, one per axis and side.

    A straight move spans its start and end, and its start is the previous motion's
    end (or the start position, which the caller checks), so its end point suffices.
    """
    straight = [m for m in motions if type(m) is Line or type(m) is Rapid]
    boxes: list[tuple[int, np.ndarray, np.ndarray]] = []
    if straight:
        ends = np.fromiter(chain.from_iterable(m.end for m in straight), float, 3 * len(straight)).reshape(-1, 3)
        bad = np.nonzero(((ends < lo_mm) | (ends > hi_mm)).any(axis=1))[0]
        boxes += [(straight[i].line, ends[i], ends[i]) for i in bad]
    arcs = [m for m in motions if type(m) is Arc]
    boxes += [(m.line, *arc_extent(m)) for m in _arcs_near_the_limits(arcs, lo_mm, hi_mm)]
    boxes += [(m.line, *nurbs_extent(m, lo_mm, hi_mm)) for m in motions if type(m) is Nurbs]
    out: list[tuple[int, str]] = []
    for line, lo, hi in sorted(boxes, key=lambda b: b[0]):
        for i, name in enumerate("XYZ"):
            if lo[i] < lo_mm[i]:
                out.append((line, f"{name} reaches {lo[i]:.4f} mm, below the travel limit {lo_mm[i]:.4f} mm"))
            if hi[i] > hi_mm[i]:
                out.append((line, f"{name} reaches {hi[i]:.4f} mm, above the travel limit {hi_mm[i]:.4f} mm"))
    return out
