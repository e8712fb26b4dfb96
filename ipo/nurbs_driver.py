"""Walks one NURBS entity with its stepper (ipo.steppers) along a planned arc-length schedule.

The stepper takes chord lengths; the feed stage plans arc length. Each period's target
chord is the arc step shortened by the circle estimate d (1 - kappa^2 d^2 / 24), and
after every call the stepper's arc position is read back from its curve parameter (the
table's Hermite s(u)), so the stepper's own chord tolerances never accumulate into a
speed error at the end of the curve.
"""
from __future__ import annotations

import numpy as np

from ipo.sampling import NurbsTable
from ipo.steppers import make_stepper


class NurbsDriver:
    def __init__(self, entity, table: NurbsTable, method: str):
        self.entity = entity
        self.table = table
        self.method = method
        self.stepper = None
        self.s_reached = 0.0
        self.end = np.array(entity.points[-1], dtype=float)

    def points(self, sigma: np.ndarray, sigma_before: float) -> np.ndarray:
        """Points at arc lengths sigma (from the curve's start); sigma_before is where the
        previous period ended (negative: inside the previous piece)."""
        n = len(sigma)
        out = np.repeat(self.end[None, :], n, axis=0)
        length = self.table.length
        target = np.minimum(sigma, length)
        lead = 0.0
        if self.stepper is None:
            lead = max(-sigma_before, 0.0)
            self.stepper = make_stepper(self.entity, method=self.method, lead_mm=lead)
            self.s_reached = 0.0
        if self.stepper.done:
            return out
        d = np.maximum(np.diff(target, prepend=self.s_reached), 0.0)
        kappa = self.table.curvature_at(target - 0.5 * d)
        steps = d * (1.0 - (kappa * d) ** 2 / 24.0)  # chord of an arc of length d
        steps[0] += lead
        # a period that reaches the curve's end must end on it even if the stepper lags
        steps[target >= length] = np.maximum(steps[target >= length], 2.0 * length + 1.0)
        st = self.stepper.advance(steps)
        k = len(st.u)
        out[:k] = st.pos_mm
        self.s_reached = length if st.done else self.table.s_of_u(float(st.u[-1])) if k else self.s_reached
        return out
