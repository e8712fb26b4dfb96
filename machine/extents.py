"""Axis-aligned extents of motion entities, for the travel-limit check before a run.

Lines and rapids span their end points. Arcs are exact: the in-plane extremes are
the end points plus every quarter point (0°, 90°, 180°, 270° about the centre) the
sweep passes, and the helix axis spans its start and end. A NURBS curve lies in the
box of its control points (convex hull property); only when that box leaves the
travel is the curve itself sampled densely (SAMPLES_PER_SPAN per knot span), so
the reported extent of such a curve is exact to the sampling's sagitta.
"""
from __future__ import annotations

import math
from itertools import chain

import numpy as np

from ipo.nurbs.kernel import curve_points
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs, Rapid

SAMPLES_PER_SPAN = 256


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


def nurbs_extent(curve: Nurbs, lo_mm: np.ndarray, hi_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The control-point box if it fits the travel, else the box of a dense sampling."""
    lo, hi = curve.points.min(axis=0), curve.points.max(axis=0)
    if np.all(lo >= lo_mm) and np.all(hi <= hi_mm):
        return lo, hi
    breaks = np.unique(curve.knots[curve.degree:len(curve.knots) - curve.degree])
    t = np.linspace(0.0, 1.0, SAMPLES_PER_SPAN + 1)
    u = np.unique((breaks[:-1, None] + np.diff(breaks)[:, None] * t[None, :]).ravel())
    pts = curve_points(curve.degree, curve.knots, curve.weights, curve.points, u)
    return pts.min(axis=0), pts.max(axis=0)


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
