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
  BLU rounding alone shows up as at most about BLU/3). Chords shorter than
  MIN_CHORD_BLU are not measured: there the rounding decides the direction of the
  chord and the estimate says nothing (at 1 µm, 1 ms that is below 8 mm/s);
- with a servo model, the actual positions and the contour error.
A travel-limit violation stops the drive at the last period inside the limits.
The rows handed to the sinks also carry spindle_rad, the spindle angle at the end of each
period (from the M3/M4 speed the controller passes on), for receivers that model the teeth.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ipo.contracts import PeriodBatch
from machine.servo import ServoModel

AXES = "XYZ"
MIN_CHORD_BLU = 8


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
    jerk_limited: bool = False  # only an S-curve stage holds the jerk; it is counted in every mode

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
            jerk_limited=getattr(config, "accel_mode", "trapezoid") == "scurve",
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


@njit(cache=True)
def _sagitta(p, i, la, lb):
    """Sagitta of the chord p[i]→p[i+1] on the circle through p[i], p[i+1], p[i+2] (0 if collinear);
    la and lb are the lengths of p[i]→p[i+1] and p[i+1]→p[i+2] (_chord)."""
    ax, ay, az = p[i + 1, 0] - p[i, 0], p[i + 1, 1] - p[i, 1], p[i + 1, 2] - p[i, 2]
    bx, by, bz = p[i + 2, 0] - p[i + 1, 0], p[i + 2, 1] - p[i + 1, 1], p[i + 2, 2] - p[i + 1, 2]
    cx, cy, cz = ax + bx, ay + by, az + bz
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    ux, uy, uz = ay * cz - az * cy, az * cx - ax * cz, ax * cy - ay * cx
    area2 = math.sqrt(ux * ux + uy * uy + uz * uz)  # twice the triangle's area
    if area2 == 0.0 or la == 0.0 or lb == 0.0:
        return 0.0
    rho = la * lb * lc / (2.0 * area2)  # circumradius
    return rho - math.sqrt(max(rho * rho - 0.25 * la * la, 0.0))


