"""Proof that a change kept behaviour bit-identical: SHA-1 of what vcnc produces.

    python bench/hashes.py [--out FILE.json] [--compare FILE.json] [--quick]

For each program and acceleration mode it runs the feed stage and interpolators
(`plan_periods`) over the checked program and hashes, over all periods in order, each
field of the period stream (pos, inc, feed, limit, line) and the non-motion events
with the period count at which each arrives (kind, line and content). It also hashes the bytes `vcnc fit`
writes for programs/finish_g01.nc, and what `vcnc surface` (IGES, its time stamp
masked) and `vcnc toolpath` write for a synthetic bump digitisation
(tests/surface_cases.py). The CLI runs in this interpreter (machine.cli.main), never a `vcnc` from PATH.

Prints one line per case and the time each took; `--out` saves the hashes as JSON,
`--compare` checks them against a saved file and exits 1 on any difference.
`--quick` skips the slow cases (lhchips4 in S-curve mode, the fit of finish_g01.nc).
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
STREAM_CASES = [  # (name, program, machine file)
    ("demo", ROOT / "programs" / "demo.nc", ROOT / "programs" / "machine.toml"),
    ("lhchips4", CORPUS / "g1_lhchips4.ngc", ROOT / "programs" / "machine.toml"),
    ("finish_nurbs", ROOT / "programs" / "finish_nurbs.nc", ROOT / "programs" / "finish_machine.toml"),
]
SLOW = {"lhchips4/scurve", "fit/finish_g01"}
FIELDS = ("pos_mm", "inc_blu", "feed_mm_s", "limit", "line")
EVENT_FIELDS = ("text", "rpm", "direction", "mist", "flood", "tool", "optional", "seconds")


def stream_hashes(program: Path, machine: Path, accel_mode: str) -> dict:
    """SHA-1 per field of the whole period stream, the events, and the period count."""
    from ipo.config import load_config
    from ipo.feed.planner import plan_periods
    from machine.controller import Controller, start_position

    config = dataclasses.replace(load_config(machine), accel_mode=accel_mode)
    prog = Controller(config).check(program)
    digests = {f: hashlib.sha1() for f in FIELDS + ("events",)}
    periods = 0
    for item in plan_periods(prog.entities, config, method=config.method, start_mm=start_position(prog)):
        if hasattr(item, "inc_blu"):
            for f in FIELDS:
                digests[f].update(getattr(item, f).tobytes())
            periods += len(item)
        else:
            digests["events"].update(f"{periods}:{_event(item)}\n".encode())
    return {"periods": periods, **{f: d.hexdigest() for f, d in digests.items()}}


def _event(item) -> str:
    """An event by its kind, line and what it says (not its repr: entities gain fields)."""
    said = {k: getattr(item, k) for k in EVENT_FIELDS if hasattr(item, k)}
    return f"{type(item).__name__}:{getattr(item, 'line', None)}:{said}"


def _cli(*args: str) -> None:
    subprocess.run([sys.executable, "-c", "from machine.cli import main; main()", *args], check=True,
                   capture_output=True, cwd=ROOT)


def _sha1(path: Path, mask: tuple[str, str] | None = None) -> str:
    data = path.read_bytes()
    if mask is not None:
        data = re.sub(mask[0].encode(), mask[1].encode(), data)
    return hashlib.sha1(data).hexdigest()


def fit_hash(tmp: Path) -> dict:
    out = tmp / "finish_fit.nc"
    _cli("fit", str(ROOT / "programs" / "finish_g01.nc"), "-o", str(out), "--tol-mm", "0.005")
    return {"bytes": out.stat().st_size, "sha1": _sha1(out)}


def surface_hashes(tmp: Path) -> dict:
    from surface_cases import bump, csv_text

    pts, igs, nc = tmp / "bump.csv", tmp / "bump.igs", tmp / "bump.nc"
    pts.write_text(csv_text(bump(0.005).sections))
    _cli("surface", str(pts), "-o", str(igs), "--tol-mm", "0.02")
    _cli("toolpath", str(igs), "--ball-mm", "3", "--pick-mm", "1", "-o", str(nc))
    return {"iges_sha1": _sha1(igs, (r"\d{8}\.\d{6}", "00000000.000000")), "toolpath_sha1": _sha1(nc)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path)
    ap.add_argument("--compare", type=Path)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    results: dict[str, dict] = {}

    def case(name: str, fn, *a) -> None:
        if args.quick and name in SLOW:
            print(f"{name:24} skipped (--quick)")
            return
        t0 = time.perf_counter()
        results[name] = fn(*a)
        summary = " ".join(f"{k}={str(v)[:12]}" for k, v in results[name].items())
        print(f"{name:24} {time.perf_counter() - t0:7.1f} s  {summary}", flush=True)

    for name, program, machine in STREAM_CASES:
        if not program.exists():
            print(f"{name:24} skipped: {program} is absent")
            continue
        for mode in ("trapezoid", "scurve"):
            case(f"{name}/{mode}", stream_hashes, program, machine, mode)
    with tempfile.TemporaryDirectory() as d:
        case("fit/finish_g01", fit_hash, Path(d))
        case("surface+toolpath/bump", surface_hashes, Path(d))
    if args.out:
        args.out.write_text(json.dumps(results, indent=1, sort_keys=True) + "\n")
    if args.compare:
        ref = json.loads(args.compare.read_text())
        diff = [k for k in sorted(set(ref) & set(results)) if ref[k] != results[k]]
        missing = sorted(set(ref) - set(results))
        print(f"compared {len(set(ref) & set(results))} cases with {args.compare}: "
              f"{'identical' if not diff else 'DIFFERENT: ' + ', '.join(diff)}"
              + (f"; not run: {', '.join(missing)}" if missing else ""))
        return 1 if diff else 0
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
