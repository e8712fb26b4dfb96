"""The LinuxCNC rows of bench/twins.py: the LinuxCNC 2.9 twin's cycle time against LinuxCNC's.

For every program of tests/data/linuxcnc_twin/measured.csv (LinuxCNC 2.9.0~pre1's own
simulator, headless, on the machine of tests/data/linuxcnc_twin/ini/<machine>.ini; README.md
there says how), the measured cycle time, the twin's prediction with the settings read from
that INI file (ipo.linuxcnc_ini), its error, and the naive estimate a CAM system or
a sender prints: each move's length at its programmed feed (rapids at the rapid speed
LinuxCNC would reach, [TRAJ]MAX_LINEAR_VELOCITY or the axis limits), dwells added, no
acceleration. Programs from ../shared are skipped, saying so, where it is absent.

Usage: python bench/twins_linuxcnc.py   (bench/twins.py prints these rows with the others)
"""
from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT)]
sys.path.append(str(ROOT / "tests"))  # after the repository: tests/ipo and tests/machine are folders of tests

from linuxcnc_measured import measured, percent_error, twin_run  # noqa: E402
from ipo.linuxcnc_ini import load_ini  # noqa: E402
from ipr.entities import Dwell, Rapid  # noqa: E402
from machine.program_summary import path_length_mm  # noqa: E402


def naive_estimate_s(path: Path, ini: Path) -> float:
    """Length / feed per move, rapids at the straight-line rapid speed, plus dwells."""
    import ipr

    s = load_ini(ini)
    total = 0.0
    for e in ipr.parse_file(str(path)).entities:
        if isinstance(e, Dwell):
            total += e.seconds
        elif isinstance(e, Rapid):
            d = [abs(a - b) for a, b in zip(e.end, e.start)]
            if any(d):
                axis_t = max(d[i] / s.axis_velocity_mm_s[i] for i in range(3))
                total += max(math.dist(e.start, e.end) / s.max_linear_velocity_mm_s, axis_t)
        elif hasattr(e, "feed_mm_s"):
            total += path_length_mm(e) / e.feed_mm_s
    return total


def rows() -> list[dict]:
    out = []
    for m in measured():
        if not m.path.exists():
            print(f"  skipped {m.id}: {m.path} not found (../shared is absent)")
            continue
        t0 = time.perf_counter()
        run = twin_run(m.path, m.ini)
        wall = time.perf_counter() - t0
        naive = naive_estimate_s(m.path, m.ini)
        group = "waits" if m.waits_dominate else ""
        out.append({"machine": m.machine, "program": m.program, "group": group, "measured_s": m.cycle_time_s,
                    "twin_s": run.cycle_time_s, "twin_err": percent_error(run.cycle_time_s, m.cycle_time_s),
                    "naive_s": naive, "naive_err": percent_error(naive, m.cycle_time_s), "wall_s": wall})
    return out


def _print(r: dict) -> None:
    print(f"{r['machine']:9s} {r['program']:34s} {r['measured_s']:10.3f} {r['twin_s']:9.3f} {r['twin_err']:+7.2f} "
          f"{r['naive_s']:9.3f} {r['naive_err']:+7.1f} {r['wall_s']:7.2f}")


def print_rows(rows_: list[dict]) -> None:
    print("LinuxCNC 2.9 twin against LinuxCNC 2.9.0~pre1's simulator (tests/data/linuxcnc_twin)")
    print(f"{'machine':9s} {'program':34s} {'measured_s':>10s} {'twin_s':>9s} {'err_%':>7s} "
          f"{'naive_s':>9s} {'err_%':>7s} {'wall_s':>7s}")
    table = [r for r in rows_ if not r["group"]]
    for r in table:
        _print(r)
    apart = {"waits": "programs written to measure task's waits (they stand mostly at coolant, tool and spindle\n"
                      "blocks: LinuxCNC's wall-clock timing, which varies from run to run)"}
    for group, why in apart.items():
        rows_apart = [r for r in rows_ if r["group"] == group]
        if rows_apart:
            print(f"not in the figures below, {why}:")
            for r in rows_apart:
                _print(r)
    if not table:
        return
    for key, name in (("twin_err", "twin"), ("naive_err", "naive")):
        errs = [abs(r[key]) for r in table]
        worst = max(table, key=lambda r: abs(r[key]))
        print(f"{name}: median |error| {statistics.median(errs):.2f} %, worst {max(errs):.2f} % "
              f"({worst['machine']}/{worst['program']}) over {len(table)} programs")


if __name__ == "__main__":
    print_rows(rows())
