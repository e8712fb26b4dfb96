"""Constant-chord study of the interpolators: every motion entity stepped at the same chord D
(no feed planning), with the chord statistics that 000 §3 reports (Fig. 7-9).

Each entity starts from its own start point with no lead, so that every chord lies on one
entity; its final period is the clamped partial step to the end point, which is kept in the
path but left out of the chord statistics.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from math import sqrt

import numpy as np
from numba import njit

from ipo.errors import STUDY, IpoError
from ipo.interp.steppers import make_stepper
from ipr.entities import MOTION_TYPES, Arc, Nurbs

CHUNK = 1 << 16  # most periods per advance call


def _length_bound_mm(e) -> float:
    """An upper bound on the path length: sizes the first chunk so one call usually suffices."""
    if isinstance(e, Nurbs):
        return float(np.linalg.norm(np.diff(e.points, axis=0), axis=1).sum())
    chord = float(np.linalg.norm(np.subtract(e.end, e.start)))
    if isinstance(e, Arc):
        return abs(e.sweep_rad) * (e.radius_mm + chord) + chord
    return chord


@dataclass(slots=True)
class ChordStudy:
    pos_mm: np.ndarray  # (N, 3) the path: the first start point, then every period's point
    u: np.ndarray  # (N,) parameter of each point (arc length in mm on lines and arcs)
    chord_dev: np.ndarray  # chord / D - 1 of every step but each entity's final clamped one
    nurbs_evals: np.ndarray  # curve evaluations of every period spent on a NURBS
    startup_evals: np.ndarray  # start-up evaluations of each NURBS entity
    steps: int  # periods in total
    seconds: float  # wall time of the stepping alone
    stalls: int  # periods before an entity's end whose parameter did not move forward

    @property
    def max_dev_pct(self) -> float:
        return float(np.abs(self.chord_dev).max() * 100) if self.chord_dev.size else 0.0

    @property
    def rms_dev_pct(self) -> float:
        return float(np.sqrt(np.mean(self.chord_dev**2)) * 100) if self.chord_dev.size else 0.0

    def summary(self) -> dict:
        ev = self.nurbs_evals
        return {
            "steps": self.steps,
            "max_dev_pct": self.max_dev_pct,
            "rms_dev_pct": self.rms_dev_pct,
            "evals_mean": float(ev.mean()) if ev.size else 0.0,
            "evals_max": int(ev.max()) if ev.size else 0,
            "startup_evals": int(self.startup_evals.max()) if self.startup_evals.size else 0,
            "steps_per_s": self.steps / self.seconds if self.seconds > 0 else float("inf"),
        }


def _grown(arrays: tuple, rows: int) -> tuple:
    return tuple(np.concatenate([a, np.empty((rows - len(a),) + a.shape[1:], a.dtype)]) for a in arrays)


def _step_all(motions: list, step_mm: float, options: dict) -> tuple:
    """Every entity stepped into one path, written in place (no chunk is copied): the first
    start point, then every period. Room is reserved for every entity's length bound (np.empty
    only reserves it) and doubled should a curve take more periods than that.
    Returns (pos, u, evals, ranges, seconds): ranges holds each entity with its rows [a, b) and
    start-up evaluations; seconds is the wall time of the stepping."""
    rows = 1 + sum(int(_length_bound_mm(e) / step_mm) + 2 for e in motions)
    out = (np.empty((rows, 3)), np.empty(rows), np.empty(rows, dtype=np.int64))
    out[0][0] = motions[0].start
    out[1][0] = 0.0 if not isinstance(motions[0], Nurbs) else float(motions[0].knots[0])
    steps = np.full(CHUNK, step_mm)
    ranges = []
    k = 1
    t0 = time.perf_counter()
    for e in motions:
        stepper = make_stepper(e, **options)
        a = k
        while not stepper.done:
            if k == len(out[1]):
                out = _grown(out, 2 * k)
            n = min(CHUNK, len(out[1]) - k)
            k += len(stepper.advance(steps[:n], out=tuple(x[k:k + n] for x in out)).u)
        ranges.append((e, a, k, stepper.startup_evals))
    seconds = time.perf_counter() - t0
    return *(x[:k] for x in out), ranges, seconds


@njit(cache=True)
def _entity_chords(start, u0, pos, u, step_mm, dev):
    """dev[i] = chord / D - 1 of the entity's periods i < len(dev), the first chord from its
    start point; returns the periods among them whose parameter did not move forward (from u0)."""
    px, py, pz, pu = start[0], start[1], start[2], u0
    stalls = 0
    for i in range(dev.shape[0]):
        dx, dy, dz = pos[i, 0] - px, pos[i, 1] - py, pos[i, 2] - pz
        dev[i] = sqrt(dx * dx + dy * dy + dz * dz) / step_mm - 1.0
        stalls += u[i] <= pu
        px, py, pz, pu = pos[i, 0], pos[i, 1], pos[i, 2], u[i]
    return stalls


def _chord_dev(pos: np.ndarray, u: np.ndarray, ranges: list, step_mm: float) -> tuple[np.ndarray, int]:
    """chord / D - 1 of every period but each entity's final clamped one, each entity's chords
    measured from its own start point; and the periods whose parameter did not move forward."""
    dev = np.empty(sum(max(b - a - 1, 0) for _, a, b, _ in ranges))
    i = stalls = 0
    for e, a, b, _ in ranges:
        n = max(b - a - 1, 0)
        u0 = float(e.knots[0]) if isinstance(e, Nurbs) else 0.0
        stalls += _entity_chords(np.asarray(e.start, dtype=float), u0, pos[a:b], u[a:b], step_mm, dev[i:i + n])
        i += n
    return dev, int(stalls)


def study(entities, step_mm: float, **options) -> ChordStudy:
    """Step every motion entity at chord step_mm; options go to make_stepper."""
    if not (np.isfinite(step_mm) and step_mm > 0):
        raise IpoError(STUDY, f"step must be > 0, got {step_mm}")
    motions = [e for e in entities if isinstance(e, MOTION_TYPES)]
    if not motions:
        raise IpoError(STUDY, "no motion to interpolate")
    for kind in {type(e) for e in motions}:  # load the compiled kernels outside the timed loop
        make_stepper(next(e for e in motions if type(e) is kind), **options).advance(np.full(2, step_mm))
    pos, u, evals, ranges, seconds = _step_all(motions, step_mm, options)
    dev, stalls = _chord_dev(pos, u, ranges, step_mm)
    nurbs = [(evals[a:b], s_evals) for e, a, b, s_evals in ranges if isinstance(e, Nurbs)]
    nurbs_evals = (nurbs[0][0] if len(nurbs) == 1 else np.concatenate([ev for ev, _ in nurbs]) if nurbs
                   else np.zeros(0, dtype=np.int64))
    return ChordStudy(pos, u, dev, nurbs_evals, np.array([s for _, s in nurbs], dtype=np.int64), len(u) - 1,
                      seconds, stalls)


def pulse_study(entities, blu_mm: float, path_mm: np.ndarray) -> float:
    """Largest distance (BLU) of the reference-pulse path (000 §2.4) driven by the points
    path_mm from the exact geometry, sampled at blu/8 with a 0.01 % chord tolerance."""
    from ipo.interp.reference_pulse import pulse_deviation_blu, pulse_path, pulses  # --pulse only: its kernels

    start_blu = np.rint(path_mm[0] / blu_mm).astype(np.int64)
    path = pulse_path(start_blu, pulses(path_mm[1:], blu_mm, start_blu))
    dense = study(entities, blu_mm / 8.0, method="recursive", chord_tol_pct=0.01).pos_mm
    return pulse_deviation_blu(path, dense, blu_mm)
