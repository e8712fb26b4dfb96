"""The NURBS drivers one build of pieces makes or trims, kept apart from the intake's own.

ipo.feed.pieces.build reads the drivers of the curves it joins (their arc-length tables)
and, at G64 corners, trims a curve (its driver replaced by the one of the remaining part,
or dropped when nothing is left) or adds a blend curve with a new driver. It records all
of that here, over a read-only view of the drivers the intake holds (ipo.feed.intake);
the intake then hands the drivers of the built pieces to the window with them.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping


class DriverChanges:
    """A mapping NURBS index -> driver: the intake's drivers with this build's changes on top."""

    def __init__(self, drivers: Mapping, next_index: int, make_drivers: Callable):
        self._base = drivers
        self._next = next_index  # the index the first new blend gets
        self._make = make_drivers  # list of Nurbs -> their drivers (a pure factory)
        self.changed: dict = {}  # index -> new driver, or None where a curve was trimmed away
        self.added = 0  # blends added, indices next_index..next_index + added - 1

    def __getitem__(self, k: int):
        if k in self.changed:
            drv = self.changed[k]
            if drv is None:
                raise KeyError(k)
            return drv
        return self._base[k]

    def __setitem__(self, k: int, drv) -> None:
        self.changed[k] = drv

    def __delitem__(self, k: int) -> None:
        self[k]  # a KeyError for a curve that is not there, as a dict's del
        self.changed[k] = None

    def add(self, blends: list) -> tuple[range, list]:
        """New blend curves: their indices and their drivers, made in one call (a build has thousands)."""
        idx = range(self._next + self.added, self._next + self.added + len(blends))
        self.added += len(blends)
        made = self._make(blends)
        self.changed.update(zip(idx, made))
        return idx, made
