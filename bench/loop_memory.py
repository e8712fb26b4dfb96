"""Memory of a long O-word loop run through `vcnc run --json`: it must not grow with the count.

    python bench/loop_memory.py [--counts 1000000 10000000]

For each count a program counts a parameter up in `o1 repeat [count]` (two blocks executed per
iteration: the assignment and `endrepeat`) and then moves by the result, so the end point proves
that every iteration ran. Each is run in its own `python -m machine.cli run --json` process; the
figure is that process's peak resident memory (os.wait4's ru_maxrss) and its CPU time. The loop is
never unrolled (ipr.program_counter): the peak is the same for every count.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def program(count: int) -> str:
    return (f"G21 G90 G0 X0 Y0 Z0\n#1=0\no1 repeat [{count}]\n  #1=[#1+1]\no1 endrepeat\n"
            f"G1 X[#1/{count}*10] F600\nM2\n")


def run(path: Path) -> tuple[dict, float, float, float]:
    """The run's JSON, its peak RSS in MB, its CPU seconds and wall seconds."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:   # a file, not a pipe: stderr cannot block the child
        proc = subprocess.Popen([sys.executable, "-m", "machine.cli", "run", "--json", str(path)],
                                stdout=subprocess.PIPE, stderr=err, stdin=subprocess.DEVNULL)
        out = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)   # this child's own peak memory
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            err.seek(0)
            sys.exit(f"vcnc run failed on {path}: {err.read().decode()[-500:]}")
    return json.loads(out), usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[1_000_000, 10_000_000])
    counts = parser.parse_args().counts
    print(f"{'iterations':>12} {'peak RSS MB':>12} {'CPU s':>8} {'wall s':>8} {'blocks/s (CPU)':>15} end X (mm)")
    with tempfile.TemporaryDirectory() as tmp:
        for count in counts:
            path = Path(tmp) / f"loop{count}.ngc"
            path.write_text(program(count))
            result, rss_mb, cpu_s, wall_s = run(path)
            blocks = 2 * count + 6
            print(f"{count:>12,} {rss_mb:>12.1f} {cpu_s:>8.1f} {wall_s:>8.1f} {blocks / cpu_s:>15,.0f} "
                  f"{result['position_mm'][0]:.4f} ({result['state']})")


if __name__ == "__main__":
    main()
