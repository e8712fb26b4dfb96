"""Per-axis servo model: what the axes actually do with the commanded positions.

The axes are velocity-commanded; one loop law covers both configured models:
    dx/dt = g·(c − x) + f·dc/dt
(proportional gain g in 1/s, velocity feed-forward fraction f). The "lag" model is
the first-order lag with time constant tau: g = 1/tau, f = 0. The "pd" model is a
PD law on the following error e = c − x, dx/dt = kp·e + kd·de/dt, which solves to
g = kp/(1 + kd), f = kd/(1 + kd). Between two periods the command c moves linearly
(the drive interpolates the setpoint), and the law is integrated exactly over that
segment, so the model adds no discretisation error of its own.

Ramp check: a constant command velocity v settles at the following error
(1 − f)·v/g (= v·tau for the lag, v/kp for the PD loop); a circle of radius R at
angular rate w under the lag model settles on a circle of radius R/sqrt(1 + (w·tau)²).

Contour error is the distance from the actual position to the commanded path (the
polyline through the commanded points), searched over the recent segments only.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ipo.segments import segment_distance


@njit(cache=True)
def _follow(cmd, c0, x0, a, gain_ramp, out):
    """Exact solution of de/dt = (1-kd)·dc/dt − kp·e over each linear command segment."""
    e = c0 - x0
    prev = c0.copy()
    for k in range(cmd.shape[0]):
        for i in range(3):
            dc = cmd[k, i] - prev[i]
            e[i] = a * e[i] + gain_ramp * dc
            out[k, i] = cmd[k, i] - e[i]
            prev[i] = cmd[k, i]


@njit(cache=True)
def _contour(actual, path, first, window, out):
    """out[k] = distance from actual[k] to the polyline path[max(0, first+k-window) .. first+k]."""
    for k in range(actual.shape[0]):
        end = first + k
        best = segment_distance(actual[k], path[end], path[end])
        for j in range(max(0, end - window), end):
            best = min(best, segment_distance(actual[k], path[j], path[j + 1]))
        out[k] = best


class ServoModel:
    """State of the three axis loops; `follow` takes commanded positions batch by batch."""

    def __init__(self, gain_1_s: float, feedforward: float, period_s: float, start_mm):
        self._a = math.exp(-gain_1_s * period_s)
        self._gain_ramp = (1.0 - feedforward) * (1.0 - self._a) / (gain_1_s * period_s)
        self._command = np.array(start_mm, dtype=float)
        self.actual_mm = np.array(start_mm, dtype=float)
        # Segments searched for the contour error: 6 time constants of the error decay back.
        self.window = int(math.ceil(6.0 / (gain_1_s * period_s))) + 2
        self._tail = self._command[None, :].copy()

    @classmethod
    def lag(cls, time_constant_s: float, period_s: float, start_mm) -> "ServoModel":
        if not time_constant_s > 0:
            raise ValueError(f"servo.time_constant_s must be > 0 for the lag model (got {time_constant_s})")
        return cls(1.0 / time_constant_s, 0.0, period_s, start_mm)

    @classmethod
    def pd(cls, kp_1_s: float, kd: float, period_s: float, start_mm) -> "ServoModel":
        if not kp_1_s > 0:
            raise ValueError(f"servo.kp_1_s must be > 0 for the pd model (got {kp_1_s})")
        if not kd >= 0:
            raise ValueError(f"servo.kd must be >= 0 (got {kd})")
        return cls(kp_1_s / (1.0 + kd), kd / (1.0 + kd), period_s, start_mm)

    @classmethod
    def from_config(cls, servo, period_s: float, start_mm) -> "ServoModel | None":
        """The model an ipo.config.Servo asks for; None for model "none"."""
        if servo.model == "lag":
            return cls.lag(servo.time_constant_s, period_s, start_mm)
        if servo.model == "pd":
            return cls.pd(servo.kp_1_s, servo.kd, period_s, start_mm)
        return None

    def follow(self, cmd_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Actual positions (N, 3) and contour errors (N,) in mm for the next N commanded points."""
        cmd_mm = np.ascontiguousarray(cmd_mm, dtype=float)
        actual = np.empty_like(cmd_mm)
        _follow(cmd_mm, self._command, self.actual_mm.copy(), self._a, self._gain_ramp, actual)
        path = np.concatenate((self._tail, cmd_mm))
        contour = np.empty(len(cmd_mm))
        _contour(actual, path, len(self._tail), self.window, contour)
        if len(cmd_mm):
            self._command = cmd_mm[-1].copy()
            self.actual_mm = actual[-1].copy()
            self._tail = path[-(self.window + 1):].copy()
        return actual, contour
