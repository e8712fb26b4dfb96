"""S-curve (jerk-limited) mode: a moving average over the planned per-period path steps.

The path step of each period is the mean of the last m planned steps, m T = A / J. A
trapezoidal profile's acceleration then ramps over m periods instead of jumping, so the
jerk stays within A / (m T) = J, and no distance is lost: at a stop the filter is run out
with m - 1 periods of zero input, which end exactly on the stop.
"""
from __future__ import annotations

import numpy as np


class MovingAverage:
    """Streaming moving average of per-period path steps over `m` periods."""

    def __init__(self, m: int):
        if m < 1:
            raise ValueError(f"the filter needs at least one period, got {m}")
        self.m = m
        self._held = np.zeros(m - 1)  # the last m - 1 inputs

    @classmethod
    def for_limits(cls, accel_mm_s2: np.ndarray, jerk_mm_s3: np.ndarray, period_s: float) -> "MovingAverage":
        span_s = float(np.max(accel_mm_s2 / jerk_mm_s3))
        return cls(max(int(np.ceil(span_s / period_s - 1e-9)), 1))

    def filter(self, steps: np.ndarray, *, run_out: bool) -> np.ndarray:
        """Filtered steps; with run_out, m - 1 more periods that bring the sum level."""
        if run_out:
            steps = np.concatenate([steps, np.zeros(self.m - 1)])
        joined = np.concatenate([self._held, steps])
        c = np.cumsum(np.concatenate([[0.0], joined]))
        self._held = joined[len(joined) - (self.m - 1):].copy()
        return (c[self.m:] - c[:-self.m]) / self.m
