"""Benchmark of the virtual workpiece: removal against the run, memory, and the analytic errors.

Per program, in one process and one machine state: the run bare (plan, interpolate, drive: its wall and
CPU time), then the same run with the Workpiece attached as a drive sink; the removal's own wall and
CPU time are measured inside its `write`, `event` and `surface` (so the ratio removal / bare run is free
of start-up and of the other sinks; the CPU time is the process's, both threads), with the nodes cut per
second of removal (a node lowered by a batch counts once), the envelopes evaluated per period (bounds and
exact ones), and the Z-map's memory (heights float32 + lines int32 + tile maxima) beside the process's
peak RSS. finish_g01 and finish_nurbs cut the
mould panel (programs/make_programs.py: z = sqrt(150^2 - (x-60)^2 - (y-20)^2) - 150
+ 6 exp(-((x-85)^2 + (y-25)^2)/3200)), whose exact surface is the reference: the deviation along the
passes (rows under pass centres) gives the facet depth and spacing; g1_lhchips4 (LinuxCNC corpus, 1/4"
ball) has no reference. Then the analytic cases of machine/workpiece/analytic.py with their errors.

Bar (issue 20): removal wall time <= 2x the run's own wall time on a finishing program.

Usage: python bench/workpiece.py [--quick]   (--quick: the analytic cases only)
"""
from __future__ import annotations

import dataclasses
import math
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
CORPUS = ROOT.parent / "shared" / "corpus" / "linuxcnc"
PANEL_STOCK = "-4,-4,-20,125,44,10"
CHIPS_STOCK = "-8,-8,-40,77,109,0"
RATIO_BAR = 2.0


def panel_z(x, y):
    return np.sqrt(150.0**2 - (x - 60) ** 2 - (y - 20) ** 2) - 150 + 6 * np.exp(-((x - 85) ** 2 + (y - 25) ** 2) / 3200)


def cut(path, config, stock, tool=None, grid_um=None):
    from machine.controller import Controller, start_position
    from machine.workpiece.build import build_workpiece

    bare = Controller(config)
    program = bare.check(path)
    c0 = time.process_time()
    r0 = bare.run(program)
    bare_cpu = time.process_time() - c0
    ctl = Controller(config)
    program = ctl.check(path)
    wp, text = build_workpiece(program, config, start_position(program), stock_text=stock, tool=tool,
                               grid_um=grid_um)
    wp.warm_up()
    ctl.sinks, ctl.on_event = [wp], wp.event
    r1 = ctl.run(program)
    assert r0.state == r1.state == "completed", (r0.fault, r1.fault)
    return r0, bare_cpu, wp, text, wp.surface()


def program_rows(quick: bool) -> None:
    from ipo.config import default_config, load_config
    from machine.workpiece.measure import profile, profile_figures
    from machine.workpiece.zmap import available_cpus

    finish = load_config(ROOT / "programs" / "finish_machine.toml")
    chips = dataclasses.replace(default_config(), tools={1: dataclasses.replace(default_config().tools[1],
                                                                                  ball_radius_mm=3.175,
                                                                                  diameter_mm=6.35)})
    cases = [("finish_g01.nc", ROOT / "programs" / "finish_g01.nc", finish, PANEL_STOCK, 1),
             ("finish_nurbs.nc", ROOT / "programs" / "finish_nurbs.nc", finish, PANEL_STOCK, 1)]
    if (CORPUS / "g1_lhchips4.ngc").exists():
        cases.append(("g1_lhchips4.ngc", CORPUS / "g1_lhchips4.ngc", chips, CHIPS_STOCK, 1))
    else:
        print(f"g1_lhchips4.ngc skipped: {CORPUS} not found")
    print(f"threads: {available_cpus()}")
    print(f"{'program':16s} {'periods':>8s} {'run s':>7s} {'removal s':>9s} {'ratio':>6s} {'run cpu':>7s} "
          f"{'rem cpu':>7s} {'cut/s':>9s} {'env/per':>7s} {'zmap MB':>7s} {'RSS MB':>7s}  bar <= {RATIO_BAR:g}x")
    facet_rows = []
    for name, path, config, stock, tool in cases:
        r0, bare_cpu, wp, text, surf = cut(path, config, stock, tool)
        zmap_mb = (wp.z.nbytes + wp.line.nbytes + wp._tile_max.nbytes) / 2**20
        rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"{name:16s} {r0.periods:8d} {r0.wall_s:7.2f} {wp.wall_s:9.2f} {wp.wall_s / r0.wall_s:6.2f} "
              f"{bare_cpu:7.2f} {wp.cpu_s:7.2f} {wp.nodes_lowered / wp.wall_s:9.3g} "
              f"{wp.nodes_evaluated / r0.periods:7.0f} {zmap_mb:7.1f} {rss_mb:7.0f}  ({text.splitlines()[0]})")
        for note in text.splitlines()[1:]:  # the workpiece's warnings (a tip starting inside the stock)
            print(f"{'':16s} {note}")
        if name.startswith("finish"):
            ref = panel_z(*np.meshgrid(surf.x_mm, surf.y_mm))
            figs = [profile_figures(*profile(surf, "x", y, 10.0, 110.0, ref), form_removed=True)
                    for y in np.arange(2.0, 38.01, 4.0)]  # pass centres: Y = 0.2 k
            dev = (surf.z_mm - ref)[(surf.y_mm > 1) & (surf.y_mm < 39)][:, (surf.x_mm > 10) & (surf.x_mm < 110)]
            facet_rows.append((name, figs, float(np.min(dev) * 1e3), float(np.max(dev) * 1e3)))
    print("\nalong the passes, deviation from the panel's exact surface (rows Y = 2, 6, ..., 38 over X 10..110), "
          "medians over the rows:")
    print(f"{'program':16s} {'facets':>6s} {'spacing mm':>10s} {'depth um':>8s} {'Rz um':>7s} {'Ra um':>7s} "
          f"{'dev min um':>10s} {'dev max um':>10s}")
    for name, figs, lo, hi in facet_rows:
        def med(key):
            vals = [getattr(f, key) for f in figs if getattr(f, key) is not None]
            return float(np.median(vals)) if vals else float("nan")
        print(f"{name:16s} {med('facets'):6.0f} {med('facet_spacing_mm'):10.3f} {med('facet_depth_um'):8.3f} "
              f"{med('rz_um'):7.3f} {med('ra_um'):7.3f} {lo:10.3f} {hi:10.3f}")


