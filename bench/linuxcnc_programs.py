"""Acceptance over LinuxCNC's own programs: of those `rs274 -g` accepts, the share vcnc accepts
with the same end points.

    python bench/linuxcnc_programs.py [--list] [DIR ...]

Default directories: /usr/share/linuxcnc/ncfiles, /usr/share/doc/linuxcnc/examples (Debian's
linuxcnc-uspace) and ../shared/corpus/linuxcnc. Every *.ngc / *.nc file below them is run through
`rs274 -g -b` (in the program's folder, where it finds subroutine files) and through
`ipr.parse_file`. A program counts as agreeing when vcnc accepts it and its Rapid/Line/Arc
entities have the same count and end points as rs274's moves (tests/rs274.py reads rs274's
output; tolerance: rs274's printed precision). The files are read where they are installed,
never copied. It prints the figure and, for each program vcnc refuses, the error code, so the
constructs still missing can be counted.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

# the repository first: tests/ipr is a folder of tests, not the package
sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parents[1] / "tests")]
from rs274 import RS274, canon_moves, private_home  # noqa: E402

import ipr  # noqa: E402
from ipr.entities import Arc, GCodeError, Line, Rapid  # noqa: E402

DIRS = (Path("/usr/share/linuxcnc/ncfiles"), Path("/usr/share/doc/linuxcnc/examples"),
        Path(__file__).resolve().parents[2] / "shared" / "corpus" / "linuxcnc")
RS274_TIMEOUT_S = 60
# Both interpreters get the same tools: vcnc's default set-up has no tool table (every tool's
# length and radius 0), while rs274 alone falls back to a built-in table of its own (T1 0.511 in
# long, T2 0.1 in, ...), so a G43 after T1 M6 would differ by a made-up length, not by semantics.
ZERO_TOOLS = "".join(f"T{t} P{t} Z0 D0\n" for t in range(1, 100))
_FLOAT_SLACK = 1e-9


def programs(dirs) -> list[Path]:
    files = set()
    for d in dirs:
        if d.is_dir():
            files.update(p for p in d.rglob("*") if p.suffix.lower() in (".ngc", ".nc") and p.is_file())
    return sorted(files)


def rs274_moves(path: Path):
    """rs274's moves, or None when it rejects the program (or does not finish)."""
    try:
        with private_home() as env:
            table = Path(env["HOME"]) / "tools.tbl"
            table.write_text(ZERO_TOOLS)
            done = subprocess.run([RS274, "-g", "-b", "-t", str(table), path.name], cwd=path.parent,
                                  capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=RS274_TIMEOUT_S,
                                  env=env)
    except subprocess.TimeoutExpired:
        return None
    # rs274 -g prints an error and still exits 0 on some failures: its message on stderr says so
    if done.returncode != 0 or "error" in done.stderr.lower():
        return None
    return canon_moves(done.stdout)


def _moving(items: list, end, straight) -> list:
    """The moves that go somewhere: a straight move to where the previous one ended is no motion
    (rs274 prints one for a `G0` without axis words, vcnc emits none), while an arc back to its
    start is a full circle."""
    kept, at = [], (0.0, 0.0, 0.0)
    for item in items:
        if not (straight(item) and all(abs(a - b) <= _FLOAT_SLACK for a, b in zip(end(item), at))):
            kept.append(item)
        at = end(item)
    return kept


def compare(path: Path, moves) -> str:
    """'agree', 'differ: ...' or the first error code vcnc reports."""
    try:
        entities = ipr.parse_file(path).entities
    except GCodeError as err:
        d = err.diagnostics[0]
        return f"{d.code}: {d.message[:70]}"
    except Exception as err:  # a traceback is the worst outcome: count it, name it
        return f"TRACEBACK {type(err).__name__}: {str(err)[:60]}"
    motions = _moving([e for e in entities if type(e) in (Rapid, Line, Arc)], lambda e: e.end,
                      lambda e: type(e) is not Arc)
    moves = _moving(moves, lambda m: m.end_mm, lambda m: m.kind != "arc")
    if len(motions) != len(moves):
        return f"differ: {len(motions)} moves, rs274 {len(moves)}"
    for i, (m, e) in enumerate(zip(moves, motions)):
        if any(abs(e.end[k] - m.end_mm[k]) > m.tol_mm + _FLOAT_SLACK for k in range(3)):
            return f"differ: move {i} (line {e.line}) ends at {e.end}, rs274 {m.end_mm}"
    return "agree"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="*", type=Path, default=list(DIRS))
    parser.add_argument("--list", action="store_true", help="print every program's outcome")
    args = parser.parse_args()
    if RS274 is None:
        sys.exit("rs274 is not installed (Debian package linuxcnc-uspace)")
    t0 = time.perf_counter()
    files = programs(args.dirs)
    outcomes: dict[Path, str] = {}
    moving: set[Path] = set()   # rs274 makes at least one move (not a subroutine library alone)
    rejected_by_rs274 = 0
    for path in files:
        moves = rs274_moves(path)
        if moves is None:
            rejected_by_rs274 += 1
            continue
        outcomes[path] = compare(path, moves)
        if moves:
            moving.add(path)
    agree = sum(1 for o in outcomes.values() if o == "agree")
    refused = Counter(o.split(":")[0] for o in outcomes.values() if o != "agree")
    if args.list:
        for path, outcome in outcomes.items():
            print(f"{outcome[:110]:<110} {path}")
    print(f"\n{len(files)} programs found, rs274 accepts {len(outcomes)} (rejects {rejected_by_rs274})")
    print(f"vcnc accepts with the same end points: {agree} / {len(outcomes)} = "
          f"{100.0 * agree / max(len(outcomes), 1):.1f} %")
    agree_moving = sum(1 for p in moving if outcomes[p] == "agree")
    print(f"  of those where rs274 moves at all: {agree_moving} / {len(moving)} = "
          f"{100.0 * agree_moving / max(len(moving), 1):.1f} %")
    print("not agreeing, by first error code: " + ", ".join(f"{k} {n}" for k, n in refused.most_common()))
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
