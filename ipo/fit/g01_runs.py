"""Runs of consecutive G01 moves: the stretches of a program that a curve fit may replace.

A run is a maximal sequence of Line entities in which each move continues the
previous one: same feed, same path control, no corner sharper than `corner_deg`
(the angle between successive directions), nothing else in between. A caller may
add its own condition (`joinable`), e.g. that the two blocks sit on adjacent
source lines.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from ipo.errors import FIT_SETTINGS, IpoError
from ipr.entities import Line

DEFAULT_CORNER_DEG = 30.0


def turning_angle_deg(a: Line, b: Line) -> float:
    """Angle between the directions of two moves (0 = straight on); 180 for a zero-length move."""
    da = np.subtract(a.end, a.start)
    db = np.subtract(b.end, b.start)
    na, nb = np.linalg.norm(da), np.linalg.norm(db)
    if na == 0.0 or nb == 0.0:
        return 180.0
    return float(np.degrees(np.arccos(np.clip(np.dot(da, db) / (na * nb), -1.0, 1.0))))


def continues(a: Line, b: Line, corner_deg: float) -> bool:
    """b may follow a in the same run."""
    return (b.start == a.end and b.feed_mm_s == a.feed_mm_s and b.path == a.path
            and turning_angle_deg(a, b) <= corner_deg)


def split_runs(entities: Iterable, *, corner_deg: float = DEFAULT_CORNER_DEG,
               joinable: Callable[[Line, Line], bool] | None = None) -> list[list[Line]]:
    """All runs (each >= 1 Line) in program order; entities other than Line end a run.

    Zero-length moves never join a run (they have no direction)."""
    if not 0.0 <= corner_deg <= 180.0:
        raise IpoError(FIT_SETTINGS, f"corner angle must be within 0..180 degrees, got {corner_deg}")
    runs: list[list[Line]] = []
    current: list[Line] = []
    for e in entities:
        if not isinstance(e, Line) or e.start == e.end:
            current = []
            continue
        if current and continues(current[-1], e, corner_deg) and (joinable is None or joinable(current[-1], e)):
            current.append(e)
        else:
            current = [e]
            runs.append(current)
    return runs


def run_vertices(run: list[Line]) -> np.ndarray:
    """(len(run) + 1, 3) polyline: the run's start and the end of every move."""
    return np.array([run[0].start] + [e.end for e in run], dtype=float)
