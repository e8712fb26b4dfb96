"""The feed stage's intake: motion entities read but not yet built into path pieces.

A motion's end corner depends on the move after it, so the intake holds the motions it
has read (each with the spindle speed it runs under and, for a NURBS, the index of its
driver) until a build (ipo.feed.pieces.build) can lay them out: all but the last, or all
of them at a stop. A NURBS is taken as its parts between its C0 corners (ipo.feed.split),
each with its driver (ipo.feed.nurbs_driver). The intake owns the drivers of the motions
it holds and hands those of every built piece over with the pieces (`NewPieces`); the
window (ipo.feed.window) then owns them. It also says where along the path an event read
now happens: where the motions read so far end.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ipo.feed.nurbs_driver import BlendCurve, NurbsDriver, blend_curves
from ipo.feed.pieces import Motion, Pieces, build, motion_length
from ipo.feed.sampling import nurbs_table
from ipo.feed.split import corner_parts
from ipr.entities import Nurbs, Spindle

_BUILD_CHUNK = 2048  # motions turned into pieces per build


class CornerRules(NamedTuple):
    """How corners are blended beyond G64 P (S-curve mode; ipo.feed.limits): no circular
    blend tighter than min_blend_radius_mm, and the curvature-continuous blends' limits
    (None: circular blends only)."""

    min_blend_radius_mm: float
    g2_limits: tuple[float, float, float, float] | None


class NewPieces(NamedTuple):
    """What a build hands to the window: the pieces, and the driver of every NURBS index
    they walk (trimmed curves and corner blends included)."""

    pieces: Pieces
    drivers: dict[int, NurbsDriver | BlendCurve]


class Intake:
    """Pending motions with their drivers; see the module docstring."""

    def __init__(self, *, method: str, end_gap_mm: float, blend_default_mm: float, rapid_mm_s: float,
                 corners: CornerRules):
        self.method = method
        self.end_gap_mm = end_gap_mm
        self.blend_default_mm = blend_default_mm
        self.rapid_mm_s = rapid_mm_s
        self.corners = corners
        self._motions: list[tuple] = []  # (entity, rpm, NURBS index), as Motion; lines as plain tuples
        self._drivers: dict[int, NurbsDriver] = {}  # the held NURBS motions' drivers
        self._next_index = 0  # NURBS indices handed out so far
        self._trim = 0.0  # how much of the held-back motion's start its corner blend took
        self._rpm = 0.0

    @property
    def pending(self) -> bool:
        return bool(self._motions)

    def add_line(self, e) -> bool:
        """A line or rapid that moves (the bulk of any program: kept lean); True when
        enough is held for a build."""
        self._motions.append((e, self._rpm, -1))
        return len(self._motions) > _BUILD_CHUNK

    def add(self, e) -> bool:
        """An arc, or a NURBS as its parts between its corners; True as add_line."""
        for m in corner_parts(e) if isinstance(e, Nurbs) else (e,):
            idx = -1
            if isinstance(m, Nurbs):
                idx = self._next_index
                self._next_index += 1
                self._drivers[idx] = self._driver(m)
            self._motions.append(Motion(m, self._rpm, idx))
        return len(self._motions) > _BUILD_CHUNK

    def spindle(self, e: Spindle) -> None:
        """The spindle speed the motions read from now on run under (the roughness limiter's)."""
        self._rpm = e.rpm if e.direction is not None else 0.0

    def _driver(self, e: Nurbs) -> NurbsDriver:
        return NurbsDriver(e, nurbs_table(e, end_gap_mm=self.end_gap_mm), self.method)

    def build(self, *, final: bool) -> NewPieces | None:
        """Pieces of all held motions but the last (its end corner needs the next move), or
        of all of them if `final`; None while fewer than two are held and not final."""
        motions = self._motions
        if not motions or (len(motions) < 2 and not final):
            return None
        built = build(motions, final=final, lead_trim_mm=self._trim, blend_default_mm=self.blend_default_mm,
                      rapid_mm_s=self.rapid_mm_s, drivers=self._drivers, next_index=self._next_index,
                      make_drivers=blend_curves, min_blend_radius_mm=self.corners.min_blend_radius_mm,
                      g2_limits=self.corners.g2_limits)
        self._next_index += built.drivers.added
        pc = built.pieces
        handed = {i: built.drivers[i] for i in np.unique(pc.nurbs[pc.nurbs >= 0]).tolist()}
        if final:
            motions.clear()
            self._drivers = {}
            # the last motion was built whole: nothing is held back, so no corner of it
            # reaches into the next motion (a stale trim cut the start off the first move
            # after a dwell or a stop that followed an event)
            self._trim = 0.0
        else:
            del motions[:-1]
            held = motions[0][2]
            self._drivers = {held: self._drivers[held]} if held >= 0 else {}
            self._trim = built.trim_mm
        return NewPieces(pc, handed)

    def event_at_mm(self, s_built_mm: float) -> float:
        """Where an event read now happens, given the arc length s_built_mm at the end of the
        pieces built so far (call build(final=False) first): at the end of the held-back
        motion (its end corner is not known yet, so the point is its programmed end)."""
        if not self._motions:
            return s_built_mm
        return s_built_mm + motion_length(self._motions[0], self._drivers) - self._trim
