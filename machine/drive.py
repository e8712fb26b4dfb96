"""Simulated drive: integrates the per-period BLU increments, guards the travel
limits, measures what the axes did, and feeds the trace.

Positions are integers in BLU, so nothing drifts however long the program. The
measurements are those a drive could make from its own command stream:
- axis velocity per period, inc·BLU/T (exact up to one BLU per period);
- axis acceleration and jerk from finite differences of the positions taken h
  periods apart, h chosen so that the BLU rounding (at most 0.5 BLU per position)
  moves the acceleration by at most 2 % of the smallest acceleration limit;
  the stencil averages over 2h (3h) periods, so it reports plateau values exactly
  and rounds off instantaneous steps;
- chord error, the sagitta between consecutive commanded points, estimated from
  the circle through three consecutive points (exact on arcs; on straight lines the
  BLU rounding alone shows up as at most about BLU/3);
- with a servo model, the actual positions and the contour error.
A travel-limit violation stops the drive at the last period inside the limits.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ipo.period import PeriodBatch
from machine.servo import ServoModel

AXES = "XYZ"


class TravelLimitError(Exception):
    """The command stream left an axis's travel range; the drive did not follow it."""

    def __init__(self, axis: int, value_mm: float, limit_mm: float, line: int, t_s: float):
        self.axis, self.value_mm, self.limit_mm, self.line, self.t_s = axis, value_mm, limit_mm, line, t_s
        side = "below" if value_mm < limit_mm else "above"
        super().__init__(f"line {line}: {AXES[axis]} {value_mm:.4f} mm is {side} the travel limit "
                         f"{limit_mm:.4f} mm (t = {t_s:.3f} s)")


class CommandMismatchError(Exception):
    """A batch's pos_mm disagrees with its integrated increments: a broken producer."""


@dataclass(slots=True)
class DriveLimits:
    """The machine figures the drive needs, per axis."""

    period_s: float
    blu_mm: float
    max_velocity_mm_s: np.ndarray
    max_accel_mm_s2: np.ndarray
    max_jerk_mm_s3: np.ndarray
    min_mm: np.ndarray
    max_mm: np.ndarray
    check_jerk: bool = False  # only an S-curve stage promises bounded jerk

    @classmethod
    def from_config(cls, config) -> "DriveLimits":
        axes = config.axes
        return cls(
            period_s=float(config.period_s),
            blu_mm=float(config.blu_mm),
            max_velocity_mm_s=np.array([a.max_velocity_mm_s for a in axes], dtype=float),
            max_accel_mm_s2=np.array([a.max_accel_mm_s2 for a in axes], dtype=float),
            max_jerk_mm_s3=np.array([a.max_jerk_mm_s3 for a in axes], dtype=float),
            min_mm=np.array([a.min_mm for a in axes], dtype=float),
            max_mm=np.array([a.max_mm for a in axes], dtype=float),
            check_jerk=getattr(config, "accel_mode", "trapezoid") == "scurve",
        )

    def stencil_periods(self) -> int:
        """h: 2·BLU/(h·T)² <= 2 % of the smallest acceleration limit."""
        span_s = math.sqrt(2.0 * self.blu_mm / (0.02 * float(np.min(self.max_accel_mm_s2))))
        return max(1, math.ceil(span_s / self.period_s - 1e-9))

    def meta(self) -> dict:
        return {
            "period_s": self.period_s, "blu_mm": self.blu_mm,
            "max_velocity_mm_s": self.max_velocity_mm_s.tolist(),
            "max_accel_mm_s2": self.max_accel_mm_s2.tolist(),
            "max_jerk_mm_s3": self.max_jerk_mm_s3.tolist(),
            "min_mm": self.min_mm.tolist(), "max_mm": self.max_mm.tolist(),
            "stencil_periods": self.stencil_periods(),
        }


@dataclass(slots=True)
class DriveStats:
    periods: int = 0
    path_length_mm: float = 0.0
    max_velocity_mm_s: np.ndarray = field(default_factory=lambda: np.zeros(3))
    max_accel_mm_s2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    max_jerk_mm_s3: np.ndarray = field(default_factory=lambda: np.zeros(3))
    max_chord_error_mm: float = 0.0
    max_contour_error_mm: float | None = None
    velocity_violations: int = 0
    accel_violations: int = 0
    jerk_violations: int = 0


def chord_errors_mm(p_mm: np.ndarray) -> np.ndarray:
    """Sagitta of each chord p[k]→p[k+1] on the circle through p[k], p[k+1], p[k+2]; (N-2,)."""
    a = p_mm[1:-1] - p_mm[:-2]
    b = p_mm[2:] - p_mm[1:-1]
    c = p_mm[2:] - p_mm[:-2]
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
    area2 = np.linalg.norm(np.cross(a, c), axis=1)  # twice the triangle's area
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = la * lb * lc / (2.0 * area2)  # circumradius
        half = 0.5 * la
        sag = rho - np.sqrt(np.maximum(rho * rho - half * half, 0.0))
    return np.where((area2 > 0) & (la > 0) & (lb > 0), sag, 0.0)


