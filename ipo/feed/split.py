"""A NURBS with corners inside it, as its parts between them.

An interior knot of multiplicity p (the degree) makes the curve only C0 there: it passes
through control point P_{f-1} (f the knot's first index in the knot vector), and its
one-sided tangents point along P_{f-1} - P_{f-2} and P_f - P_{f-1} (the end tangents of the
two clamped halves; where consecutive points coincide, along the first point further out
that differs, the limit of the unit tangent). Where these turn by more than the planner's
corner threshold, the curve is cut there (ipo.nurbs.subcurve) into consecutive entities (NURBS,
or Lines where a part of a degree-1 curve is one segment), so that the corner is handled
like one between blocks: a stop under G61, a crossing at the corner cap under G64 P0, a
blend within P under G64. A C0 knot whose tangents agree stays inside its part and is
crossed at speed, its parametrisation evened out (even_speed). Parts whose control points
all coincide (a repeated point of a polyline) have no length and are dropped.

A part whose derivative vanishes at an end (its first or last control points coincide, as
in LinuxCNC's G5.2 when the program repeats the current position as the first point) has a
tangent there only as a limit, which the steppers cannot start from: the END_TRIM_MM of the
curve at that end is machined as the straight chord to the rest of it (a deviation far
below any BLU, in the direction of the limit tangent), and the rest as a NURBS.

Left out: a cusp where the derivative vanishes inside a curve (p coincident control points of
a curve of degree >= 2) is not cut; the NURBS table rejects it with its "vanishing derivative"
error (E-NURBS-PATH), saying where.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ipo.errors import IpoError
from ipo.feed.sampling import nurbs_table
from ipo.feed.table_verdict import DEGREE as VERDICT_DEGREE, tabled
from ipo.nurbs.kernel import curve_points
from ipo.nurbs.subcurve import sub_curve
from ipr.entities import Line, Nurbs

# a tangent turn at a C0 knot above this is a corner (pieces._CURVE_BLEND_MIN_RAD: gentler
# corners next to NURBS are crossed as they are, so cutting there would change nothing)
CORNER_MIN_RAD = 1e-4
_SAME_POINT_MM = 1e-12  # control points closer than this are the same point
_MAX_SPEED_RATIO = 1e6  # even_speed rescales knots by at most this
# length of a stalled end machined as a chord (a hundredth of the finest BLU the machine file allows)
END_TRIM_MM = 1e-8


def _c0_firsts(p: int, knots: np.ndarray) -> np.ndarray:
    """Index of the first occurrence of each interior knot of multiplicity p (C0 there)."""
    _, first, counts = np.unique(knots[p + 1:len(knots) - p - 1], return_index=True, return_counts=True)
    return first[counts >= p] + p + 1


def _direction(points: np.ndarray, i: int, step: int) -> np.ndarray | None:
    """Unit vector from points[i] to the first point after it in the direction step that
    differs from it, or None if there is none."""
    j = i + step
    while 0 <= j < len(points):
        v = points[j] - points[i]
        n = float(np.linalg.norm(v))
        if n > _SAME_POINT_MM:
            return v / n
        j += step
    return None


def corner_knots(e: Nurbs) -> np.ndarray:
    """Interior knots of e at which its tangent turns by more than CORNER_MIN_RAD."""
    p = int(e.degree)
    knots = np.asarray(e.knots, dtype=float)
    points = np.asarray(e.points, dtype=float)
    out = []
    for f in _c0_firsts(p, knots):
        c = f - 1  # C(knots[f]) = points[c]
        back, ahead = _direction(points, c, -1), _direction(points, c, 1)
        if back is None or ahead is None:
            continue  # the rest of the curve on one side is this very point: no turn
        # a repeated point next to it (a polyline's zero-length segment) is cut off too
        repeated = min(np.linalg.norm(points[c] - points[c - 1]), np.linalg.norm(points[c + 1] - points[c]))
        if repeated <= _SAME_POINT_MM or np.arccos(np.clip(-np.dot(back, ahead), -1.0, 1.0)) > CORNER_MIN_RAD:
            out.append(knots[f])
    return np.array(out)


def even_speed(e: Nurbs) -> Nurbs:
    """e with the knots after each C0 knot scaled so that |C'(u)| is the same on both sides
    of it (the same curve: each side of a knot of multiplicity p is a clamped NURBS of its
    own, unchanged by an affine map of its knots). The steppers predict the parameter step
    from the last one, which a jump of |C'| there would throw off for the rest of the curve."""
    p = int(e.degree)
    knots = np.array(e.knots, dtype=float)
    pts, w = np.asarray(e.points, dtype=float), np.asarray(e.weights, dtype=float)
    firsts = _c0_firsts(p, knots)
    if len(firsts) == 0:
        return e
    for f in firsts:  # left to right: each scaling moves the knots of the ones after it
        u, c = knots[f], f - 1  # C(u) = points[c]
        span_left, span_right = u - knots[c], knots[c + p + 1] - u
        if not (span_left > 0 and span_right > 0):
            continue
        # one-sided |C'(u)| of the two clamped halves (The NURBS Book eq. 4.9 at their ends)
        left = p * w[c - 1] / w[c] * np.linalg.norm(pts[c] - pts[c - 1]) / span_left
        right = p * w[c + 1] / w[c] * np.linalg.norm(pts[c + 1] - pts[c]) / span_right
        # a ratio beyond _MAX_SPEED_RATIO (extreme weights) would squeeze the later knots together
        # in floating point, which changes the curve: those keep their parametrisation
        if left > 0 and right > 0 and 1 / _MAX_SPEED_RATIO <= right / left <= _MAX_SPEED_RATIO:
            knots[c + p + 1:] = u + right / left * (knots[c + p + 1:] - u)
    knots.setflags(write=False)
    return dataclasses.replace(e, knots=knots)


