"""Can grbl keep up with a stream? Two limits a hobby board puts on short segments.

- Serial bandwidth: at the planned feed, a run of short lines may need more bytes per
  second than the port carries (8N1: baud / 10 bytes/s); grbl then starves and stops.
- Look-ahead: grbl plans over its planner blocks only, so it must be able to stop
  within the blocks it holds: v <= sqrt(2 a L), L the length of `planner_blocks`
  consecutive moves (a the smallest axis acceleration); faster feeds are cut to that.

Both are checked over every run of `planner_blocks` consecutive feed moves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ipr.entities import PLANE_AXES
from machine.grbl.program import StreamLine


@dataclass(frozen=True, slots=True)
class Demand:
    peak_bytes_s: float  # the most bytes per second any run of lines needs at its planned feed
    peak_seq: int  # the first line of that run
    capacity_bytes_s: float
    slowest_ratio: float  # min over runs of (speed grbl's look-ahead allows) / (planned speed), capped at 1
    slowest_seq: int
    warnings: list[str]


def _length_mm(line: StreamLine) -> float:
    s, e = np.asarray(line.start_mm), np.asarray(line.end_mm)
    if line.arc is None:
        return float(np.linalg.norm(e - s))
    center, plane, ccw, _ = line.arc
    a, b, n = PLANE_AXES[plane]
    r = math.hypot(s[a] - center[a], s[b] - center[b])
    a0 = math.atan2(s[b] - center[b], s[a] - center[a])
    a1 = math.atan2(e[b] - center[b], e[a] - center[a])
    sweep = (a1 - a0) % (2 * math.pi) if ccw else (a0 - a1) % (2 * math.pi)
    sweep = sweep or 2 * math.pi
    return math.hypot(r * sweep, e[n] - s[n])


def _feed_mm_s(line: StreamLine) -> float | None:
    return None if line.feed_mm_min is None else line.feed_mm_min / 60.0


def stream_demand(lines: Sequence[StreamLine], *, baud: int, planner_blocks: int,
                  accel_mm_s2: float) -> Demand:
    """Bytes per second and look-ahead over every run of `planner_blocks` feed moves."""
    moves = [(l, _length_mm(l), f) for l in lines if l.motion and (f := _feed_mm_s(l))]
    capacity = baud / 10.0
    if len(moves) < planner_blocks:
        return Demand(0.0, 0, capacity, 1.0, 0, [])
    n_bytes = np.array([len(l.text) + 1 for l, _, _ in moves], float)
    length = np.array([d for _, d, _ in moves])
    feed = np.array([f for _, _, f in moves])
    k = planner_blocks
    csum = lambda v: np.concatenate(([0.0], np.cumsum(v)))  # noqa: E731
    run_bytes = csum(n_bytes)[k:] - csum(n_bytes)[:-k]
    run_time = csum(length / feed)[k:] - csum(length / feed)[:-k]
    run_len = csum(length)[k:] - csum(length)[:-k]
    rate = run_bytes / np.maximum(run_time, 1e-12)
    i = int(np.argmax(rate))
    v_ok = np.sqrt(2.0 * accel_mm_s2 * run_len)  # stop within the blocks grbl holds
    ratio = np.minimum(v_ok / np.maximum(feed[:len(v_ok)], 1e-12), 1.0)
    j = int(np.argmin(ratio))
    warnings = []
    first = moves[i][0]
    if rate[i] > 0.8 * capacity:
        warnings.append(f"from stream line {first.seq} (program line {first.source_line}) the stream needs "
                        f"{rate[i]:.0f} bytes/s at the planned feed; {baud} baud carries {capacity:.0f}: grbl "
                        f"will run dry and pause there")
    if ratio[j] < 1.0:
        slow = moves[j][0]
        warnings.append(f"from stream line {slow.seq} (program line {slow.source_line}) grbl's "
                        f"{planner_blocks}-block look-ahead spans {run_len[j]:.3f} mm: it cannot run faster than "
                        f"{v_ok[j] * 60:.0f} mm/min there (planned {feed[j] * 60:.0f})")
    return Demand(float(rate[i]), first.seq, capacity, float(ratio[j]), moves[j][0].seq, warnings)
