"""Controller twins against the controllers they model: per program, the job time measured on the
controller's own firmware or simulator, the twin's prediction and its error, and the same for a
naive estimate (each move's length over its feed, capped at the axes' max rates, G0 at them, plus
dwells: no acceleration), and the
wall time the twin took.

grbl rows: tests/data/grbl_sim/measured.json (grbl 1.1h in grbl-sim; its provenance is in the
file), read by tests/grbl_sim_cases.py: the twin is fed the exact lines `vcnc stream --dry-run`
sends, over the wire the measurement used (a baud rate, or grbl-sim's own byte period). Corpus
programs (`corpus/...`) are read from ../shared and left out where it is absent.

LinuxCNC 2.9 rows: bench/twins_linuxcnc.py (measurements in tests/data/linuxcnc_twin).

Bar (issue 18): median error <= 1 %, worst <= 3 %.

    .venv/bin/python bench/twins.py
"""
from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "bench")]

import twins_linuxcnc  # noqa: E402

from grbl_sim_cases import SIM_CLIENT_S, cases  # noqa: E402
from ipo.feed.grbl_twin.twin import motion_span  # noqa: E402
from ipr.entities import PLANE_AXES, Arc, Dwell, Line, Nurbs, Rapid  # noqa: E402

MEDIAN_BAR_PCT, WORST_BAR_PCT = 1.0, 3.0


def naive_s(entities, settings) -> float:
    """Each move's length over its feed (a G0 at the axes' max rates), the feed capped at the axes'
    max rates along the move, plus dwells: what an estimate without acceleration gives."""
    rate = [r / 60.0 for r in settings.max_rate_mm_min]

    def along(start, end, feed_mm_s):
        d = [abs(b - a) for a, b in zip(start, end)]
        length = math.sqrt(sum(x * x for x in d))
        cap = min((r * length / x for x, r in zip(d, rate) if x > 0), default=math.inf)
        return length / min(feed_mm_s, cap) if length else 0.0

    total = 0.0
    for e in entities:
        if isinstance(e, Rapid):
            total += along(e.start, e.end, math.inf)
        elif isinstance(e, Line):
            total += along(e.start, e.end, e.feed_mm_s)
        elif isinstance(e, Arc):
            a, b, n = PLANE_AXES[e.plane]
            length = math.hypot(e.radius_mm * e.sweep_rad, e.end[n] - e.start[n])
            total += length / min(e.feed_mm_s, min(rate[a], rate[b]))
        elif isinstance(e, Nurbs):
            from ipo.nurbs.kernel import arc_length

            total += arc_length(e.degree, e.knots, e.weights, e.points) / min(e.feed_mm_s, min(rate))
        elif isinstance(e, Dwell):
            total += e.seconds
    return total


def grbl_rows():
    for case in cases():
        if case.text is None:
            print(f"  ({case.label}: ../shared absent, left out)")
            continue
        t0 = time.perf_counter()
        first, last = motion_span(case.wire(), case.settings, baud=case.baud, answer_s=SIM_CLIENT_S)
        wall = time.perf_counter() - t0
        yield "grbl 1.1h", case.label, case.motion_s, last - first, naive_s(case.entities(), case.settings), wall


def main() -> None:
    twins_linuxcnc.print_rows(twins_linuxcnc.rows())
    print()
    print("grbl 1.1 twin against grbl 1.1h in grbl-sim (tests/data/grbl_sim)")
    rows = list(grbl_rows())
    print(f"{'controller':10s} {'program':44s} {'measured':>9s} {'twin':>9s} {'error':>8s} {'naive':>9s} "
          f"{'error':>8s} {'twin wall':>9s}")
    errs, naive_errs = [], []
    for ctl, label, meas, twin, naive, wall in rows:
        e, n = (twin / meas - 1) * 100, (naive / meas - 1) * 100
        errs.append(abs(e))
        naive_errs.append(abs(n))
        print(f"{ctl:10s} {label:44s} {meas:8.3f}s {twin:8.3f}s {e:+7.3f}% {naive:8.3f}s {n:+7.1f}% {wall:8.2f}s")
    if errs:
        med, worst = statistics.median(errs), max(errs)
        print(f"grbl twin: median |error| {med:.2f} %, worst {worst:.2f} % over {len(errs)} programs "
              f"(bar: median <= {MEDIAN_BAR_PCT:g} %, worst <= {WORST_BAR_PCT:g} %: "
              f"{'met' if med <= MEDIAN_BAR_PCT and worst <= WORST_BAR_PCT else 'NOT met'})")
        print(f"naive (length / feed): median |error| {statistics.median(naive_errs):.2f} %, "
              f"worst {max(naive_errs):.2f} %")


if __name__ == "__main__":
    main()
