"""Line and arc stepping throughput: periods per second of LineStepper / ArcStepper against a
plain vectorised numpy reference computed in the same run.

    python bench/stepping.py [--repeats N]

Period 1 ms at 50 mm/s: a 0.05 mm step. Chunks of 4096 periods (the feed stage's batch).
- long line: one 12.5 m Line, 250,000 periods;
- long helix: R = 10 mm, 199 full turns + a half, 2 mm rise per turn, ~250,000 periods;
- short blocks: 20,000 Lines of 0.5 mm (10 periods each), and 20,000 Arcs of 0.5 rad on
  R = 1 mm, a stepper built per block, as a CAM program of short G1/G2 moves drives it.
The numpy references compute the same points without the stepper contract (no end check,
lead or carry): the line as start + unit * cumsum(steps), the helix with the closed-form
angle per chord 2*asin(d / 2R) corrected for the pitch by one fixed-point pass. Rates are per
CPU second of this process (the machine is shared); wall-clock next to them. Best of N.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from ipo.interp.line_arc import ArcStepper, LineStepper
from ipr.entities import Arc, Line

STEP_MM = 50.0 * 1e-3  # 50 mm/s at a 1 ms period
CHUNK = 4096


def timed(fn, repeats: int) -> tuple[float, float, int]:
    """Best CPU and wall seconds over repeats, and the periods fn produced."""
    best_cpu = best_wall = np.inf
    n = 0
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        n = fn()
        best_cpu = min(best_cpu, time.process_time() - c0)
        best_wall = min(best_wall, time.perf_counter() - w0)
    return best_cpu, best_wall, n


def run_stepper(stepper) -> int:
    steps = np.full(CHUNK, STEP_MM)
    n = 0
    while not stepper.done:
        n += len(stepper.advance(steps).u)
    return n


LINE = Line(1, (0.0, 0.0, 0.0), (10000.0, 7500.0, 0.0), 50.0)
HELIX = Arc(1, (10.0, 0.0, 0.0), (-10.0, 0.0, 399.0), (0.0, 0.0, 0.0), "XY", True, 50.0, turns=199)


def numpy_line() -> int:
    start, end = np.array(LINE.start), np.array(LINE.end)
    length = np.linalg.norm(end - start)
    unit = (end - start) / length
    n_total = int(np.ceil(length / STEP_MM))
    s = 0.0
    for i in range(0, n_total, CHUNK):
        cum = s + np.cumsum(np.full(min(CHUNK, n_total - i), STEP_MM))
        pos = start + unit * cum[:, None]
        s = cum[-1]
    assert pos.shape[1] == 3
    return n_total


def numpy_helix() -> int:
    r = HELIX.radius_mm
    total = abs(HELIX.sweep_rad)
    k = (HELIX.end[2] - HELIX.start[2]) / total
    phi = 2 * np.arcsin(STEP_MM / (2 * r))
    phi = 2 * np.arcsin(np.sqrt(max(STEP_MM**2 - (k * phi) ** 2, 0.0)) / (2 * r))  # pitch pass
    n_total = int(np.ceil(total / phi))
    th0 = 0.0
    for i in range(0, n_total, CHUNK):
        th = th0 + np.cumsum(np.full(min(CHUNK, n_total - i), phi))
        pos = np.column_stack([r * np.cos(th), r * np.sin(th), k * th])
        th0 = th[-1]
    assert pos.shape[1] == 3
    return n_total


SHORT_LINES = [Line(i, (0.5 * i, 0.0, 0.0), (0.5 * i + 0.5, 0.0, 0.0), 50.0) for i in range(20000)]
SHORT_ARCS = [Arc(i, (1.0, 0.0, 0.0), (np.cos(0.5), np.sin(0.5), 0.0), (0.0, 0.0, 0.0), "XY", True, 50.0)
              for i in range(20000)]


def short_blocks(entities, stepper_cls) -> int:
    """One stepper per block, chained by lead = step - carry as the feed stage does."""
    steps = np.full(16, STEP_MM)
    n = 0
    lead = 0.0
    for e in entities:
        r = stepper_cls(e, lead_mm=lead).advance(steps)
        n += len(r.u)
        lead = STEP_MM - r.carry_mm
    return n


def numpy_short_lines() -> int:
    n = 0
    for line in SHORT_LINES:
        start, end = np.array(line.start), np.array(line.end)
        length = np.linalg.norm(end - start)
        cum = np.cumsum(np.full(int(np.ceil(length / STEP_MM)), STEP_MM))
        pos = start + (end - start) / length * np.minimum(cum, length)[:, None]
        n += len(pos)
    return n


def numpy_short_arcs() -> int:
    n = 0
    for arc in SHORT_ARCS:
        r = arc.radius_mm
        phi = 2 * np.arcsin(STEP_MM / (2 * r))
        th = np.minimum(np.cumsum(np.full(int(np.ceil(abs(arc.sweep_rad) / phi)), phi)), arc.sweep_rad)
        pos = np.column_stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)])
        n += len(pos)
    return n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    run_stepper(LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 1.0)))  # numba compile / cache load
    run_stepper(ArcStepper(Arc(1, (1, 0, 0), (0, 1, 0), (0, 0, 0), "XY", True, 1.0)))
    cases = [
        ("long line", lambda: run_stepper(LineStepper(LINE)), numpy_line),
        ("long helix", lambda: run_stepper(ArcStepper(HELIX)), numpy_helix),
        ("short lines (0.5 mm)", lambda: short_blocks(SHORT_LINES, LineStepper), numpy_short_lines),
        ("short arcs (0.5 mm)", lambda: short_blocks(SHORT_ARCS, ArcStepper), numpy_short_arcs),
    ]
    print(f"step {STEP_MM} mm (50 mm/s, 1 ms), chunks of {CHUNK}, best of {args.repeats}")
    print(f"{'case':22s} {'periods':>8s} {'vcnc Mper/s cpu (wall)':>24s} "
          f"{'numpy Mper/s cpu (wall)':>25s} {'vcnc/numpy':>10s}")
    for name, ours, ref in cases:
        c, w, n = timed(ours, args.repeats)
        rc, rw, rn = timed(ref, args.repeats)
        print(f"{name:22s} {n:8d} {n / c / 1e6:12.2f} ({n / w / 1e6:6.2f})     "
              f"{rn / rc / 1e6:12.2f} ({rn / rw / 1e6:6.2f})   {(n / c) / (rn / rc):8.2f}")


if __name__ == "__main__":
    main()
