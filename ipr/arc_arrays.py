"""Arcs as arrays: their points, plane axes, start angles, signed sweeps and radii, computed for a
whole list of ipr.entities.Arc at once by the same rules, bit for bit, as the Arc's own
properties (radius_mm, sweep_rad): numpy's hypot, arctan2 and mod give an array's elements
exactly what they give one float. The travel check (machine.extents), `vcnc parse`'s summary
and the feed stage's arc pieces (ipo.feed.pieces) take them from here.
"""
from __future__ import annotations

from itertools import chain
from operator import attrgetter
from typing import NamedTuple

import numpy as np

from ipr.entities import PLANE_AXES, Arc


def coordinates(entities, attr: str) -> np.ndarray:
    """(n, 3) array of one point attribute ("start", "end", "center") of n entities."""
    return np.fromiter(chain.from_iterable(map(attrgetter(attr), entities)), float,
                       3 * len(entities)).reshape(-1, 3)


_PLANES = ("XY", "ZX", "YZ")
_PLANE_AXES = np.array([PLANE_AXES[p] for p in _PLANES])


class ArcSweeps(NamedTuple):
    """Arcs as arrays: (n, 3) start, end and centre; per arc its plane's axes (n, 3: a, b,
    normal), the start angle, the signed sweep (ipr.entities.Arc.sweep_rad's rule, full turns
    included) and the start's and end's distance from the centre in the plane."""

    start: np.ndarray
    end: np.ndarray
    centre: np.ndarray
    axes: np.ndarray
    a0_rad: np.ndarray
    sweep_rad: np.ndarray
    r_start_mm: np.ndarray
    r_end_mm: np.ndarray


def arc_sweeps(arcs: list[Arc]) -> ArcSweeps:
    n = len(arcs)
    start, end, centre = coordinates(arcs, "start"), coordinates(arcs, "end"), coordinates(arcs, "center")
    axes = _PLANE_AXES[[_PLANES.index(m.plane) for m in arcs]].reshape(n, 3)
    rows, a, b = np.arange(n), axes[:, 0], axes[:, 1]
    sa, sb = start[rows, a] - centre[rows, a], start[rows, b] - centre[rows, b]
    ea, eb = end[rows, a] - centre[rows, a], end[rows, b] - centre[rows, b]
    a0, a1 = np.arctan2(sb, sa), np.arctan2(eb, ea)
    ccw = np.fromiter(map(attrgetter("ccw"), arcs), bool, n)
    turns = np.fromiter(map(attrgetter("turns"), arcs), float, n)
    up, down = np.mod(a1 - a0, 2 * np.pi), -np.mod(a0 - a1, 2 * np.pi)
    sweep = np.where(ccw, np.where(up > 1e-12, up, 2 * np.pi), np.where(down < -1e-12, down, -2 * np.pi))
    sweep += np.copysign(2 * np.pi * turns, sweep)
    return ArcSweeps(start, end, centre, axes, a0, sweep, np.hypot(sa, sb), np.hypot(ea, eb))
