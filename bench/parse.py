"""Interpreter throughput: blocks per second, vcnc against LinuxCNC's rs274 in the same run.

    python bench/parse.py [--repeats N]

Files: ../shared/corpus/linuxcnc/g1_stellabee1.ngc (where present) and a generated
200,000-line `G1 X Y Z F` program. vcnc is timed text -> entities with full modal semantics,
both whole-file (`parse_file`) and streaming (`iter_entities`). rs274 is timed as
`rs274 -g FILE > /dev/null` minus its start-up time on a program holding only M2.
Each figure is the best of N runs (the machine is shared and noisy).
"""
from __future__ import annotations

import argparse
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


def write_generated(path: Path, n_blocks: int = GENERATED_BLOCKS) -> Path:
    """n `G1 X Y Z F` blocks along a deterministic random walk, 3 decimals like CAM output."""
    rng = np.random.default_rng(20240601)
    xyz = np.cumsum(rng.uniform(-0.5, 0.5, size=(n_blocks, 3)), axis=0)
    feed = rng.integers(100, 3000, size=n_blocks)
    with path.open("w") as f:
        f.writelines(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F{fr}\n" for (x, y, z), fr in zip(xyz, feed))
    return path


def count_blocks(path: Path) -> int:
    with path.open() as f:
        return sum(1 for line in f if line.strip())


def best_s(run, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return min(times)


def vcnc_whole(path: Path) -> None:
    ipr.parse_file(path)


def vcnc_stream(path: Path) -> None:
    with path.open() as f:
        for _ in ipr.iter_entities(f, str(path)):
            pass


def rs274_s(rs274: str, path: Path, repeats: int) -> float:
    def run() -> None:
        subprocess.run([rs274, "-g", str(path)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       stdin=subprocess.DEVNULL, check=True)
    return best_s(run, repeats)


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
        startup_s = 0.0
        if rs274:
            empty = Path(tmp) / "empty.ngc"
            empty.write_text("M2\n")
            startup_s = rs274_s(rs274, empty, 2 * repeats + 1)
        else:
            print("note: rs274 not installed (Debian package linuxcnc-uspace); its columns are empty")

        header = (f"{'program':<40} {'blocks':>8} {'vcnc parse_file':>16} {'vcnc iter_entities':>19} "
                  f"{'rs274 -g':>12} {'vcnc/rs274':>11}")
        print(f"\ninterpreter throughput, blocks/s (best of {repeats}; rs274 start-up "
              f"{startup_s * 1e3:.1f} ms subtracted)")
        print(header)
        print("-" * len(header))
        generated_rate = 0.0
        for label, path in files:
            blocks = count_blocks(path)
            whole = blocks / best_s(lambda: vcnc_whole(path), repeats)
            stream = blocks / best_s(lambda: vcnc_stream(path), repeats)
            ref = ratio = "-"
            if rs274:
                ref_rate = blocks / max(rs274_s(rs274, path, repeats) - startup_s, 1e-9)
                ref, ratio = f"{ref_rate:,.0f}", f"{whole / ref_rate:.2f}x"
            print(f"{label:<40} {blocks:>8,} {whole:>16,.0f} {stream:>19,.0f} {ref:>12} {ratio:>11}")
            generated_rate = whole
        verdict = "MET" if generated_rate >= BAR_BLOCKS_S else "NOT MET"
        print(f"\nbar: >= {BAR_BLOCKS_S:,} blocks/s (parse_file) on the generated program: "
              f"{generated_rate:,.0f} -> {verdict}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
