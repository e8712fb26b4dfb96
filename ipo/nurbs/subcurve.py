"""The part of a NURBS between two parameters, as a NURBS of its own (exactly the same curve).

Boehm's knot insertion in homogeneous coordinates (Piegl & Tiller, The NURBS Book, A5.1):
inserting u until it has multiplicity p makes C(u) a control point, and the control points
and knots on one side of it are a clamped NURBS of that side. A G64 corner blend trims a
NURBS entity this way, so its stepper walks the remaining part from its start to its end.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ipo.errors import NURBS_CUT, IpoError
from ipr.entities import Nurbs

# a split parameter this close (relative to the knot range) to an existing knot is that knot:
# inserting it would leave a span too short for the stepper's polynomial form
_SNAP = 1e-12


def _insert(p: int, knots: np.ndarray, pw: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """Knots and homogeneous control points with u inserted once (Boehm)."""
    k = int(np.searchsorted(knots, u, side="right")) - 1  # knots[k] <= u < knots[k + 1]
    q = np.empty((len(pw) + 1, pw.shape[1]))
    q[:k - p + 1] = pw[:k - p + 1]
    q[k + 1:] = pw[k:]
    i = np.arange(k - p + 1, k + 1)
    alpha = ((u - knots[i]) / (knots[i + p] - knots[i]))[:, None]
    q[i] = alpha * pw[i] + (1.0 - alpha) * pw[i - 1]
    return np.insert(knots, k + 1, u), q


def _to_multiplicity(p: int, knots: np.ndarray, pw: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Insert u until it has multiplicity p; returns knots, points and the index of its first
    occurrence f, so that C(u) is control point f - 1."""
    for _ in range(p - int(np.count_nonzero(knots == u))):
        knots, pw = _insert(p, knots, pw, u)
    return knots, pw, int(np.searchsorted(knots, u, side="left"))


def _snapped(knots: np.ndarray, u: float) -> float:
    j = int(np.argmin(np.abs(knots - u)))
    return float(knots[j]) if abs(knots[j] - u) <= _SNAP * (knots[-1] - knots[0]) else float(u)


def sub_curve(e: Nurbs, u0: float, u1: float) -> Nurbs:
    """The curve e restricted to [u0, u1] (a clamped NURBS with the same line, feed and path)."""
    p = int(e.degree)
    knots = np.asarray(e.knots, dtype=float)
    lo, hi = float(knots[0]), float(knots[-1])
    u0, u1 = _snapped(knots, u0), _snapped(knots, u1)
    if not lo <= u0 < u1 <= hi:
        raise IpoError(NURBS_CUT, f"cannot cut a NURBS with knot range [{lo}, {hi}] to [{u0}, {u1}]", e.line)
    w = np.asarray(e.weights, dtype=float)
    pw = np.column_stack([np.asarray(e.points, dtype=float) * w[:, None], w])
    if u1 < hi:
        knots, pw, f = _to_multiplicity(p, knots, pw, u1)
        knots, pw = np.concatenate([knots[:f + p], [u1]]), pw[:f]
    if u0 > lo:
        knots, pw, f = _to_multiplicity(p, knots, pw, u0)
        knots, pw = np.concatenate([[u0], knots[f:]]), pw[f - 1:]
    weights = pw[:, 3].copy()
    points = pw[:, :3] / weights[:, None]
    for a in (knots, weights, points):
        a.setflags(write=False)
    return dataclasses.replace(e, knots=knots, weights=weights, points=points)
