"""Benchmark of the grbl link through the grbl TEST DOUBLE (tests/grbl_emulator.py), and
of NURBS programs turned into G1 segments by vcnc's IPO.

1. Throughput over a pty pair with no drain limit (the double's planner empties at
   once): lines/s and bytes/s of character counting, against the same lines sent
   call-and-response (one line, wait for its ok) in the same run. RX-buffer fill is
   the link's count of unanswered bytes after each send (what character counting
   keeps below 127), mean and min over the run's middle (first and last 20 lines
   left out); the double's own peak RX fill is printed next to it.
2. For each NURBS program: G1 segments sent against the NURBS blocks in the source,
   and the largest distance from the exact curve (dense samples, 200 per segment)
   to the polyline sent, at the machine's chord tolerance as merge tolerance and at
   half of it. The vertices are the IPO's period points on the curve (not rounded to
   the BLU), written with 4 decimals and merged within the tolerance less that
   rounding, so the deviation stays within the merge tolerance. Then what
   the stream asks of a 115200-baud grbl with 15 planner blocks (machine.grbl.budget).

3. Compact lines (issue 17) against the format vcnc sent before (every axis and F on
   every line, 4 decimals, a preamble G21G90G91.1G94G17), written in the same run from
   the same stream: bytes per line, bytes in all, the time a 115200-baud port needs for
   them, and lines per second through the double for both.

Usage: python bench/stream.py
"""
from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]   # the repository first: tests/machine is a folder of tests

from grbl_emulator import GrblDouble, PtyServer  # noqa: E402
from ipr.entities import PLANE_AXES  # noqa: E402
from ipo.config import default_config  # noqa: E402
from ipo.nurbs.kernel import curve_points  # noqa: E402
from ipr import parse_file  # noqa: E402
from ipr.entities import Line, Nurbs, Rapid  # noqa: E402
from machine.grbl.budget import stream_demand  # noqa: E402
from machine.grbl.ledger import Ledger  # noqa: E402
from machine.grbl.link import GrblLink  # noqa: E402
from machine.grbl.program import stream_lines  # noqa: E402

CFG = default_config()
UNBLENDED = dataclasses.replace(CFG, g64_blend_tol_mm=0.0)
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"


def _zigzag(n: int):
    ents, p = [Rapid(1, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))], (0.0, 0.0, 1.0)
    for i in range(n):
        q = (round(0.01 * (i + 1), 4), round(12.3456 * (i % 2), 4), -0.5)
        ents.append(Line(i + 2, p, q, 25.0))
        p = q
    return list(stream_lines(ents, CFG))


def _call_and_response(link: GrblLink, lines) -> float:
    t0 = time.perf_counter()
    for line in lines:
        link.command(line.text)
    return time.perf_counter() - t0


def _timed_stream(lines, reference_lines=()):
    """Stream `lines` through a fresh double with no drain limit: (result, seconds, double,
    seconds for `reference_lines` sent call-and-response afterwards)."""
    double = GrblDouble(drain_s_per_block=0.0, wco=(0.0, 0.0, 0.0))
    with PtyServer(double).start() as srv:
        link = GrblLink(srv.port, poll_interval_s=0.2, settle_s=0.05)
        link.connect(CFG)
        t0 = time.perf_counter()
        res = link.stream(lines, Ledger(1))
        dt = time.perf_counter() - t0
        t_ref = _call_and_response(link, reference_lines)
        link.close()
    assert res.completed, res.fault
    return res, dt, double, t_ref


