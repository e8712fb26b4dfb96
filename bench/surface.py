"""Benchmark of issue 8: digitised points -> rational sections -> skinned surface -> IGES -> finishing.

    python bench/surface.py

Prints: fit error against control-point count, rational and non-rational (weights fixed
at 1), for 001's figure (14 points of one section) and for whole families of sections
(cylinder arcs, saddle, bump, noise-free and with 5 um noise); 001's 14-point /
8-control-point fit with f_l after every iteration; section-fit, skinning, IGES export
and read times on a large digitisation, with the surface evaluation timed against
geomdl in the same run; the IGES round-trip error (own reader, and pyiges + geomdl);
C0 against C1 merging; and the finishing toolpath of the bump.
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from ipo.surface.iges import RationalCurve, read_surfaces, write_iges  # noqa: E402
from ipo.fit.rational import fit_rational  # noqa: E402
from ipo.surface.section_fit import fit_sections, fit_shared, section_error  # noqa: E402
from ipo.surface.skinning import deviation_from_points, skin_patches  # noqa: E402
from ipo.surface.evaluation import grid, surface_points  # noqa: E402
from ipo.surface.toolpath import ToolpathSettings, plan_passes, program_text  # noqa: E402
from surface_cases import bump, cylinder, geomdl_surface, saddle  # noqa: E402


def um(x: float) -> str:
    return f"{x * 1e3:9.3f}"


def counts_table() -> None:
    print("== fit error (um) against control points per section: rational | non-rational (weights 1)")
    q = bump(0.005, n_points=14).sections[5]
    print("001 figure data: one section of 14 points (bump, 5 um noise); max | rms")
    print(f"{'m':>3} {'rat max':>9} {'rat rms':>9} | {'poly max':>9} {'poly rms':>9}")
    for m in range(4, 15):
        a = fit_rational(q, m, 3)
        b = fit_rational(q, m, 3, rational=False)
        print(f"{m:>3} {um(section_error(a, q))} {um(a.rms_history.min())} | "
              f"{um(section_error(b, q))} {um(b.rms_history.min())}")
    cases = [cylinder(), saddle(), bump(), cylinder(0.005), saddle(0.005), bump(0.005)]
    print("families of sections (shared weights); worst section's max error")
    print(f"{'m':>3} " + " ".join(f"{c.name + (' noisy' if k > 2 else ''):>25}" for k, c in enumerate(cases)))
    for m in (4, 5, 6, 7, 8, 10, 12, 14):
        row = []
        for c in cases:
            a = fit_shared(c.sections, m).max_error_mm.max()
            b = fit_shared(c.sections, m, rational=False).max_error_mm.max()
            row.append(f"{um(a)} |{um(b)}   ")
        print(f"{m:>3} " + " ".join(row))


def paper_figure() -> None:
    q = bump(0.005, n_points=14).sections[5]
    fit = fit_rational(q, 8, 3, max_iter=60)
    print("\n== 001 Fig. 3: 14 points, 8 control points, f_l (um) after each iteration (App. I step 5)")
    print(" ".join(f"{f * 1e3:.3f}" for f in fit.rms_history))
    print(f"iterations {len(fit.rms_history)}, converged {fit.converged}, weights {np.round(fit.weights, 3)}")
    family = fit_shared(bump(0.005, n_points=14).sections, 8, max_iter=60)
    print("all 11 sections of 14 points, 8 control points, shared weights: f_l (um) per iteration")
    print(" ".join(f"{f * 1e3:.3f}" for f in family.rms_history))
    print(f"iterations {len(family.rms_history)}, converged {family.fits[0].converged}, "
          f"worst section max error {um(family.max_error_mm.max())} um")


def timings() -> None:
    print("\n== times on a large digitisation (bump, 41 sections x 60 points, 5 um noise, tol 20 um)")
    case = bump(0.005, n_sections=41, n_points=60)
    t0 = time.perf_counter()
    fits = fit_sections(case.sections, tol_mm=0.02)
    t1 = time.perf_counter()
    res = skin_patches(fits.fits)
    t2 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bump.igs"
        curves = [RationalCurve(f.degree, f.knots, f.weights, f.points) for f in fits.fits]
        write_iges(path, [res.surface], curves)
        t3 = time.perf_counter()
        back = read_surfaces(path)[0]
        t4 = time.perf_counter()
        size = path.stat().st_size
        pyiges_err = _pyiges_round_trip(path, res.surface)
    surf = res.surface
    print(f"section fits   {t1 - t0:8.3f} s  ({fits.n_ctrl} control points, rational {fits.rational})")
    print(f"skinning       {(t2 - t1) * 1e3:8.3f} ms ({surf.weights.shape[0]} x {surf.weights.shape[1]} net)")
    print(f"IGES export    {(t3 - t2) * 1e3:8.3f} ms ({size} bytes, 1 surface + {len(curves)} curves)")
    print(f"IGES read      {(t4 - t3) * 1e3:8.3f} ms (own reader)")
    dev = deviation_from_points(surf, fits.fits, case.sections, res.section_v)
    truth = case.error_to_truth(surface_points(surf, *grid(surf, 200, 200)))
    print(f"deviation from the input points max {um(dev.max())} um; from the true surface max {um(truth.max())} um, "
          f"rms {um(np.sqrt(np.mean(truth**2)))} um")
    u, v = grid(surf, 100, 100)
    t5 = time.perf_counter()
    pts = surface_points(surf, u, v)
    t6 = time.perf_counter()
    from geomdl import NURBS
    g = NURBS.Surface()
    g.degree_u, g.degree_v = surf.degree_u, surf.degree_v
    g.ctrlpts_size_u, g.ctrlpts_size_v = surf.weights.shape
    g.ctrlptsw = surf.homogeneous.reshape(-1, 4).tolist()
    g.knotvector_u = list(surf.knots_u / surf.knots_u[-1])
    g.knotvector_v = list(surf.knots_v / surf.knots_v[-1])
    sub = slice(0, 2000)
    t7 = time.perf_counter()
    ref = np.array(g.evaluate_list(list(zip(u[sub] / surf.knots_u[-1], v[sub] / surf.knots_v[-1]))))
    t8 = time.perf_counter()
    ours_us = (t6 - t5) / len(u) * 1e6
    ref_us = (t8 - t7) / 2000 * 1e6
    print(f"S(u,v) eq. 16: {ours_us:.2f} us/point vectorised, geomdl {ref_us:.2f} us/point "
          f"({ref_us / ours_us:.0f}x), max difference {np.abs(ref - pts[sub]).max():.1e} mm")
    print("\n== IGES round trip (max point difference over a 100 x 100 grid)")
    print(f"own reader       {np.abs(surface_points(back, u, v) - pts).max():.1e} mm")
    print(f"pyiges + geomdl  {pyiges_err:.1e} mm")


def _pyiges_round_trip(path, surf) -> float:
    import pyiges
    b = pyiges.read(str(path)).bspline_surfaces()[0]
    g = geomdl_surface(b)
    u, v = grid(surf, 40, 40)
    ref = np.array(g.evaluate_list(list(zip(u / b.knot1[-1], v / b.knot2[-1]))))
    return float(np.abs(ref - surface_points(surf, u, v)).max())


def merging() -> None:
    print("\n== patch merging (bump, 5 um noise, 11 sections, patches of 5 sections): 001 eq. 17 / 18")
    case = bump(0.005)
    fits = fit_sections(case.sections, tol_mm=0.02)
    for cont in ("C0", "C1"):
        res = skin_patches(fits.fits, 5, cont)
        dev = deviation_from_points(res.surface, fits.fits, case.sections, res.section_v)
        truth = case.error_to_truth(surface_points(res.surface, *grid(res.surface, 120, 120)))
        print(f"{cont}: {len(res.patches)} patches, deviation from input points max {um(dev.max())} um, "
              f"from the true surface max {um(truth.max())} um")


def finishing() -> None:
    print("\n== finishing passes over the bump (r 3 mm, pick 1 mm, tolerance 5 um)")
    case = bump(0.005)
    surf = skin_patches(fit_sections(case.sections, tol_mm=0.02).fits).surface
    settings = ToolpathSettings(3.0, 1.0, 0.005, 3000, 12500)
    t0 = time.perf_counter()
    passes = plan_passes(surf, settings)
    t1 = time.perf_counter()
    text = program_text(passes, settings, "bump")
    ctrl = [len(f.points) for p in passes for f in p.pieces]
    print(f"passes {len(passes)}, G06.2 groups {len(ctrl)}, control points {sum(ctrl)} "
          f"(per group {min(ctrl)}..{max(ctrl)}), blocks {text.count(chr(10))}")
    print(f"max | distance to surface - r | {um(max(p.deviation_mm for p in passes))} um, "
          f"planning {t1 - t0:.2f} s")


if __name__ == "__main__":
    counts_table()
    paper_figure()
    timings()
    merging()
    finishing()
