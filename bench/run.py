"""Benchmark of `vcnc run`: whole processes, the memory bound, and where the time goes.

For each program: blocks, periods, simulated time, wall time of the whole `vcnc run`
process (interpreter start, imports, numba cache loads, parse, check, plan,
interpolate, drive), realtime_factor = simulated time / that wall time, and the
process's peak RSS (os.wait4). Machine: 100 mm/s and 1000 mm/s² per axis, 1 ms
period (the built-in default machine).

The machine is shared, so the CPU time of the process (user + system, from the same
wait4) is printed next to the wall time: it is the figure that noise does not move.

Memory check: lhchips4 runs at 1 ms and again at a 0.1 ms period (ten times the
periods, same blocks); the peak RSS must not grow with the periods.

Breakdown: stellabee1 in-process, phase by phase (parse + travel check, then the
run), with cProfile's own time attributed to the module that spent it.

Usage: python bench/run.py [--quick]   (--quick: skip stellabee1)
"""
from __future__ import annotations

import cProfile
import json
import os
import pstats
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
PROGRAMS = [CORPUS / "g1_stellabee1.ngc", CORPUS / "g1_lhchips4.ngc", CORPUS / "g6_farfalla.ngc",
            ROOT / "programs" / "demo.nc"]
VCNC = [sys.executable, "-c", "from machine.cli import main; main()"]


def run_process_rss(path: Path, *extra: str) -> dict:
    """One whole `vcnc run --json` process, reaped with wait4 to read its own peak RSS."""
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:
        os.chdir(ROOT)
        fd = os.open(os.devnull, os.O_WRONLY)
        out = os.open(f"/tmp/vcnc-bench-{os.getpid()}.json", os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(out, 1)
        os.dup2(fd, 2)
        os.execv(sys.executable, VCNC + ["run", str(path), "--json", *extra])
    _, status, usage = os.wait4(pid, 0)
    wall = time.perf_counter() - t0
    result = Path(f"/tmp/vcnc-bench-{pid}.json")
    text = result.read_text()
    result.unlink()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"vcnc run {path.name} failed with status {os.waitstatus_to_exitcode(status)}")
    return {"summary": json.loads(text.strip().splitlines()[-1]), "wall_s": wall, "rss_mb": usage.ru_maxrss / 1024,
            "cpu_s": usage.ru_utime + usage.ru_stime}


def breakdown(path: Path) -> None:
    """Phase CPU times in-process, then cProfile's self time per module."""
    from ipo.config import default_config
    from machine.controller import Controller

    clock = time.process_time
    controller = Controller(default_config())
    t0 = clock()
    program = controller.check(path)
    t_check = clock() - t0
    drive_s = [0.0]
    make_drive = controller.make_drive

    def timed_drive(program):
        drive = make_drive(program)
        receive = drive.receive

        def timed(batch):
            t = clock()
            receive(batch)
            drive_s[0] += clock() - t
        drive.receive = timed
        return drive

    controller.make_drive = timed_drive
    t0 = clock()
    result = controller.run(program)
    t_run = clock() - t0
    print(f"\nbreakdown, {path.name} in one process (CPU seconds, numba caches warm):")
    print(f"  parse + whole-program check  {t_check:8.2f} s")
    print(f"  plan + interpolate           {t_run - drive_s[0]:8.2f} s")
    print(f"  drive (integrate, measure)   {drive_s[0]:8.2f} s")
    print(f"  simulated time {result.cycle_time_s:.1f} s; in-process factor "
          f"{result.cycle_time_s / (t_check + t_run):.0f}x")

    controller.make_drive = make_drive
    prof = cProfile.Profile()
    prof.enable()
    controller.run(controller.check(path))
    prof.disable()
    per_module: dict[str, float] = defaultdict(float)
    for (file, _, _), (_, _, tottime, _, _) in pstats.Stats(prof).stats.items():
        p = Path(file)
        key = "/".join(p.parts[-2:]) if str(ROOT) in file else ("numpy" if "numpy" in file else
                                                                  "lark" if "lark" in file else "other")
        per_module[key] += tottime
    total = sum(per_module.values())
    print("  cProfile self time by module (profiled run; shares matter, not absolute times):")
    for key, s in sorted(per_module.items(), key=lambda kv: -kv[1])[:12]:
        print(f"    {key:32s} {s:7.2f} s  {100 * s / total:5.1f} %")


def main() -> None:
    quick = "--quick" in sys.argv
    programs = [p for p in PROGRAMS if p.exists() and not (quick and "stellabee" in p.name)]
    missing = [p for p in PROGRAMS if not p.exists()]
    for p in missing:
        print(f"skipped (not found): {p}")
    run_process_rss(ROOT / "programs" / "demo.nc")  # warm numba's caches so no row pays for compiling
    print(f"{'program':22s} {'blocks':>7s} {'periods':>9s} {'sim s':>8s} {'wall s':>7s} {'rt factor':>9s} "
          f"{'cpu s':>7s} {'sim/cpu':>8s} {'peak MB':>8s}")
    rows = {}
    for p in programs:
        r = run_process_rss(p)
        s = r["summary"]
        rows[p.name] = r
        print(f"{p.name:22s} {s['blocks']:7d} {s['periods']:9d} {s['cycle_time_s']:8.1f} {r['wall_s']:7.2f} "
              f"{s['cycle_time_s'] / r['wall_s']:9.1f} {r['cpu_s']:7.2f} {s['cycle_time_s'] / r['cpu_s']:8.1f} "
              f"{r['rss_mb']:8.1f}")
    mem = CORPUS / "g1_lhchips4.ngc"
    if mem.name in rows:
        fine = run_process_rss(mem, "--period-ms", "0.1")
        base = rows[mem.name]
        print(f"\nmemory vs periods, {mem.name}: {base['summary']['periods']} periods -> {base['rss_mb']:.1f} MB; "
              f"at a 0.1 ms period {fine['summary']['periods']} periods -> {fine['rss_mb']:.1f} MB")
    big = programs[0]
    if "stellabee" in big.name:
        base = rows[big.name]
        factor = base["summary"]["cycle_time_s"] / base["wall_s"]
        cpu_factor = base["summary"]["cycle_time_s"] / base["cpu_s"]
        print(f"bar: >= 100x real time end to end on {big.name}: {factor:.1f}x by wall time, "
              f"{cpu_factor:.1f}x by CPU time -> {'met' if factor >= 100 else 'NOT met'} (wall); "
              f"cycle {base['summary']['cycle_time_s'] / 60:.1f} min (the issue expects 7-8 min at these limits)")
        breakdown(big)


if __name__ == "__main__":
    main()