def throughput(n_lines: int = 4000) -> None:
    lines = _zigzag(n_lines)
    n_bytes = sum(len(l.text) + 1 for l in lines)
    ref_lines = lines[: n_lines // 4]
    res, t_count, double, t_ref = _timed_stream(lines, ref_lines)
    fill = np.array(res.rx_fill[20:-20])
    ref_rate = len(ref_lines) / t_ref
    print(f"grbl test double over a pty, no drain limit, {len(lines)} lines, {n_bytes} bytes "
          f"(mean {n_bytes / len(lines):.1f} bytes/line)")
    print(f"  character counting : {len(lines) / t_count:9.0f} lines/s  {n_bytes / t_count:10.0f} bytes/s")
    print(f"  call-and-response  : {ref_rate:9.0f} lines/s  (reference, same run, {len(ref_lines)} lines)")
    print(f"  ratio              : {len(lines) / t_count / ref_rate:9.2f} x")
    print(f"  RX fill (unanswered bytes after each send): mean {fill.mean():.1f}, min {fill.min()}, "
          f"max {fill.max()} of 127; the double's peak RX fill {double.max_rx_fill}, overflow {double.rx_overflow}")


def _nurbs_blocks(source: list[str], first: int, last: int) -> int:
    """Non-blank, non-comment source lines from the group's first line to before `last`."""
    count = 0
    for text in source[first - 1: last - 1]:
        t = text.split(";")[0].strip()
        while "(" in t and ")" in t:
            t = (t[: t.index("(")] + t[t.index(")") + 1:]).strip()
        count += bool(t)
    return count


def _deviation(e: Nurbs, poly: np.ndarray) -> float:
    """Largest distance from the exact curve to the polyline: dense curve samples, each
    measured against the segments around its nearest vertex."""
    n_seg = len(poly) - 1
    u = np.linspace(e.knots[0], e.knots[-1], 200 * n_seg + 1)
    c = curve_points(e.degree, e.knots, e.weights, e.points, u)
    a, b = poly[:-1], poly[1:]
    # each sample's segment: samples are in curve order, so assign by the nearest vertex index, monotone
    d_vert = np.empty(len(c), dtype=np.int64)
    j = 0
    for i in range(len(c)):
        while j + 1 < len(poly) and np.sum((poly[j + 1] - c[i]) ** 2) <= np.sum((poly[j] - c[i]) ** 2):
            j += 1
        d_vert[i] = j
    worst = 0.0
    for k in (-1, 0):
        s = np.clip(d_vert + k, 0, n_seg - 1)
        ab = b[s] - a[s]
        t = np.clip(np.einsum("ij,ij->i", c - a[s], ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        dist = np.linalg.norm(a[s] + t[:, None] * ab - c, axis=1)
        worst = dist if k == -1 else np.minimum(worst, dist)
    return float(np.max(worst))


def nurbs_programs() -> None:
    progs = [ROOT / "programs" / "demo.nc", CORPUS / "g6_farfalla.ngc"]
    print(f"NURBS through vcnc's IPO to G1 segments (chord tolerance {CFG.chord_tol_mm * 1e3:.1f} um, "
          f"BLU {CFG.blu_mm * 1e3:.1f} um, period {CFG.period_s * 1e3:.1f} ms)")
    for path in progs:
        if not path.exists():
            print(f"  {path.name}: not found (corpus absent), skipped")
            continue
        prog = parse_file(path)
        source = path.read_text().splitlines()
        for tol_mm in (CFG.chord_tol_mm, CFG.chord_tol_mm / 2):
            t0 = time.perf_counter()
            lines = list(stream_lines(prog.entities, CFG, ipo_from_start=True, merge_tol_mm=tol_mm))
            t_gen = time.perf_counter() - t0
            # the machine blends the corners at the curve's ends within its G64 tolerance; the same
            # stream without those blends shows the merge's own deviation
            unblended = list(stream_lines(prog.entities, UNBLENDED, ipo_from_start=True, merge_tol_mm=tol_mm))
            _report(path, prog.entities, source, lines, unblended, tol_mm)
            d = stream_demand(lines, baud=115200, planner_blocks=15,
                              accel_mm_s2=min(a.max_accel_mm_s2 for a in CFG.axes))
            print(f"  {path.name}: {len(lines)} stream lines generated in {t_gen:.2f} s; at the planned feed the "
                  f"stream needs up to {d.peak_bytes_s:.0f} bytes/s (115200 baud: {d.capacity_bytes_s:.0f}); "
                  f"grbl's 15-block look-ahead allows {d.slowest_ratio * 100:.0f} % of the planned feed at worst")


def _report(path, ents, source, lines, unblended, tol_mm) -> None:
    for i, e in enumerate(ents):
        if not isinstance(e, Nurbs):
            continue
        nxt = next((x.line for x in ents[i + 1:] if x.line > e.line), len(source) + 1)
        blocks = _nurbs_blocks(source, e.line, nxt)
        segs = [l for l in lines if l.source_line == e.line and l.motion]
        poly = np.array([segs[0].start_mm] + [l.end_mm for l in segs])
        dev_blended = _deviation(e, poly)
        segs_u = [l for l in unblended if l.source_line == e.line and l.motion]
        dev = _deviation(e, np.array([segs_u[0].start_mm] + [l.end_mm for l in segs_u]))
        feeds = np.array([float(l.text.rsplit("F", 1)[1]) for l in segs])
        length = float(np.sum(np.linalg.norm(np.diff(poly, axis=0), axis=1)))
        print(f"  {path.name} line {e.line}, merge tolerance {tol_mm * 1e3:.1f} um: {len(segs)} G1 segments "
              f"for {blocks} NURBS blocks ({len(e.points)} control points, degree {e.degree}, {length:.1f} mm, "
              f"mean segment {length / len(segs) * 1e3:.0f} um); max deviation from the exact curve "
              f"{dev * 1e3:.2f} um ({dev_blended * 1e3:.2f} um with the G64 blends of its end corners, "
              f"P = {CFG.g64_blend_tol_mm * 1e3:g} um); F {feeds.min():.0f}..{feeds.max():.0f} mm/min (programmed "
              f"{e.feed_mm_s * 60:.0f})")


def _verbose(line) -> str:
    """The line as vcnc wrote it before issue 17: every axis and F, 4 decimals."""
    n = lambda v: f"{v:.4f}"  # noqa: E731
    xyz = "".join(f"{a}{n(v)}" for a, v in zip("XYZ", line.end_mm))
    if line.arc is not None:
        center, plane, ccw, feed = line.arc
        a, b, _ = PLANE_AXES[plane]
        offs = "".join(f"{'IJK'[k]}{n(center[k] - line.start_mm[k])}" for k in sorted((a, b)))
        return f"{ {'XY': 'G17', 'ZX': 'G18', 'YZ': 'G19'}[plane]}F{n(feed)}{'G3' if ccw else 'G2'}{xyz}{offs}"
    if line.motion:
        return f"G1{xyz}F{n(line.feed_mm_min)}" if line.feed_mm_min is not None else f"G0{xyz}"
    return line.text


def _rate(lines) -> float:
    return len(lines) / _timed_stream(lines)[1]


def compactness() -> None:
    from machine.grbl.job import build_job, machine_at_zero

    import tempfile

    gen = Path(tempfile.mkdtemp()) / "zigzag500.nc"  # written and removed in this run
    gen.write_text("G21 G90 G17\nG0 Z1\n" + "".join(
        f"G1 X{0.5 * (i + 1):.3f} Y{12.3456 * (i % 2):.4f} Z-0.5 F1500\n" for i in range(498)))
    progs = [gen, ROOT / "programs" / "demo.nc", CORPUS / "g1_lhchips4.ngc"]
    print("compact lines (issue 17) against vcnc's earlier format (every axis and F, 4 decimals), same run:")
    try:
        for path in progs:
            if not path.exists():
                print(f"  {path.name}: not found (corpus absent), skipped")
                continue
            lines = build_job(path, CFG, machine_at_zero()).lines
            verbose = [dataclasses.replace(l, text=_verbose(l)) for l in lines]
            verbose.insert(0, dataclasses.replace(lines[0], seq=0, text="G21G90G91.1G94G17", motion=False))
            verbose = [dataclasses.replace(l, seq=i + 1) for i, l in enumerate(verbose)]
            b_new = sum(len(l.text) + 1 for l in lines)
            b_old = sum(len(l.text) + 1 for l in verbose)
            name = "500-line zigzag" if path == gen else path.name
            print(f"  {name}: source {path.stat().st_size} bytes; before {len(verbose)} lines {b_old} bytes "
                  f"({b_old / len(verbose):.1f} bytes/line, {b_old / 11520:.2f} s at 115200 baud); after "
                  f"{len(lines)} lines {b_new} bytes ({b_new / len(lines):.1f} bytes/line, {b_new / 11520:.2f} s); "
                  f"{b_old / b_new:.2f}x fewer bytes")
            if len(lines) <= 5000:
                r_old, r_new = _rate(verbose), _rate(lines)
                print(f"    through the double: before {r_old:.0f} lines/s, after {r_new:.0f} lines/s "
                      f"({r_new / r_old:.2f}x)")
    finally:
        gen.unlink(missing_ok=True)
        gen.parent.rmdir()


if __name__ == "__main__":
    throughput()
    compactness()
    nurbs_programs()