@njit(cache=True)
def _chord(p, r):
    """Length of p[r]→p[r+1]."""
    dx, dy, dz = p[r + 1, 0] - p[r, 0], p[r + 1, 1] - p[r, 1], p[r + 1, 2] - p[r, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def _measure(ext, old, h, blu, period_s, vlim, alim, jlim, peak, counts):
    """One pass over the positions ext (BLU; the first `old` rows measured before).

    peak: [path length, velocity x3, acceleration x3, jerk x3, chord error] (updated);
    counts: velocity, acceleration, jerk violations (updated).
    """
    m = ext.shape[0]
    ht = h * period_s
    v_tol, a_tol, j_tol = blu / period_s, 2.0 * blu / ht**2, 4.0 * blu / ht**3  # rounding: 0.5 BLU a position
    p = np.empty((3, 3))
    first = max(old, 2)
    chord_out = 0.0
    for i in range(max(old, 1), m):
        d2 = 0.0
        bad_v = bad_a = bad_j = False
        for a in range(3):
            d = ext[i, a] - ext[i - 1, a]
            d2 += float(d * d)
            v = abs(d) * blu / period_s
            peak[1 + a] = max(peak[1 + a], v)
            bad_v |= v > vlim[a] + v_tol + 1e-9
            if i >= 2 * h:
                acc = abs(ext[i, a] - 2 * ext[i - h, a] + ext[i - 2 * h, a]) * blu / ht**2
                peak[4 + a] = max(peak[4 + a], acc)
                bad_a |= acc > alim[a] + a_tol + 1e-9
            if i >= 3 * h:
                jerk = abs(ext[i, a] - 3 * ext[i - h, a] + 3 * ext[i - 2 * h, a] - ext[i - 3 * h, a]) * blu / ht**3
                peak[7 + a] = max(peak[7 + a], jerk)
                bad_j |= jerk > jlim[a] + j_tol + 1e-9
        peak[0] += math.sqrt(d2) * blu
        counts[0] += bad_v
        counts[1] += bad_a
        counts[2] += bad_j
        if i >= 2:
            for r in range(3):
                for a in range(3):
                    p[r, a] = ext[i - 2 + r, a] * blu
            # the chord in is the last period's chord out (the same points, the same arithmetic)
            chord_in = chord_out if i > first else _chord(p, 0)
            chord_out = _chord(p, 1)
            if min(chord_in, chord_out) >= MIN_CHORD_BLU * blu:
                peak[10] = max(peak[10], _sagitta(p, 0, chord_in, chord_out))


@njit(cache=True)
def _follow(start, inc, lo, hi, blu, pos_mm):
    """Positions (BLU) and commanded positions (mm) after each increment; the first period
    outside [lo, hi] on some axis (or -1), and the first whose pos_mm is more than half a
    BLU off the integrated position (the largest such difference's period, or -1)."""
    n = inc.shape[0]
    pos = np.empty((n, 3), np.int64)
    cmd = np.empty((n, 3))
    acc = start.copy()
    worst, off = 0.5 * blu + 1e-9, -1
    for k in range(n):
        for a in range(3):
            acc[a] += inc[k, a]
            pos[k, a] = acc[a]
        for a in range(3):
            if acc[a] < lo[a] or acc[a] > hi[a]:
                return pos, cmd, k, -1
        for a in range(3):
            cmd[k, a] = pos[k, a] * blu
            d = abs(cmd[k, a] - pos_mm[k, a])
            if d > worst:
                worst, off = d, k
    return pos, cmd, -1, off


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
        self.spindle_rad_s = 0.0  # signed: M3 (cw) positive; set by the controller as the program's M3/M4/M5 pass
        self.spindle_rad = 0.0  # spindle angle at the end of the last period, in [0, 2 pi)
        self._h = limits.stencil_periods()
        self._tail = self.position_blu[None, :].copy()  # the last positions the stencils reach back to
        self._peak = np.zeros(11)
        self._counts = np.zeros(3, np.int64)
        self._lo = np.ceil(limits.min_mm / limits.blu_mm - 1e-9).astype(np.int64)
        self._hi = np.floor(limits.max_mm / limits.blu_mm + 1e-9).astype(np.int64)

    def warm_up(self) -> None:
        """Load the compiled kernels now (numba loads them on first call, which takes a second)."""
        lim = self.limits
        _measure(np.zeros((4, 3), np.int64), 4, 1, lim.blu_mm, lim.period_s, lim.max_velocity_mm_s,
                 lim.max_accel_mm_s2, lim.max_jerk_mm_s3, np.zeros(11), np.zeros(3, np.int64))
        if self.servo is not None:
            ServoModel(1.0, 0.0, lim.period_s, (0, 0, 0)).follow(np.zeros((2, 3)))

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
        blu = self.limits.blu_mm
        pos, cmd_mm, k, off = _follow(self.position_blu, inc, self._lo, self._hi, blu,
                                      np.asarray(batch.pos_mm, dtype=np.float64))
        if k >= 0:
            if k:
                self.receive(PeriodBatch(batch.pos_mm[:k], inc[:k], batch.feed_mm_s[:k],
                                         batch.limit[:k], batch.line[:k]))
            axis = int(np.nonzero((pos[k] < self._lo) | (pos[k] > self._hi))[0][0])
            limit = self.limits.min_mm[axis] if pos[k, axis] < self._lo[axis] else self.limits.max_mm[axis]
            raise TravelLimitError(axis, float(pos[k, axis] * self.limits.blu_mm), float(limit),
                                   int(batch.line[k]), self.t_s + self.limits.period_s)
        if off >= 0:
            k = off
            raise CommandMismatchError(
                f"line {int(batch.line[k])}: batch pos_mm {batch.pos_mm[k]} is not the integrated "
                f"position {cmd_mm[k]} (BLU {blu} mm)")
        self._measure(pos)
        turn = self.spindle_rad_s * self.limits.period_s  # spindle angle per period
        if self.servo is not None or self.sinks:
            steps = np.arange(1, n + 1)
            rows = {"t_s": self.t_s + self.limits.period_s * steps, "pos_mm": cmd_mm,
                    "inc_blu": inc, "feed_mm_s": batch.feed_mm_s, "limit": batch.limit, "line": batch.line,
                    "spindle_rad": self.spindle_rad + turn * steps}
            if self.servo is not None:
                actual, contour = self.servo.follow(cmd_mm)
                self.stats.max_contour_error_mm = max(self.stats.max_contour_error_mm, float(contour.max()))
                rows["actual_mm"] = actual
                rows["contour_um"] = contour * 1e3
            for sink in self.sinks:
                sink.write(rows)
        self.position_blu = pos[-1].copy()
        self.spindle_rad = float((self.spindle_rad + turn * n) % (2.0 * math.pi))
        self.stats.periods += n
        self.line = int(batch.line[-1])
        self.feed_mm_s = float(batch.feed_mm_s[-1])

    def _measure(self, pos: np.ndarray) -> None:
        lim, h = self.limits, self._h
        ext = np.concatenate((self._tail, pos))
        _measure(ext, len(self._tail), h, lim.blu_mm, lim.period_s, lim.max_velocity_mm_s, lim.max_accel_mm_s2,
                 lim.max_jerk_mm_s3, self._peak, self._counts)
        self._tail = ext[-max(3 * h, 2):].copy()
        st = self.stats
        st.path_length_mm = float(self._peak[0])
        st.max_velocity_mm_s, st.max_accel_mm_s2 = self._peak[1:4].copy(), self._peak[4:7].copy()
        st.max_jerk_mm_s3, st.max_chord_error_mm = self._peak[7:10].copy(), float(self._peak[10])
        st.velocity_violations, st.accel_violations, st.jerk_violations = (int(c) for c in self._counts)
