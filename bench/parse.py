"""Interpreter throughput: blocks per second, vcnc against LinuxCNC's rs274 in the same run.

    python bench/parse.py [--repeats N]

Files: ../shared/corpus/linuxcnc/g1_stellabee1.ngc (where present) and a generated
200,000-line `G1 X Y Z F` program.

Two more tables: the command line (`python -m machine.cli parse FILE`, summary included, whole
process against whole `rs274 -g` process; start-up cancelled by timing each program and its first
half: rate = extra blocks / extra seconds), and a loop-heavy program (an `o1 while` loop of
LOOP_ITERATIONS iterations with an expression move and a counter: blocks *executed* per second). vcnc is timed text -> entities with full modal semantics,
both whole-file (`parse_file`) and streaming (`iter_entities`). rs274 is timed as
`rs274 -g FILE > /dev/null` minus its start-up time on a program holding only M2.
Each figure is the best of N runs, vcnc and rs274 interleaved (the machine is shared and
noisy); besides wall-clock rates it prints CPU-time rates (this process's CPU time for vcnc,
the child's user+sys for rs274), which are far less sensitive to other load.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import ipr

STELLABEE = Path(__file__).resolve().parents[2] / "shared" / "corpus" / "linuxcnc" / "g1_stellabee1.ngc"
GENERATED_BLOCKS = 200_000
BAR_BLOCKS_S = 150_000
LOOP_ITERATIONS = 50_000


def write_generated(path: Path, n_blocks: int = GENERATED_BLOCKS) -> Path:
    """n `G1 X Y Z F` blocks along a deterministic random walk, 3 decimals like CAM output, then M2
    (rs274 rejects a program that just stops)."""
    rng = np.random.default_rng(20240601)
    xyz = np.cumsum(rng.uniform(-0.5, 0.5, size=(n_blocks, 3)), axis=0)
    feed = rng.integers(100, 3000, size=n_blocks)
    with path.open("w") as f:
        f.writelines(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F{fr}\n" for (x, y, z), fr in zip(xyz, feed))
        f.write("M2\n")
    return path


def write_loop(path: Path, iterations: int = LOOP_ITERATIONS) -> tuple[Path, int]:
    """An O-word loop program and the number of blocks it executes (4 per iteration)."""
    path.write_text(f"G21 G90 G0 X0 Y0 Z0 F1000\n#1=0\no1 while [#1 LT {iterations}]\n"
                    "  G1 X[#1 MOD 100] Y[FIX[#1/100]]\n  #1=[#1+1]\no1 endwhile\nM2\n")
    return path, 4 * iterations + 4


def write_half(src: Path, path: Path) -> Path:
    """The first half of a program's lines, then M2."""
    lines = src.read_text().splitlines()
    path.write_text("\n".join(lines[:len(lines) // 2]) + "\nM2\n")
    return path


def count_blocks(path: Path) -> int:
    with path.open() as f:
        return sum(1 for line in f if line.strip())


class Timing:
    """Best (smallest) wall-clock and CPU seconds over the runs recorded."""

    def __init__(self) -> None:
        self.wall_s = self.cpu_s = float("inf")

    def add(self, wall_s: float, cpu_s: float) -> None:
        self.wall_s, self.cpu_s = min(self.wall_s, wall_s), min(self.cpu_s, cpu_s)


def _children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def time_vcnc(run, path: Path, timing: Timing) -> None:
    w0, c0 = time.perf_counter(), time.process_time()
    run(path)
    timing.add(time.perf_counter() - w0, time.process_time() - c0)


def time_rs274(rs274: str, path: Path, timing: Timing) -> None:
    w0, c0 = time.perf_counter(), _children_cpu_s()
    subprocess.run([rs274, "-g", str(path)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   stdin=subprocess.DEVNULL, check=True)
    timing.add(time.perf_counter() - w0, _children_cpu_s() - c0)


def time_cli(path: Path, timing: Timing) -> None:
    """The whole `vcnc parse FILE` process (summary table included), as a user runs it."""
    w0, c0 = time.perf_counter(), _children_cpu_s()
    subprocess.run([sys.executable, "-m", "machine.cli", "parse", str(path)], stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, check=True)
    timing.add(time.perf_counter() - w0, _children_cpu_s() - c0)


def cli_table(files, rs274: str | None, repeats: int, tmp: Path) -> None:
    print(f"\ncommand line, whole process, blocks/s from a program and its first half (best of {repeats})")
    header = (f"{'program':<38} | {'wall: vcnc parse':>16} {'rs274 -g':>9} {'ratio':>6} | "
              f"{'CPU: vcnc parse':>15} {'rs274 -g':>9} {'ratio':>6}")
    print(header)
    print("-" * len(header))
    for label, path in files:
        half = write_half(path, tmp / f"half_{path.name}")
        extra = count_blocks(path) - count_blocks(half)
        t = {k: Timing() for k in ("vcnc", "vcnc_half", "rs274", "rs274_half")}
        for _ in range(repeats):
            time_cli(path, t["vcnc"])
            time_cli(half, t["vcnc_half"])
            if rs274:
                time_rs274(rs274, path, t["rs274"])
                time_rs274(rs274, half, t["rs274_half"])
        cells = []
        for clock in ("wall_s", "cpu_s"):
            v_s = getattr(t["vcnc"], clock) - getattr(t["vcnc_half"], clock)
            r_s = getattr(t["rs274"], clock) - getattr(t["rs274_half"], clock) if rs274 else float("nan")
            cells += [_rate(extra, v_s), _rate(extra, r_s) if rs274 else "-",
                      f"{r_s / v_s:.2f}x" if rs274 else "-"]
        print(f"{label:<38} | {cells[0]:>16} {cells[1]:>9} {cells[2]:>6} | {cells[3]:>15} {cells[4]:>9} "
              f"{cells[5]:>6}")
    print("bar (issue 13): ratio >= 1.00x on both programs")


def loop_table(rs274: str | None, repeats: int, startup: Timing, tmp: Path) -> None:
    path, blocks = write_loop(tmp / "loop.ngc")
    vcnc, ref = Timing(), Timing()
    for _ in range(repeats):
        time_vcnc(vcnc_whole, path, vcnc)
        if rs274:
            time_rs274(rs274, path, ref)
    print(f"\nloop-heavy program ({LOOP_ITERATIONS:,} iterations of an o1 while loop), blocks executed/s, "
          f"best of {repeats}")
    for clock in ("wall_s", "cpu_s"):
        v_s = getattr(vcnc, clock)
        line = f"  {clock[:-2]:<5} vcnc parse_file {_rate(blocks, v_s):>10}"
        if rs274:
            r_s = getattr(ref, clock) - getattr(startup, clock)
            line += f"   rs274 -g {_rate(blocks, r_s):>10}   ratio {r_s / v_s:.2f}x"
        print(line)


def vcnc_whole(path: Path) -> None:
    ipr.parse_file(path)


def vcnc_stream(path: Path) -> None:
    with path.open() as f:
        for _ in ipr.iter_entities(f, str(path)):
            pass


def _rate(blocks: int, seconds: float) -> str:
    return f"{blocks / max(seconds, 1e-9):,.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure; the best is reported")
    repeats = parser.parse_args().repeats
    rs274 = shutil.which("rs274")
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        if STELLABEE.is_file():
            files.append(("g1_stellabee1.ngc", STELLABEE))
        else:
            print(f"note: {STELLABEE} not found; corpus row skipped")
        files.append((f"generated G1 X Y Z F ({GENERATED_BLOCKS:,} lines)",
                      write_generated(Path(tmp) / "generated.ngc")))
        startup = Timing()
        if rs274:
            empty = Path(tmp) / "empty.ngc"
            empty.write_text("M2\n")
            for _ in range(2 * repeats + 1):
                time_rs274(rs274, empty, startup)
        else:
            print("note: rs274 not installed (Debian package linuxcnc-uspace); its columns are empty")

        rows = []
        for label, path in files:
            whole, stream, ref = Timing(), Timing(), Timing()
            for _ in range(repeats):  # interleaved, so that vcnc and rs274 see the same machine load
                time_vcnc(vcnc_whole, path, whole)
                time_vcnc(vcnc_stream, path, stream)
                if rs274:
                    time_rs274(rs274, path, ref)
            rows.append((label, count_blocks(path), whole, stream, ref))

        print(f"\ninterpreter throughput, blocks/s, best of {repeats} interleaved runs "
              f"(rs274 start-up {startup.wall_s * 1e3:.1f} ms wall / {startup.cpu_s * 1e3:.1f} ms CPU subtracted)")
        header = (f"{'program':<38} {'blocks':>8} | {'wall: vcnc parse_file':>21} {'iter_entities':>13} "
                  f"{'rs274 -g':>9} {'ratio':>6} | {'CPU: vcnc parse_file':>20} {'rs274 -g':>9} {'ratio':>6}")
        print(header)
        print("-" * len(header))
        for label, blocks, whole, stream, ref in rows:
            wall_ref = cpu_ref = ratio_wall = ratio_cpu = "-"
            if rs274:
                ref_wall_s, ref_cpu_s = ref.wall_s - startup.wall_s, ref.cpu_s - startup.cpu_s
                wall_ref, cpu_ref = _rate(blocks, ref_wall_s), _rate(blocks, ref_cpu_s)
                ratio_wall = f"{ref_wall_s / whole.wall_s:.2f}x"
                ratio_cpu = f"{ref_cpu_s / whole.cpu_s:.2f}x"
            print(f"{label:<38} {blocks:>8,} | {_rate(blocks, whole.wall_s):>21} {_rate(blocks, stream.wall_s):>13} "
                  f"{wall_ref:>9} {ratio_wall:>6} | {_rate(blocks, whole.cpu_s):>20} {cpu_ref:>9} {ratio_cpu:>6}")
        print("ratio = vcnc parse_file rate / rs274 rate")
        blocks, whole = rows[-1][1], rows[-1][2]
        for clock, seconds in (("wall clock", whole.wall_s), ("CPU time", whole.cpu_s)):
            rate = blocks / seconds
            print(f"bar: >= {BAR_BLOCKS_S:,} blocks/s (vcnc parse_file) on the generated program, {clock}: "
                  f"{rate:,.0f} -> {'MET' if rate >= BAR_BLOCKS_S else 'NOT MET'}")
        cli_table(files, rs274, repeats, Path(tmp))
        loop_table(rs274, repeats, startup, Path(tmp))
        print(f"load average during the run: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