def corner_parts(e: Nurbs) -> list[Nurbs | Line]:
    """e as consecutive motion entities (same line, feed and path control) cut at its corner
    knots, without parts of no length, each with an even parametric speed (even_speed);
    one part when it has no corner inside. A part that is one straight segment (degree 1,
    two control points) is that Line: the same path, on the planner's lean G1 path."""
    e = even_speed(e)
    cuts = corner_knots(e)
    if len(cuts) == 0:
        return _with_moving_ends(e)
    bounds = np.concatenate([[e.knots[0]], cuts, [e.knots[-1]]])
    parts = [sub_curve(e, float(a), float(b)) for a, b in zip(bounds[:-1], bounds[1:])]
    return [r for q in parts if np.ptp(q.points, axis=0).max() > _SAME_POINT_MM
            for r in ([Line(e.line, q.start, q.end, e.feed_mm_s, e.path)] if len(q.points) == 2
                      else _with_moving_ends(q))]


def _trim_u(e: Nurbs, at_start: bool) -> float:
    """The parameter END_TRIM_MM (as a chord) from e's start or end: bisection on the chord,
    which grows from 0 there (the first or last points coincide, so no nearer point returns)."""
    knots = np.asarray(e.knots, dtype=float)
    u_end = float(knots[0] if at_start else knots[-1])
    end_point = np.asarray(e.points[0 if at_start else -1], dtype=float)
    near, far = u_end, float(knots[-1] if at_start else knots[0])
    for _ in range(200):
        mid = 0.5 * (near + far)
        if mid in (near, far):
            break
        chord = np.linalg.norm(curve_points(e.degree, knots, e.weights, e.points, np.array([mid]))[0] - end_point)
        near, far = (mid, far) if chord < END_TRIM_MM else (near, mid)
    return far


def _with_moving_ends(e: Nurbs) -> list[Nurbs | Line]:
    """e, with each end where its derivative vanishes (module docstring) machined as a chord."""
    pts = np.asarray(e.points, dtype=float)
    stalled_start = e.degree >= 2 and np.linalg.norm(pts[1] - pts[0]) <= _SAME_POINT_MM
    stalled_end = e.degree >= 2 and np.linalg.norm(pts[-1] - pts[-2]) <= _SAME_POINT_MM
    if not (stalled_start or stalled_end):
        return [e]
    u0, u1 = float(e.knots[0]), float(e.knots[-1])
    a = _trim_u(e, True) if stalled_start else u0
    b = _trim_u(e, False) if stalled_end else u1
    if not a < b:
        return [Line(e.line, e.start, e.end, e.feed_mm_s, e.path)]  # all of it within END_TRIM_MM
    body = sub_curve(e, a, b)
    head = [Line(e.line, e.start, body.start, e.feed_mm_s, e.path)] if stalled_start else []
    tail = [Line(e.line, body.end, e.end, e.feed_mm_s, e.path)] if stalled_end else []
    return head + [body] + tail


def planning_problem(e: Nurbs, end_gap_mm: float = 0.0) -> str | None:
    """Why the feed stage cannot walk e, or None: its parts' arc-length tables (with the
    planner's end gap, ipo.feed.planner.nurbs_end_gap_mm) are what it builds first, so a
    controller that checks them before moving never stops mid-program. A degree-2 part that
    ipo.feed.table_verdict is sure of is not tabled here (the fit asks about thousands)."""
    try:
        for part in corner_parts(e):
            if isinstance(part, Nurbs) and not _surely_tabled(part, end_gap_mm):
                nurbs_table(part, end_gap_mm)
    except IpoError as err:
        return err.message
    return None


def _surely_tabled(part: Nurbs, end_gap_mm: float) -> bool:
    """Copies: one compiled signature (the parts' arrays are read-only, the programs' may not be)."""
    return part.degree == VERDICT_DEGREE and tabled(np.array(part.knots, dtype=float), np.array(part.weights, dtype=float),
                                                    np.array(part.points, dtype=float), float(end_gap_mm))