class Drive:
    """Receives PeriodBatch after PeriodBatch; `position_blu` is the exact axis state."""

    def __init__(self, limits: DriveLimits, *, start_mm=(0.0, 0.0, 0.0), servo: ServoModel | None = None,
                 sinks=()):
        self.limits = limits
        self.servo = servo
        self.sinks = list(sinks)
        self.position_blu = np.rint(np.asarray(start_mm, dtype=float) / limits.blu_mm).astype(np.int64)
        self.stats = DriveStats(max_contour_error_mm=0.0 if servo else None)
        self.line = 0
        self.feed_mm_s = 0.0
        self._h = limits.stencil_periods()
        self._tail = self.position_blu[None, :].copy()  # last 3h+? positions, for the stencils
        self._tail_mm = self._tail * limits.blu_mm  # last two commanded points, for the chord error
        self._lo = np.ceil(limits.min_mm / limits.blu_mm - 1e-9).astype(np.int64)
        self._hi = np.floor(limits.max_mm / limits.blu_mm + 1e-9).astype(np.int64)

    @property
    def position_mm(self) -> np.ndarray:
        return self.position_blu * self.limits.blu_mm

    @property
    def t_s(self) -> float:
        return self.stats.periods * self.limits.period_s

    def receive(self, batch: PeriodBatch) -> None:
        """Follow one batch; raise TravelLimitError (after following the periods before it)."""
        n = len(batch)
        if n == 0:
            return
        inc = np.asarray(batch.inc_blu, dtype=np.int64)
        pos = self.position_blu + np.cumsum(inc, axis=0)
        bad = np.nonzero(((pos < self._lo) | (pos > self._hi)).any(axis=1))[0]
        if len(bad):
            k = int(bad[0])
            if k:
                self.receive(PeriodBatch(batch.pos_mm[:k], inc[:k], batch.feed_mm_s[:k],
                                         batch.limit[:k], batch.line[:k]))
            axis = int(np.nonzero((pos[k] < self._lo) | (pos[k] > self._hi))[0][0])
            limit = self.limits.min_mm[axis] if pos[k, axis] < self._lo[axis] else self.limits.max_mm[axis]
            raise TravelLimitError(axis, float(pos[k, axis] * self.limits.blu_mm), float(limit),
                                   int(batch.line[k]), self.t_s + self.limits.period_s)
        blu = self.limits.blu_mm
        cmd_mm = pos * blu
        if np.max(np.abs(cmd_mm - batch.pos_mm)) > 0.5 * blu + 1e-9:
            k = int(np.argmax(np.abs(cmd_mm - batch.pos_mm).max(axis=1)))
            raise CommandMismatchError(
                f"line {int(batch.line[k])}: batch pos_mm {batch.pos_mm[k]} is not the integrated "
                f"position {cmd_mm[k]} (BLU {blu} mm)")
        self._measure(inc, pos, cmd_mm)
        rows = {"t_s": self.t_s + self.limits.period_s * np.arange(1, n + 1), "pos_mm": cmd_mm,
                "inc_blu": inc, "feed_mm_s": batch.feed_mm_s, "limit": batch.limit, "line": batch.line}
        if self.servo is not None:
            actual, contour = self.servo.follow(cmd_mm)
            self.stats.max_contour_error_mm = max(self.stats.max_contour_error_mm, float(contour.max()))
            rows["actual_mm"] = actual
            rows["contour_um"] = contour * 1e3
        for sink in self.sinks:
            sink.write(rows)
        self.position_blu = pos[-1].copy()
        self.stats.periods += n
        self.line = int(batch.line[-1])
        self.feed_mm_s = float(batch.feed_mm_s[-1])

    def _measure(self, inc: np.ndarray, pos: np.ndarray, cmd_mm: np.ndarray) -> None:
        lim, st, h = self.limits, self.stats, self._h
        blu, T = lim.blu_mm, lim.period_s
        st.path_length_mm += float(np.linalg.norm(inc * blu, axis=1).sum())
        vel = np.abs(inc).max(axis=0) * blu / T
        st.max_velocity_mm_s = np.maximum(st.max_velocity_mm_s, vel)
        st.velocity_violations += int((np.abs(inc) * blu / T > lim.max_velocity_mm_s + blu / T + 1e-9)
                                      .any(axis=1).sum())
        ext = np.concatenate((self._tail, pos))
        hT = h * T
        old = len(self._tail)  # stencils lying wholly in the tail were measured with the last batch
        if len(ext) > 2 * h:
            acc = np.abs(ext[2 * h:] - 2 * ext[h:-h] + ext[:-2 * h])[max(0, old - 2 * h):] * blu / hT**2
            st.max_accel_mm_s2 = np.maximum(st.max_accel_mm_s2, acc.max(axis=0))
            tol = 2 * blu / hT**2  # rounding of three positions by <= 0.5 BLU each
            st.accel_violations += int((acc > lim.max_accel_mm_s2 + tol + 1e-9).any(axis=1).sum())
        if len(ext) > 3 * h:
            jerk = (np.abs(ext[3 * h:] - 3 * ext[2 * h:-h] + 3 * ext[h:-2 * h] - ext[:-3 * h])
                    [max(0, old - 3 * h):] * blu / hT**3)
            st.max_jerk_mm_s3 = np.maximum(st.max_jerk_mm_s3, jerk.max(axis=0))
            if lim.check_jerk:
                tol = 4 * blu / hT**3
                st.jerk_violations += int((jerk > lim.max_jerk_mm_s3 + tol + 1e-9).any(axis=1).sum())
        self._tail = ext[-3 * h:].copy()
        pts = np.concatenate((self._tail_mm, cmd_mm))
        if len(pts) >= 3:
            st.max_chord_error_mm = max(st.max_chord_error_mm, float(chord_errors_mm(pts).max(initial=0.0)))
        self._tail_mm = pts[-2:].copy()