def analytic_rows() -> None:
    from ipo.config import default_config
    from machine.workpiece.analytic import (BOWL_STOCK, bowl_deviation, bowl_nurbs_program, bowl_polygon_program,
                                            bowl_sagitta_mm, raster_program)
    from machine.workpiece.measure import classical_scallop_mm

    config = default_config()
    flat_blend = dataclasses.replace(config, g64_blend_tol_mm=0.0)
    print("\nanalytic cases (ball r = 3 mm):")
    with tempfile.TemporaryDirectory() as tmp:
        def run(text, stock, grid_um, cfg=config):
            p = Path(tmp) / "p.nc"
            p.write_text(text)
            return cut(p, cfg, stock, grid_um=grid_um)[4]

        for s_mm, g_um in ((0.5, 5.0), (0.2, 5.0), (0.5, 20.0)):
            surf = run(raster_program(s_mm, 9, 8.0, 1.0, 3000.0), "0,0,-5,8,6,0", g_um)
            ix, iy = (surf.x_mm > 3) & (surf.x_mm < 5), (surf.y_mm >= 1 + 2 * s_mm) & (surf.y_mm <= 1 + 6 * s_mm)
            z = surf.z_mm[np.ix_(iy, ix)]
            got, want = float(np.median(z.max(axis=0) - z.min(axis=0))), classical_scallop_mm(3.0, s_mm)
            bound = (s_mm / 2) / 3.0 * g_um / 2000
            print(f"  raster s = {s_mm} mm, grid {g_um:g} um: scallop {got * 1e3:.4f} um, classical {want * 1e3:.4f} um,"
                  f" error {(got - want) * 1e3:+.4f} um (sampling bound {bound * 1e3:.4f} um)")
        for n in (17, 40):
            _, dev = bowl_deviation(run(bowl_polygon_program(n), BOWL_STOCK, 10.0, flat_blend), 3.0)
            sag = bowl_sagitta_mm(n)
            print(f"  bowl as {n} G01 chords: deepest facet {dev.max() * 1e3:.3f} um, sagitta {sag * 1e3:.3f} um, "
                  f"error {(dev.max() - sag) * 1e3:+.3f} um; at the vertices {dev.min() * 1e3:+.3f} um")
        _, dev = bowl_deviation(run(bowl_nurbs_program(), BOWL_STOCK, 10.0), 3.0)
        print(f"  bowl as one rational G06.2: deviation {dev.min() * 1e3:+.3f} .. {dev.max() * 1e3:+.3f} um "
              f"(floor: BLU {config.blu_mm * 1e3:g} um + chord tolerance {config.chord_tol_mm * 1e3:g} um)")


def main() -> None:
    quick = "--quick" in sys.argv
    if not quick:
        program_rows(quick)
    analytic_rows()


if __name__ == "__main__":
    main()
