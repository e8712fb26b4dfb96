"""The look-ahead window: what the planner has read but not yet emitted, under one owner.

The window holds the path pieces built so far and where each starts, the NURBS drivers
those pieces walk, the samples with their caps on v^2 (and reasons, and corner flags), and
the events waiting for the machine to reach their place on the path. The planner
(ipo.feed.planner) owns one window: it extends it with the pieces and drivers the intake
(ipo.feed.intake) built, which the window samples (ipo.feed.sampling) and caps (a pure
function of the samples and pieces, ipo.feed.limits.sample_caps with the machine's
limits), places the events the intake placed, and drops what has been emitted. The
output side (ipo.feed.emission) only reads it.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ipo.feed.nurbs_driver import BlendCurve, NurbsDriver
from ipo.feed.pieces import Pieces
from ipo.feed.sampling import Samples, sample

Caps = Callable[[Samples, Pieces], tuple[np.ndarray, np.ndarray, np.ndarray]]


class Window:
    """Pieces, drivers, samples with caps, and pending events between intake and emission."""

    def __init__(self, caps: Caps, end_gap_mm: float):
        self._caps = caps  # (samples, pieces) -> cap, reason, corner
        self._end_gap_mm = end_gap_mm  # the NURBS tables' end gap (ipo.feed.sampling.nurbs_table)
        self.pieces: Pieces | None = None
        self.piece_base = 0  # global index of pieces[0]
        self.pstart = np.zeros(0)  # global arc length where each held piece starts
        self.samples: Samples | None = None
        self.cap = np.zeros(0)  # v^2 cap at each sample
        self.reason = np.zeros(0, np.int8)  # the LIMIT_* code of each cap
        self.corner = np.zeros(0, bool)  # a sample at an unblended corner
        self.x0_v2 = 0.0  # v^2 at the first held sample
        self.tail = None  # S-curve mode: the last plan's rest from the first held sample (ipo.feed.scurve)
        self.s_end_mm = 0.0  # arc length at the end of everything built
        self.drivers: dict[int, NurbsDriver | BlendCurve] = {}  # NURBS index -> driver (a blend: its curve)
        self.events: list[tuple[float, object]] = []  # (arc length, event), in path order

    def extend(self, pc: Pieces, drivers: dict[int, NurbsDriver | BlendCurve]) -> None:
        """New pieces after those held, with the drivers of the NURBS indices they walk,
        sampled and capped."""
        self.drivers.update(drivers)
        if len(pc) == 0:
            return
        tables = {k: drv.table for k, drv in drivers.items()}
        self._append(pc, sample(pc, self.s_end_mm, tables, end_gap_mm=self._end_gap_mm))

    def _append(self, pc: Pieces, smp: Samples) -> None:
        """New pieces and their samples (global piece indices from 0 within pc), capped."""
        if self.pieces is None:
            base = self.piece_base
            self.pieces = pc
            self.pstart = self.s_end_mm + np.concatenate([[0.0], np.cumsum(pc.length)[:-1]])
        else:
            base = self.piece_base + len(self.pieces)
            self.pieces = Pieces.concat([self.pieces, pc])
            self.pstart = np.concatenate([self.pstart, self.s_end_mm + np.concatenate(
                [[0.0], np.cumsum(pc.length)[:-1]])])
        smp.piece += base
        local = self.pieces
        if self.samples is None:
            self.samples = smp
            self.cap, self.reason, self.corner = self._caps(self._relative(smp), local)
        else:
            # the last two held samples are capped again: a corner where the windows join
            # also caps the sample before it (limits.CORNER_SHARE); they and the new ones are
            # the end of the joined window (a view, not a second copy of the new samples)
            j = min(2, len(self.samples))
            self.samples = Samples.concat([self.samples, smp])
            cap, reason, corner = self._caps(self._relative(self.samples.tail(len(self.samples) - len(smp) - j)),
                                             local)
            lower = cap[:j] < self.cap[-j:]
            self.cap[-j:] = np.where(lower, cap[:j], self.cap[-j:])
            self.reason[-j:] = np.where(lower, reason[:j], self.reason[-j:])
            self.corner[-j:] |= corner[:j]
            self.cap = np.concatenate([self.cap, cap[j:]])
            self.reason = np.concatenate([self.reason, reason[j:]])
            self.corner = np.concatenate([self.corner, corner[j:]])
        self.s_end_mm += float(pc.length.sum())

    def _relative(self, smp: Samples) -> Samples:
        return Samples(smp.s, smp.t, smp.kv, smp.piece - self.piece_base, smp.sigma)

    def drop(self, k: int) -> None:
        """Forget samples before k and the pieces no sample refers to any more."""
        self.samples = self.samples.tail(k)
        self.cap, self.reason, self.corner = self.cap[k:], self.reason[k:], self.corner[k:]
        first = int(self.samples.piece[0]) - self.piece_base
        if first > 0:
            kept = set(self.pieces.nurbs[first:].tolist())
            for i in np.unique(self.pieces.nurbs[:first]).tolist():
                if i >= 0 and i not in kept:
                    self.drivers.pop(i, None)
            self.pieces = self.pieces.take(slice(first, None))
            self.pstart = self.pstart[first:]
            self.piece_base += first

    def reset(self) -> None:
        """At a stop with everything emitted: no pieces or samples held."""
        if self.pieces is not None:
            self.piece_base += len(self.pieces)
        self.pieces, self.samples = None, None
        self.pstart = np.zeros(0)
        self.cap, self.reason, self.corner = np.zeros(0), np.zeros(0, np.int8), np.zeros(0, bool)
        self.x0_v2 = 0.0
        self.tail = None

    def add_event(self, s_mm: float, event) -> None:
        """An event that happens where the machine reaches arc length s_mm (after those held)."""
        self.events.append((s_mm, event))

    def take_events(self, n: int) -> None:
        """The first n events have been put out."""
        del self.events[:n]

    def pop_events(self) -> list:
        """All events held, in path order, now put out (at a stop, everything emitted)."""
        out = [ev for _, ev in self.events]
        self.events.clear()
        return out
