"""Peak memory of `vcnc run --json`: it grows with the program's text, never with the blocks executed.

    python bench/loop_memory.py [--lines 2000000] [--counts 1000000 10000000] [--moving 20000 200000]

Each program runs in its own `python -m machine.cli run --json` process; the figure is that
process's peak resident memory (os.wait4's ru_maxrss) and its CPU time. The programs:

- a generated CAM-like raster of `--lines` G1 lines (a 100 x 100 mm surface, 0.1 mm steps),
  against issue 22's bar: <= 600 MB for 2,000,000 lines;
- `o1 repeat [count]` loops of `--counts` iterations counting a parameter up (two blocks
  executed per iteration), then moving by the result, so the end point proves that every
  iteration ran;
- `o1 repeat [count]` loops of `--moving` iterations with a move in each (a zigzag): the
  entities a loop makes are checked and run as they come, never held.

The check before motion (machine.check) interprets the whole program and the run interprets
it again, so neither holds the executed entities: the peak is the same for every count.
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

PASS_POINTS = 1000   # points per raster pass: X from 0 to 100 mm in 0.1 mm steps
BAR_MB = 600.0       # issue 22: vcnc run of a 2,000,000-line program


def write_raster(path: Path, n_lines: int) -> Path:
    """n_lines G1 moves over a wavy surface, passes along X stepping over in Y, 3 decimals."""
    with path.open("w") as f:
        f.write("G21 G90 G17 G64\nG0 X0 Y0 Z5\nG1 Z0 F3000\n")
        for i in range(n_lines):
            k, j = divmod(i, PASS_POINTS)
            x = 0.1 * (j if k % 2 == 0 else PASS_POINTS - 1 - j)
            y = 100.0 * k / max(1, n_lines // PASS_POINTS)
            f.write(f"G1 X{x:.3f} Y{y:.3f} Z{0.5 * ((x * 7919 + y * 104729) % 17) / 17:.3f}\n")
        f.write("G0 Z5\nM2\n")
    return path


def counting_loop(count: int) -> str:
    return (f"G21 G90 G0 X0 Y0 Z0\n#1=0\no1 repeat [{count}]\n  #1=[#1+1]\no1 endrepeat\n"
            f"G1 X[#1/{count}*10] F600\nM2\n")


def moving_loop(count: int) -> str:
    return (f"G21 G90 G0 X0 Y0 Z0\n#1=0\no1 repeat [{count}]\n  #1=[#1+1]\n  G1 X[#1 MOD 2] Y[#1/{count}*10] F3000\n"
            f"o1 endrepeat\nM2\n")


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
    parser.add_argument("--lines", type=int, default=2_000_000, help="lines of the raster program (0: skip)")
    parser.add_argument("--counts", type=int, nargs="*", default=[1_000_000, 10_000_000])
    parser.add_argument("--moving", type=int, nargs="*", default=[20_000, 200_000])
    args = parser.parse_args()
    print(f"{'program':<44} {'peak RSS MB':>12} {'CPU s':>8} {'wall s':>8} {'motions':>9}  end X Y (mm), state")
    with tempfile.TemporaryDirectory() as tmp:
        cases = []
        if args.lines:
            cases.append((f"raster of {args.lines:,} G1 lines", write_raster(Path(tmp) / "raster.ngc", args.lines)))
        for count in args.counts:
            path = Path(tmp) / f"loop{count}.ngc"
            path.write_text(counting_loop(count))
            cases.append((f"o1 repeat, {count:,} iterations, no motion", path))
        for count in args.moving:
            path = Path(tmp) / f"moving{count}.ngc"
            path.write_text(moving_loop(count))
            cases.append((f"o1 repeat, {count:,} iterations with a G1", path))
        for label, path in cases:
            result, rss_mb, cpu_s, wall_s = run(path)
            x, y, _ = result["position_mm"]
            print(f"{label:<44} {rss_mb:>12.1f} {cpu_s:>8.1f} {wall_s:>8.1f} {result['motions']:>9,}  "
                  f"{x:.4f} {y:.4f}, {result['state']}", flush=True)
            if label.startswith("raster") and args.lines == 2_000_000:
                print(f"bar (issue 22): peak RSS <= {BAR_MB:.0f} MB on 2,000,000 lines -> "
                      f"{'MET' if rss_mb <= BAR_MB else 'NOT MET'}")


if __name__ == "__main__":
    main()
