"""NURBS interpolators side by side: 000's experiment, real curves, throughput.

    python bench/interp.py [--no-plots]

(a) programs/curve000.nc, a curve like 000's (length 0.089 mm, control polygon 0.157 mm,
    tightest radius 1 um) at D = 1 um: chord deviation per method, the §2.2.1 start-up to
    e = 1 %, the reference-pulse path at BLU = 1 um; chord-per-step plots like 000 Fig. 7-9
    in bench/out/.
(b) The NURBS of ../shared/corpus/linuxcnc/g6_{farfalla,stella,unipa}.ngc at D = 0.1 mm
    (F6000 at a 1 ms period); constant du is given the du that makes its mean chord D.
(c) Periods per second of recursive n1 = 2 on a cubic 3-axis NURBS with 30 control points,
    against geomdl's single-point evaluation rate in the same run. Rates are per CPU second
    of this process (the machine is shared); wall-clock rates are printed next to them.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ipo.nurbs import kernel as nurbs
from ipo.interp.chord_study import study
from ipo.interp.reference_pulse import pulse_deviation_blu, pulse_path, pulses
from ipo.interp.steppers import make_stepper
from ipr import parse_file
from ipr.entities import Nurbs

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
OUT = ROOT / "bench" / "out"
CURVE000 = ROOT / "programs" / "curve000.nc"

METHODS_000 = [
    ("constant-du, du = 0.02", dict(method="constant-du", du=0.02)),
    ("recursive n1 = 1, m1 = 3", dict(n1=1, m1=3)),
    ("recursive n1 = 2, m1 = 3", dict(n1=2, m1=3)),
    ("recursive n1 = 3, m1 = 4", dict(n1=3, m1=4)),
    ("taylor1", dict(method="taylor1")),
    ("taylor2", dict(method="taylor2")),
    ("adaptive E = 0.01 %", dict(chord_tol_pct=0.01)),
]
METHODS_REAL = [
    ("constant-du (mean chord D)", None),
    ("recursive n1 = 2", dict(n1=2)),
    ("recursive n1 = 3", dict(n1=3, m1=4)),
    ("taylor1", dict(method="taylor1")),
    ("taylor2", dict(method="taylor2")),
    ("adaptive E = 0.01 %", dict(chord_tol_pct=0.01)),
]


def curves_of(path: Path) -> list[Nurbs]:
    return [e for e in parse_file(path).entities if isinstance(e, Nurbs)]


def row(name: str, s, evals: bool = True) -> str:
    text = f"  {name:28s} steps {s.steps:6d}   max {s.max_dev_pct:9.3f} %   rms {s.rms_dev_pct:8.3f} %"
    if evals:
        ev = s.nurbs_evals
        text += f"   evals/period mean {ev.mean():.2f} max {ev.max()}"
    return text


def chord_plot(curve_studies, step_um: float) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    OUT.mkdir(parents=True, exist_ok=True)
    written = []
    figures = [("fig7_constant_du.png", ["constant-du, du = 0.02"]),
               ("fig8_recursive_n1_2.png", ["recursive n1 = 2, m1 = 3"]),
               ("fig9_recursive_n1_3.png", ["recursive n1 = 3, m1 = 4", "adaptive E = 0.01 %"]),
               ("chords_all_methods.png", [name for name, _ in METHODS_000])]
    for fname, names in figures:
        fig, ax = plt.subplots(figsize=(8, 4))
        for name in names:
            chords_um = np.linalg.norm(np.diff(curve_studies[name].pos_mm, axis=0), axis=1) * 1000
            ax.plot(np.arange(1, len(chords_um) + 1), chords_um, ".-", ms=3, lw=0.8, label=name)
        ax.axhline(step_um, color="k", lw=0.5)
        ax.set_xlabel("step j")
        ax.set_ylabel("chord s_j (um)")
        ax.set_title(f"chord length per step, 000-like curve, D = {step_um:g} um")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(OUT / fname, dpi=110)
        plt.close(fig)
        written.append(OUT / fname)
    return written


def part_a(plots: bool) -> None:
    print(f"(a) 000's experiment on {CURVE000.relative_to(ROOT)}, D = 1 um")
    curve = curves_of(CURVE000)[0]
    geom = (curve.degree, curve.knots, curve.weights, curve.points)
    length = nurbs.arc_length(*geom)
    polygon = np.linalg.norm(np.diff(curve.points, axis=0), axis=1).sum()
    u = np.linspace(curve.knots[0], curve.knots[-1], 200_001)
    radius = 1.0 / nurbs.curvature(*geom, u).max()
    print(f"  curve: length {length:.4f} mm, control polygon {polygon:.4f} mm, tightest radius {radius * 1000:.2f} um")
    d = 0.001
    studies = {}
    for name, opts in METHODS_000:
        studies[name] = s = study([curve], d, **opts)
        print(row(name, s))
    print("  (deviation |chord/D - 1| over every step but the final clamped partial one)")
    n1_3 = studies["recursive n1 = 3, m1 = 4"].max_dev_pct
    print(f"  paper: every chord within 1 +- 0.02 um at n1 = 3; vcnc: max {n1_3:.2f} % "
          f"(bar <= 2 %: {'met' if n1_3 <= 2.0 else 'NOT met'})")
    du01 = d * (u[-1] - u[0]) / polygon  # 000 eq. 12
    s01 = np.linalg.norm(nurbs.curve_points(*geom, np.array([u[0] + du01]))[0] - curve.points[0])
    print(f"  start-up: eq. 12 alone gives a first chord of {s01 * 1000:.3f} um")
    for e_pct in (1.0, 0.1):
        st = make_stepper(curve, n1=2, start_tol_pct=e_pct)
        first = np.linalg.norm(st.advance(np.array([d])).pos_mm[0] - curve.points[0])
        print(f"  start-up search (000 §2.2.1) to e = {e_pct:g} %: {st.startup_evals} curve evaluations "
              f"(the accepted trial is the output point), first chord {first * 1000:.4f} um")
    blu = 0.001
    dense = study([curve], blu / 8, chord_tol_pct=0.01).pos_mm  # the exact curve, finely sampled
    for name in ("recursive n1 = 2, m1 = 3", "recursive n1 = 3, m1 = 4", "adaptive E = 0.01 %"):
        pts = studies[name].pos_mm
        start = np.rint(pts[0] / blu).astype(np.int64)
        path = pulse_path(start, pulses(pts[1:], blu, start))
        at_pos = pulse_deviation_blu(path, dense, blu, segments=False)
        along = pulse_deviation_blu(path, dense, blu, segments=True)
        print(f"  reference pulses, BLU = 1 um, {name}: {len(path) - 1} pulse steps, max distance from the "
              f"curve {at_pos:.3f} BLU at the BLU positions, {along:.3f} BLU along the step segments")
    print("  paper: the pulse path stays within 0.5 BLU of the curve. The 0.5 BLU rule keeps each axis within\n"
          "  0.5 BLU of the point it chases, so the Euclidean distance can reach 0.5*sqrt(2) = 0.71 BLU in a plane")
    if plots:
        for p in chord_plot(studies, 1.0):
            print(f"  wrote {p.relative_to(ROOT)}")


def part_b() -> None:
    print("\n(b) real curves at D = 0.1 mm")
    d = 0.1
    for fname in ("g6_farfalla.ngc", "g6_stella.ngc", "g6_unipa.ngc"):
        path = CORPUS / fname
        if not path.is_file():
            print(f"  {fname}: not found at {path}, skipped")
            continue
        curves = curves_of(path)
        lengths = [nurbs.arc_length(c.degree, c.knots, c.weights, c.points) for c in curves]
        print(f"  {fname}: {len(curves)} NURBS, {sum(lengths):.1f} mm")
        stalls = 0
        for name, opts in METHODS_REAL:
            if opts is None:  # one du per curve: the mean chord is D
                parts = [study([c], d, method="constant-du", du=(c.knots[-1] - c.knots[0]) * d / L)
                         for c, L in zip(curves, lengths)]
                dev = np.concatenate([p.chord_dev for p in parts])
                stalls += sum(p.stalls for p in parts)
                print(f"  {name:30s} steps {sum(p.steps for p in parts):6d}   max {np.abs(dev).max() * 100:9.3f} %"
                      f"   rms {np.sqrt(np.mean(dev**2)) * 100:8.3f} %")
                continue
            s = study(curves, d, **opts)
            stalls += s.stalls
            print(row(name, s).replace(f"  {name:28s}", f"  {name:30s}"))
        adaptive = study(curves, d, chord_tol_pct=0.01)
        ok = adaptive.max_dev_pct <= 0.01 + 1e-9 and adaptive.nurbs_evals.mean() <= 2.5
        print(f"  bar (adaptive: max <= 0.01 % at <= 2.5 evals/period): {'met' if ok else 'NOT met'}; "
              f"periods that stalled or stepped back, all methods: {stalls}")


def throughput_curve() -> Nurbs:
    rng = np.random.default_rng(1)
    n, p = 30, 3
    points = np.cumsum(rng.normal(size=(n, 3)) * 10, axis=0)
    knots = np.r_[[0.0] * p, np.linspace(0, 1, n - p + 1), [1.0] * p]
    return Nurbs(1, p, knots, rng.uniform(0.7, 1.5, n), points, 100.0)


def rate(fn, repeats: int = 3) -> tuple[float, float]:
    """Best (CPU, wall) rate over repeats of fn() -> count."""
    best_cpu = best_wall = 0.0
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        count = fn()
        c1, w1 = time.process_time(), time.perf_counter()
        best_cpu = max(best_cpu, count / max(c1 - c0, 1e-9))
        best_wall = max(best_wall, count / max(w1 - w0, 1e-9))
    return best_cpu, best_wall


def part_c() -> None:
    from geomdl import NURBS

    print("\n(c) throughput, cubic 3-axis NURBS with 30 control points")
    e = throughput_curve()
    length = nurbs.arc_length(e.degree, e.knots, e.weights, e.points)
    d = length / 2_000_000
    steps = np.full(1 << 16, d)
    make_stepper(e, n1=2).advance(steps[:4])  # compile outside the timing

    def run(**opts):
        st = make_stepper(e, **opts)
        k = 0
        while not st.done:
            k += len(st.advance(steps).u)
        return k

    g = NURBS.Curve(normalize_kv=False)
    g.degree, g.ctrlpts, g.weights, g.knotvector = e.degree, e.points.tolist(), e.weights.tolist(), e.knots.tolist()
    us = np.random.default_rng(2).uniform(0, 1, 20_000).tolist()

    def geomdl_points():
        for u in us:
            g.evaluate_single(u)
        return len(us)

    ours_cpu, ours_wall = rate(lambda: run(n1=2))
    geo_cpu, geo_wall = rate(geomdl_points)
    print(f"  recursive n1 = 2: {ours_cpu / 1e6:.2f} M periods/s per CPU second ({ours_wall / 1e6:.2f} M/s wall), "
          "2 curve evaluations per period")
    print(f"  geomdl evaluate_single: {geo_cpu / 1e3:.1f} k points/s per CPU second ({geo_wall / 1e3:.1f} k/s wall)")
    print(f"  ratio periods/s : geomdl points/s = {ours_cpu / geo_cpu:.0f} "
          f"(bar >= 5 M periods/s: {'met' if ours_cpu >= 5e6 else 'NOT met'})")
    for name, opts in (("adaptive E = 0.01 %", dict(chord_tol_pct=0.01)), ("taylor2", dict(method="taylor2"))):
        c, w = rate(lambda: run(**opts), repeats=2)
        print(f"  {name}: {c / 1e6:.2f} M periods/s per CPU second ({w / 1e6:.2f} M/s wall)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    args = ap.parse_args()
    part_a(not args.no_plots)
    part_b()
    part_c()


if __name__ == "__main__":
    main()
