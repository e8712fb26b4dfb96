"""Benchmark of `--report`: the report's size and what it costs against the run itself.

For each program, in one process, the same run twice through the built-in default
machine: once bare and once with the report's DigestSink attached (as `vcnc run
--report` does), then the page written from the digest. Printed per program: the
periods, the bare run's wall time (plan, interpolate, drive), the digest's cost
(the difference of the two runs' CPU times, which the shared machine's noise moves
less than wall time), the time to write the page, the report's cost as a share of
the bare run's wall time and, CPU against CPU, of its CPU time, and the file's size. plotly.js alone is ~4.8 MB of it.

Bars (issue 21): g1_stellabee1's report <= 15 MB and written in <= 10 % of the
run's wall time.

Usage: python bench/report.py [--quick]   (--quick: skip stellabee1)
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
PROGRAMS = [ROOT / "programs" / "demo.nc", ROOT / "programs" / "finish_nurbs.nc", CORPUS / "g1_lhchips4.ngc",
            CORPUS / "g1_stellabee1.ngc"]
SIZE_BAR_MB, SHARE_BAR = 15.0, 0.10


def _run(path: Path, with_digest: bool):
    from ipo.config import default_config
    from machine.controller import Controller
    from machine.report.digest import DigestSink

    ctl = Controller(default_config())
    program = ctl.check(path)
    sink = DigestSink(dict(ctl.limits.meta(), file=str(path))) if with_digest else None
    ctl.sinks = [sink] if sink else []
    c0 = time.process_time()
    result = ctl.run(program)
    cpu = time.process_time() - c0
    return program, result, cpu, sink


def measure(path: Path, out_dir: Path) -> dict:
    from machine.report.build import machine_info, run_report

    _, bare, bare_cpu, _ = _run(path, False)
    program, result, cpu, sink = _run(path, True)
    t0, c0 = time.perf_counter(), time.process_time()
    digest = sink.finish()
    out = run_report(out_dir / (path.stem + ".html"), digest, program=program, summary=result.summary(),
                     machine=machine_info(None))
    write_s, write_cpu = time.perf_counter() - t0, time.process_time() - c0
    digest_s = max(cpu - bare_cpu, 0.0)
    return {"name": path.name, "periods": bare.periods, "run_s": bare.wall_s, "run_cpu_s": bare_cpu,
            "digest_s": digest_s, "write_s": write_s, "share": (digest_s + write_s) / bare.wall_s,
            "share_cpu": (digest_s + write_cpu) / bare_cpu, "size_mb": out.stat().st_size / 1e6}


def main() -> None:
    quick = "--quick" in sys.argv
    programs = [p for p in PROGRAMS if p.exists() and not (quick and p.name == "g1_stellabee1.ngc")]
    missing = [p.name for p in PROGRAMS if not p.exists()]
    if missing:
        print(f"skipped (not found): {', '.join(missing)}")
    print(f"{'program':22s} {'periods':>9s} {'run s':>7s} {'run cpu s':>9s} {'digest s':>8s} {'write s':>7s} "
          f"{'share':>6s} {'cpu share':>9s} {'size MB':>7s}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in programs:
            r = measure(path, Path(tmp))
            rows.append(r)
            print(f"{r['name']:22s} {r['periods']:9d} {r['run_s']:7.2f} {r['run_cpu_s']:9.2f} {r['digest_s']:8.2f} "
                  f"{r['write_s']:7.2f} {r['share'] * 100:5.1f}% {r['share_cpu'] * 100:8.1f}% {r['size_mb']:7.2f}")
    for r in rows:
        if r["name"] == "g1_stellabee1.ngc":
            print(f"bar: stellabee1 report {r['size_mb']:.2f} MB <= {SIZE_BAR_MB:g} MB: "
                  f"{'MET' if r['size_mb'] <= SIZE_BAR_MB else 'NOT MET'}")
            print(f"bar: stellabee1 report cost {r['share'] * 100:.1f} % of the run's wall time <= "
                  f"{SHARE_BAR * 100:g} %: {'MET' if r['share'] <= SHARE_BAR else 'NOT MET'} "
                  f"(CPU against CPU, which the shared machine's load moves less: {r['share_cpu'] * 100:.1f} %)")


if __name__ == "__main__":
    main()
