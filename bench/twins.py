"""Controller twins against the controllers themselves: per program, the job time measured on the
controller's own firmware or simulator, the twin's prediction and its error, and the same for a
naive estimate (each move's length over its feed, G0 at the axes' max rate, plus dwells).

grbl rows: tests/data/grbl_sim/measured.json (grbl 1.1h in grbl-sim; its provenance is in the
file): the twin is fed the exact lines `vcnc stream --dry-run` sends, over the wire the
measurement used (grbl-sim's own byte period, or the baud rate of the case). Corpus programs
(`corpus/...`) are read from ../shared and left out where it is absent.

Bar (issue 18): median error <= 1 %, worst <= 3 %.

    .venv/bin/python bench/twins.py
"""
from __future__ import annotations

import json
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ipo.config import default_config  # noqa: E402
from ipo.feed.grbl_twin.twin import motion_span  # noqa: E402
from ipo.grbl_settings import read_dump  # noqa: E402
from ipr import parse_file  # noqa: E402
from ipr.entities import PLANE_AXES, Arc, Dwell, Line, Nurbs, Rapid  # noqa: E402
from machine.grbl.program import stream_groups  # noqa: E402
from machine.grbl.wire import wire_lines  # noqa: E402

GRBL_DATA = ROOT / "tests" / "data" / "grbl_sim"
SHARED = ROOT.parent / "shared"
SIM_BYTE_S = 66 / 16e6  # grbl-sim's byte period at 115200 (2*UBRR0+1 ticks, doubled by U2X0)
SIM_CLIENT_S = 1e-4  # the measuring client's answer-to-next-line latency at -t 0.1
MEDIAN_BAR_PCT, WORST_BAR_PCT = 1.0, 3.0


def program_path(name: str) -> Path | None:
    if name.startswith("corpus/"):
        path = SHARED / name
        return path if path.exists() else None
    return GRBL_DATA / name


def naive_s(entities, settings) -> float:
    """Length over feed per move; a G0 at the axes' max rates along its direction; dwells."""
    rate = [r / 60.0 for r in settings.max_rate_mm_min]
    total = 0.0
    for e in entities:
        if isinstance(e, Rapid):
            d = [abs(b - a) for a, b in zip(e.start, e.end)]
            length = math.sqrt(sum(x * x for x in d))
            if length:
                total += max(x / r for x, r in zip(d, rate))
        elif isinstance(e, Line):
            total += math.dist(e.start, e.end) / e.feed_mm_s
        elif isinstance(e, Arc):
            a, b, n = PLANE_AXES[e.plane]
            total += math.hypot(e.radius_mm * e.sweep_rad, e.end[n] - e.start[n]) / e.feed_mm_s
        elif isinstance(e, Nurbs):
            from ipo.nurbs.kernel import arc_length

            total += arc_length(e.degree, e.knots, e.weights, e.points) / e.feed_mm_s
        elif isinstance(e, Dwell):
            total += e.seconds
    return total


def grbl_rows():
    data = json.loads((GRBL_DATA / "measured.json").read_text())
    for case in data["cases"]:
        path = program_path(case["program"])
        if path is None:
            print(f"  ({case['program']}: ../shared absent, left out)")
            continue
        settings = read_dump(GRBL_DATA / case["settings"])
        program = parse_file(path)
        lines = wire_lines(stream_groups(program.entities, default_config()))
        wire = case["wire_baud"] or 10.0 / SIM_BYTE_S
        t0 = time.perf_counter()
        first, end = motion_span(lines, settings, baud=wire, reply_latency_s=SIM_CLIENT_S)
        wall = time.perf_counter() - t0
        label = f"{Path(case['program']).name} {Path(case['settings']).stem}"
        label += f" {case['wire_baud']:.0f} baud" if case["wire_baud"] else " sim wire"
        yield "grbl 1.1h", label, case["motion_s"], end - first, naive_s(program.entities, settings), wall


def main() -> None:
    rows = list(grbl_rows())
    print(f"{'controller':10s} {'program':44s} {'measured':>9s} {'twin':>9s} {'error':>8s} {'naive':>9s} "
          f"{'error':>8s} {'twin wall':>9s}")
    errs, naive_errs = [], []
    for ctl, label, meas, twin, naive, wall in rows:
        e, n = (twin / meas - 1) * 100, (naive / meas - 1) * 100
        errs.append(abs(e))
        naive_errs.append(abs(n))
        print(f"{ctl:10s} {label:44s} {meas:8.3f}s {twin:8.3f}s {e:+7.2f}% {naive:8.3f}s {n:+7.2f}% {wall:8.2f}s")
    if errs:
        med, worst = statistics.median(errs), max(errs)
        print(f"grbl twin: median |error| {med:.2f} %, worst {worst:.2f} % over {len(errs)} programs "
              f"(bar: median <= {MEDIAN_BAR_PCT:g} %, worst <= {WORST_BAR_PCT:g} %: "
              f"{'met' if med <= MEDIAN_BAR_PCT and worst <= WORST_BAR_PCT else 'NOT met'})")
        print(f"naive (length / feed): median |error| {statistics.median(naive_errs):.2f} %, "
              f"worst {max(naive_errs):.2f} %")


if __name__ == "__main__":
    main()
