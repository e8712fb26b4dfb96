"""The virtual workpiece against analytic results: scallops, plunges, slots, chord facets."""
from __future__ import annotations

import dataclasses
import itertools
import json
import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from ipo.config import Tool, default_config
from machine.controller import Controller, start_position
from machine.workpiece.analytic import (BOWL_STOCK, bowl_deviation, bowl_nurbs_program, bowl_polygon_program,
                                        raster_program)
from machine.workpiece.build import build_workpiece
from machine.workpiece.figures import RASTER_KEYS, format_rows, surface_figures
from machine.workpiece.envelope import envelope
from machine.workpiece.removal import cut as cut_batch
from machine.workpiece.tiles import COUNTS, TILE, Batch, ZMap
from machine.workpiece.measure import profile_figures
from machine.workpiece import removal, zmap

F32_MM = 2e-6  # the heights are stored in float32: 1 nm steps at these heights, 2 nm allowed


def cut(tmp_path, text: str, stock: str, grid_um: float, *, tools=None, tool=None, **machine):
    """Run `text` in the controller with a workpiece attached; the machined Surface."""
    config = dataclasses.replace(default_config(), **machine)
    if tools is not None:
        config = dataclasses.replace(config, tools=tools)
    path = tmp_path / "p.nc"
    path.write_text(text)
    ctl = Controller(config)
    program = ctl.check(path)
    wp, _ = build_workpiece(program, config, start_position(program), stock_text=stock, tool=tool,
                            grid_um=grid_um)
    ctl.sinks = [wp]
    ctl.on_event = wp.event
    result = ctl.run(program)
    assert result.state == "completed", result.fault
    return wp.surface()


@pytest.mark.slow
def test_envelope_is_the_minimum_over_the_segment():
    """Closed forms (ball, flat) and the bisection (bull) against a dense sampling of t."""
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 100001)
    for core, corner in ((0.0, 3.0), (2.0, 0.0), (1.5, 1.0)):
        radius = core + corner
        for _ in range(60):
            p0 = rng.uniform(-1, 1, 3)
            p1 = p0 + rng.normal(0, 1, 3) * rng.choice([0.01, 0.3, 3.0])
            q = p0[:2] + rng.uniform(-radius - 0.5, radius + 0.5, 2)
            xy = p0[:2] + t[:, None] * (p1[:2] - p0[:2])
            rho = np.hypot(*(q - xy).T)
            d = rho - core
            h = np.where(rho <= core, 0.0, np.where(d > corner, np.inf,
                                                    corner - np.sqrt(np.maximum(corner**2 - d**2, 0.0))))
            g = p0[2] + t * (p1[2] - p0[2]) + h
            ref = np.min(g)
            got, t_got = envelope(q[0], q[1], *p0, *p1, core, corner)
            if np.isinf(ref):
                assert np.isinf(got) or got >= p0[2] - 1e-9  # a grazing touch between samples
                continue
            assert ref - 2e-4 <= got <= ref + 1e-12
            # and it is reached at t_got
            rho_t = np.hypot(*(q - p0[:2] - t_got * (p1[:2] - p0[:2])))
            h_t = 0.0 if rho_t <= core else corner - math.sqrt(max(corner**2 - (rho_t - core) ** 2, 0.0))
            assert p0[2] + t_got * (p1[2] - p0[2]) + h_t == pytest.approx(got, abs=1e-9)


@pytest.mark.slow
def test_ball_raster_leaves_the_classical_scallop(tmp_path):
    r, s, g_um = 3.0, 0.5, 5.0
    surf = cut(tmp_path, raster_program(s, 9, 8.0, 1.0, 3000.0), "0,0,-5,8,6,0", g_um)
    ix = (surf.x_mm > 3) & (surf.x_mm < 5)
    iy = (surf.y_mm >= 2.0) & (surf.y_mm <= 4.0)
    z = surf.z_mm[np.ix_(iy, ix)]
    h = r - math.sqrt(r * r - (s / 2) ** 2)  # the classical scallop
    measured = float(np.median(z.max(axis=0) - z.min(axis=0)))
    # the cusp lies within g/2 of a node, where the surface's slope is (s/2)/r
    assert abs(measured - h) <= (s / 2) / r * (g_um / 2000) + F32_MM, (measured, h)
    assert np.allclose(z.min(), -1.0, atol=F32_MM)
    # the same through the measurement: the scallop across the passes and their spacing
    figs = surface_figures(surf, feed_axis="x")
    assert figs["pass_spacing_mm"] == pytest.approx(s, abs=g_um / 1000)
    assert abs(figs["scallop_um"] / 1e3 - h) <= (s / 2) / r * (g_um / 2000) + F32_MM
    assert figs["classical_scallop_um"] == pytest.approx(h * 1e3, rel=1e-3)


def test_a_slot_is_not_measured_as_a_finished_surface(tmp_path):
    # a 3 mm ball 1 mm deep cuts where |y - 5| < sqrt(r^2 - (r - 1)^2): 4.47 mm of the window's 8 (y 1..9)
    surf = cut(tmp_path, "G21 G90 G94 T1 M6\nG0 X1 Y5 Z1\nG1 Z-1 F300\nG1 X9\nG0 Z5\nM2\n", "0,0,-3,10,10,0", 100.0)
    figs = surface_figures(surf, feed_axis="x")
    assert figs["machined_pct"] == pytest.approx(100 * 2 * math.sqrt(5.0) / 8.0, abs=100 * 0.1 / 8.0)
    assert all(figs[key] is None for key in RASTER_KEYS) and "not machined all over" in figs["note"]
    assert "note (slot)" in format_rows({"slot": figs})


def test_without_a_stock_the_error_says_where_the_program_cuts(tmp_path):
    from machine.workpiece.stock import StockError

    # a full circle of r 5 about (10, 10) at Z-1 (its extremes 5..15 are not its ends), a line to X20;
    # work zero at machine (100, 50, -20), T2 (ball r 2) 30 mm long and compensated (G43 H2): the tip is where written
    text = "G21 G90 G94 T2 M6 G43 H2\nG0 X15 Y10 Z5\nG1 Z-1 F300\nG2 X15 Y10 I-5 J0\nG1 X20 Y12\nG0 Z5\nM2\n"
    config = dataclasses.replace(default_config(), tools={2: Tool(length_mm=30.0, ball_radius_mm=2.0)},
                                 work_offsets_mm={"G54": (100.0, 50.0, -20.0)})
    path = tmp_path / "p.nc"
    path.write_text(text)
    program = Controller(config).check(path)
    with pytest.raises(StockError) as err:
        build_workpiece(program, config, start_position(program))
    assert "tip over X5.000..20.000 Y5.000..15.000 Z-1.000..5.000 (work)" in str(err.value)
    assert "--stock=3.000,3.000,-2.000,22.000,17.000,ZMAX" in str(err.value)


def test_flat_plunge_leaves_its_exact_disc(tmp_path):
    tools = {2: Tool(shape="flat", diameter_mm=4.0, flutes=2)}
    text = "G21 G90 G94 T2 M6\nG0 X5 Y5 Z1\nG1 Z-2 F300\nG0 Z5\nM2\n"
    surf = cut(tmp_path, text, "0,0,-5,10,10,0", 20.0, tools=tools)
    X, Y = np.meshgrid(surf.x_mm, surf.y_mm)
    rho = np.hypot(X - 5, Y - 5)
    clear = np.abs(rho - 2.0) > 1e-6
    assert np.all(surf.z_mm[(rho < 2.0) & clear] == -2.0)
    assert np.all(surf.z_mm[(rho > 2.0) & clear] == 0.0)
    assert set(np.unique(surf.line[rho < 2.0])) == {3}


@pytest.mark.slow
def test_slot_at_constant_depth_has_the_tool_width(tmp_path):
    tools = {3: Tool(shape="flat", diameter_mm=4.0, flutes=2), 1: Tool(ball_radius_mm=3.0)}
    text = "G21 G90 G94 T3 M6\nG0 X2 Y5 Z1\nG1 Z-1 F1200\nX8\nG0 Z5\nT1 M6\nG0 X2 Y12\nG1 Z-1\nX8\nG0 Z5\nM2\n"
    g_mm = 0.01
    surf = cut(tmp_path, text, "0,0,-5,10,16,0", g_mm * 1000, tools=tools)
    col = surf.z_mm[:, np.argmin(np.abs(surf.x_mm - 5.0))]
    flat = (surf.y_mm < 9) & (col < 0)
    assert abs(np.count_nonzero(flat) * g_mm - 4.0) <= g_mm
    assert np.all(col[flat] == -1.0)
    # the ball's slot 1 mm deep: width 2 sqrt(2 r d - d^2)
    ball = (surf.y_mm > 9) & (col < 0)
    assert abs(np.count_nonzero(ball) * g_mm - 2 * math.sqrt(2 * 3.0 * 1.0 - 1.0)) <= g_mm


@pytest.mark.slow
def test_g01_polygon_of_a_circle_leaves_facets_of_its_sagitta(tmp_path):
    n = 17
    sagitta_mm = 20.0 * (1 - math.cos(math.pi / 3 / n / 2))  # the bowl: 60 degrees of a 20 mm circle
    surf = cut(tmp_path, bowl_polygon_program(n), BOWL_STOCK, 10.0, g64_blend_tol_mm=0.0)
    x, dev = bowl_deviation(surf, 3.0)
    # BLU rounding of the commanded positions moves the swept segments by up to ~0.7 um
    assert abs(dev.max() - sagitta_mm) <= 1e-3, (dev.max(), sagitta_mm)
    assert abs(dev.min()) <= 1e-3
    fig = profile_figures(x, dev, form_removed=True)
    assert fig.facet_depth_um == pytest.approx(sagitta_mm * 1e3, abs=1.0)
    # each vertex prints where the ball's radius through it meets the surface: the chords' angle on a circle
    # of radius rho + r, projected on X (cos of at most 30 degrees - 3 mm margin)
    arc_mm = (20.0 + 3.0) * math.pi / 3 / n
    assert arc_mm * math.cos(math.pi / 6) - 0.02 <= fig.facet_spacing_mm <= arc_mm + 0.02


def test_the_same_circle_as_nurbs_leaves_no_facets(tmp_path):
    surf = cut(tmp_path, bowl_nurbs_program(), BOWL_STOCK, 10.0)
    _, dev = bowl_deviation(surf, 3.0)
    config = default_config()
    floor_mm = config.blu_mm + config.chord_tol_mm  # BLU rounding and the per-period chords
    assert dev.max() - dev.min() <= floor_mm, (dev.min(), dev.max())


def test_the_period_rows_carry_the_spindle_angle(tmp_path):
    from machine.trace import MemoryTrace

    path = tmp_path / "s.nc"
    path.write_text("G21 G90 G94 G0 X0 Y0 Z1\nS12500 M3\nG1 X5 F600\nM5\nG1 X6\nM4 S6000\nG1 X7\nM2\n")
    sink = MemoryTrace({})
    ctl = Controller(default_config(), sinks=[sink])
    ctl.run(ctl.check(path))
    tr = sink.close()
    step = np.diff(np.unwrap(tr["spindle_rad"]))
    line = tr["line"][1:]
    period_s = default_config().period_s
    assert np.allclose(step[line == 3], 2 * math.pi * 12500 / 60 * period_s)
    assert np.allclose(step[line == 5], 0.0)
    assert np.allclose(step[line == 7], -2 * math.pi * 6000 / 60 * period_s)


def test_saved_heights_are_the_zmaps_float32_values_stored_losslessly(tmp_path):
    import zipfile

    from machine.workpiece.surface_file import load_npz, save_npz
    from machine.workpiece.zmap import Surface

    z = np.float32([[-1.0, 0.1], [1e-7, 15.999999]]).astype(np.float64)  # float32 values, none a round float64
    line = np.int32([[3, 3], [0, 7]])
    surface = Surface(np.array([0.0, 0.05]), np.array([1.0, 1.05]), z, line, {"grid_mm": 0.05})
    save_npz(surface, tmp_path / "s.npz")
    back, gouge = load_npz(tmp_path / "s.npz")
    assert back.z_mm.dtype == np.float64 and np.array_equal(back.z_mm, z) and np.array_equal(back.line, line)
    assert not gouge.any() and back.meta == {"grid_mm": 0.05}
    with zipfile.ZipFile(tmp_path / "s.npz") as archive:
        assert archive.getinfo("z_mm.npy").compress_type == zipfile.ZIP_STORED
    with np.load(tmp_path / "s.npz") as data:
        assert data["z_mm"].dtype == np.float32
    surface.z_mm[0, 1] = 0.1  # not a float32 value: refused, not rounded
    with pytest.raises(ValueError, match="float32"):
        save_npz(surface, tmp_path / "t.npz")


def test_run_writes_the_surface_files(tmp_path):
    from click.testing import CliRunner

    from machine.cli import main
    from machine.workpiece.surface_file import load_npz

    prog = tmp_path / "plunge.nc"
    prog.write_text("G21 G90 G94 T1 M6\nG0 X5 Y5 Z1\nG1 Z-1 F300\nG0 Z5\nM2\n")
    out, stl = tmp_path / "s.npz", tmp_path / "s.stl"
    res = CliRunner().invoke(main, ["run", str(prog), "--stock", "0,0,-3,10,10,0", "--grid-um", "100",
                                    "--surface", str(out), "--surface", str(stl), "--json"])
    assert res.exit_code == 0, res.output
    surf, gouge = load_npz(out)
    assert surf.z_mm.shape == (len(surf.y_mm), len(surf.x_mm)) == (101, 101) and gouge.shape == surf.z_mm.shape
    assert surf.z_mm.min() == pytest.approx(-1.0, abs=F32_MM)  # the ball's tip
    i = np.argmin(np.abs(surf.x_mm - 7.0))  # 2 mm off the axis: r - sqrt(r^2 - 4) above the tip
    assert surf.z_mm[np.argmin(np.abs(surf.y_mm - 5.0)), i] == pytest.approx(-1 + 3 - math.sqrt(5), abs=F32_MM)
    assert stl.stat().st_size == 84 + 50 * 2 * 100 * 100
    bad = CliRunner().invoke(main, ["run", str(prog), "--stock", "0,0,-3,10,10", "--surface", str(out)])
    assert bad.exit_code == 2 and "six" in bad.output
    no_stock = CliRunner().invoke(main, ["run", str(prog), "--surface", str(out)])
    assert no_stock.exit_code == 2 and "no stock" in no_stock.output and "no axis moved" in no_stock.output


def test_compare_cuts_both_programs_and_differs_by_the_facets(tmp_path):
    from click.testing import CliRunner

    from machine.cli import main

    a, b, machine = tmp_path / "g01.nc", tmp_path / "nurbs.nc", tmp_path / "m.toml"
    a.write_text(bowl_polygon_program(17))
    b.write_text(bowl_nurbs_program())
    default = Path(__file__).resolve().parents[2] / "programs" / "machine.toml"
    machine.write_text(default.read_text().replace("g64_blend_tol_mm = 0.01", "g64_blend_tol_mm = 0.0"))
    png = tmp_path / "pair.png"
    res = CliRunner().invoke(main, ["compare", str(a), str(b), "--machine", str(machine), "--stock", BOWL_STOCK,
                                    "--grid-um", "20", "--surface-plot", str(png), "--json"])
    assert res.exit_code == 0, res.output
    diff = json.loads(res.stdout)["surfaces"]["difference_um"]["max_abs"]
    sagitta_um = 20.0 * (1 - math.cos(math.pi / 3 / 17 / 2)) * 1e3
    # radial sagitta seen vertically on a bowl sloping up to 30 degrees, plus the BLU floor of both
    assert sagitta_um - 1.0 <= diff <= sagitta_um / math.cos(math.pi / 6) + 2.0
    assert png.stat().st_size > 10_000


def test_surface_report_flags_the_gouging_line_against_an_iges_reference(tmp_path):
    """A plane z = -1 + 0.05 x as a tilted bilinear IGES patch; the raster follows it, but one pass dips
    0.2 mm: the report names that pass's line and the depth, computed here from the geometry."""
    from click.testing import CliRunner

    from ipo.surface.evaluation import RationalSurface
    from ipo.surface.iges import write_iges
    from machine.cli import main

    pts = np.array([[[-1.0, -1.0, -1.05], [-1.0, 7.0, -1.05]], [[9.0, -1.0, -0.55], [9.0, 7.0, -0.55]]])
    write_iges(tmp_path / "plane.igs", [RationalSurface(1, 1, np.array([0, 0, 1, 1.0]), np.array([0, 0, 1, 1.0]),
                                                        np.ones((2, 2)), pts)])
    lines = ["G21 G90 G94 G64 T1 M6 S10000 M3", "G0 X0 Y1 Z1", "G1 Z-1 F3000"]
    for k in range(9):
        dip = 0.2 if k == 4 else 0.0
        x_end = 8.0 if k % 2 == 0 else 0.0
        lines += [f"G1 X{x_end:g} Y{1 + 0.5 * k:g} Z{-1 + 0.05 * x_end - dip:g}"]  # line 4 + 2k
        if k < 8:
            lines += [f"G1 Y{1.5 + 0.5 * k:g}"]
    prog = tmp_path / "g.nc"
    prog.write_text("\n".join(lines + ["G0 Z5", "M2", ""]))
    out = tmp_path / "g.npz"
    res = CliRunner().invoke(main, ["run", str(prog), "--stock", "0,0,-3,8,6,0", "--grid-um", "50",
                                    "--surface", str(out), "--json"])
    assert res.exit_code == 0, res.output
    # a ball whose tip follows a plane of slope 0.05 sinks r (1 - cos a) = 3.7 um into it: below 10 um
    rep = CliRunner().invoke(main, ["surface-report", str(out), "--reference", str(tmp_path / "plane.igs"),
                                    "--gouge-tol-um", "10", "--json"])
    assert rep.exit_code == 0, rep.output
    figs = json.loads(rep.stdout)
    gouging = {g["line"] for g in figs["gouges"]}
    # the dipping pass (line 12) ramps down from X0 to 0.2 mm below at X8, where the step-over (13) and
    # the next pass (14, ramping back up) continue from that depth: only those lines gouge
    assert 12 in gouging and gouging <= {12, 13, 14}
    worst = figs["gouges"][0]
    sink_um = 3.0 * (1 - math.cos(math.atan(0.05))) * 1e3
    assert 150.0 < worst["depth_um"] <= 200.0 + sink_um + 1.0 and worst["x_mm"] > 7.0
    assert figs["deviation_min_um"] == pytest.approx(-worst["depth_um"], abs=1e-6)


@njit(cache=True)
def _every_segment_at_every_node(z, line, origin, grid_mm, floor_mm, pos, lines, core, corner, stamp_first):
    """One batch by the Z-map's definition, evaluated exhaustively: each node takes the lowest envelope of
    any segment (floored) if below its height, from the first segment in program order reaching it."""
    ny, nx = z.shape
    for j in range(ny):
        for i in range(nx):
            best, k_best = np.float64(z[j, i]), -1
            for k in range(pos.shape[0] - 1):
                if not (stamp_first and k == 0) and pos[k, 0] == pos[k + 1, 0] and pos[k, 1] == pos[k + 1, 1] \
                        and pos[k, 2] == pos[k + 1, 2]:
                    continue
                v = max(envelope(origin[0] + i * grid_mm, origin[1] + j * grid_mm, pos[k, 0], pos[k, 1], pos[k, 2],
                                 pos[k + 1, 0], pos[k + 1, 1], pos[k + 1, 2], core, corner)[0], floor_mm)
                if v < best:
                    best, k_best = v, k
            if k_best >= 0:
                z[j, i] = best
                line[j, i] = lines[k_best]


def _paths(rng):
    """Tool paths at 1 um BLU: a zig-zag raster over a tilted wavy surface (chords along the passes), a
    random walk, a plunge and a dwell, level passes of equal depth (exact ties) and a dive through the
    stock's bottom."""
    paths = []
    pts = []
    for k in range(5):
        x = np.linspace(0.0, 6.0, 40)[:: 1 if k % 2 == 0 else -1]
        xs = np.concatenate([np.linspace(x[m], x[m + 1], 9)[:-1] for m in range(len(x) - 1)] + [x[-1:]])
        pts.append(np.column_stack([xs, np.full_like(xs, 1.0 + 0.3 * k), 0.1 * xs + 0.05 * np.sin(2 * xs) - 1.0]))
    paths.append(np.vstack(pts))
    paths.append(np.cumsum(rng.normal(0, 0.05, (400, 3)), axis=0) + [3.0, 2.5, -1.0])
    plunge = np.column_stack([np.full(30, 2.0), np.full(30, 2.0), np.linspace(0.5, -1.5, 30)])
    paths.append(np.vstack([plunge, np.repeat(plunge[-1:], 5, axis=0)]))
    paths.append(np.vstack([np.column_stack([np.linspace(0.5, 5.5, 60), np.full(60, y), np.full(60, -0.8)])
                            for y in (2.0, 2.5, 2.5)]))
    paths.append(np.column_stack([np.linspace(0.0, 6.0, 80), np.linspace(1.0, 4.0, 80), np.linspace(0.0, -6.0, 80)]))
    return [np.round(p, 3) for p in paths]


# radii off the 1 um grid of the paths: no node lies exactly on a rim (where rounding decides a tangency)
@pytest.mark.parametrize("core, corner", [(0.0, 1.5013), (1.0013, 0.0), (0.6013, 0.5)])
def test_the_update_is_every_segment_at_every_node(core, corner, monkeypatch):
    """removal.cut (runs, bounds, tiles, threads) against the exhaustive definition, in two batches; also with
    the number of threads changing between chunks of blocks, as when the run ends in the middle of a batch,
    which gives the same bits as one thread, lines included (the threads take blocks that share no node)."""
    monkeypatch.setattr(removal, "CHUNK_BLOCKS", 2)
    rng = np.random.default_rng(11)
    grid_mm, origin, floor_mm = 0.05, (0.0, 0.0), -2.0
    for path in _paths(rng):
        lines = np.arange(1, len(path), dtype=np.int32)
        half = len(path) // 2
        batches = ((path[:half + 1], lines[:half], True), (path[half:], lines[half:], False))
        want_z = np.zeros((90, 130), np.float32)
        want_line = np.zeros(want_z.shape, np.int32)
        for pos, pos_lines, stamp in batches:
            _every_segment_at_every_node(want_z, want_line, origin, grid_mm, floor_mm, pos, pos_lines, core, corner,
                                         stamp)
        serial = None
        for threads in (1, 2, itertools.cycle((1, 2, 2, 1)).__next__):
            z = np.zeros(want_z.shape, np.float32)
            line = np.zeros(z.shape, np.int32)
            tile_max = np.zeros((-(-z.shape[0] // TILE), -(-z.shape[1] // TILE)))
            counts = np.zeros(COUNTS, np.int64)
            for pos, pos_lines, stamp in batches:
                cut_batch(ZMap(z, line, tile_max, *origin, grid_mm, floor_mm),
                          Batch(pos, pos_lines, core, corner, stamp), counts, threads)
            serial = (z, line) if serial is None else serial
            assert np.array_equal(z, serial[0]) and np.array_equal(line, serial[1])
            assert np.array_equal(z, want_z)
            # a node's line names a segment that cut it to its height: the reference's, or one whose
            # envelope there is the same to float64 rounding (the two ends of a joint, level passes)
            assert np.array_equal(line > 0, want_line > 0)
            for j, i in np.argwhere(line != want_line):
                mine, theirs = (envelope(i * grid_mm, j * grid_mm, *path[n - 1], *path[n], core, corner)[0]
                                for n in (line[j, i], want_line[j, i]))
                assert max(mine, floor_mm) == pytest.approx(max(theirs, floor_mm), abs=1e-12)


@pytest.mark.parametrize("core, corner", [(1.0013, 0.0), (0.6013, 0.4)])
def test_sloped_passes_leave_every_segment_at_every_node(core, corner):
    """A flat (and a bull) end mill over a raster of sloped passes, step-over far below its diameter: a tile
    meets many runs, so the removal prunes most of them by planes below G*. A flat end's profile jumps at its
    rim, so on a line that is not level no tangent plane bounds G* (the disc reaches lower further along the
    line): a plane there pruned runs that cut, leaving nodes tens of um high (84f2ca3)."""
    grid_mm, origin, floor_mm = 0.05, (0.0, 0.0), -3.0
    passes = []
    for k in range(24):
        x = np.linspace(0.0, 6.0, 61)[:: 1 if k % 2 == 0 else -1]
        passes.append(np.column_stack([x, np.full_like(x, 0.5 + 0.11 * k), 0.12 * x + 0.03 * np.sin(3 * x + k) - 1.0]))
    path = np.round(np.vstack(passes), 3)
    lines = np.arange(1, len(path), dtype=np.int32)
    want_z = np.zeros((70, 130), np.float32)
    want_line = np.zeros(want_z.shape, np.int32)
    _every_segment_at_every_node(want_z, want_line, origin, grid_mm, floor_mm, path, lines, core, corner, True)
    z = np.zeros(want_z.shape, np.float32)
    line = np.zeros(z.shape, np.int32)
    tile_max = np.zeros((-(-z.shape[0] // TILE), -(-z.shape[1] // TILE)))
    cut_batch(ZMap(z, line, tile_max, *origin, grid_mm, floor_mm), Batch(path, lines, core, corner, True),
              np.zeros(COUNTS, np.int64), 1)
    assert np.array_equal(z, want_z), f"{int((z != want_z).sum())} nodes, up to {float(np.abs(z - want_z).max()) * 1e3:.1f} um"


def test_the_removal_thread_leaves_the_heights_of_one_batch(tmp_path, monkeypatch):
    """The removal thread cuts the periods in batches of HANDOFF_PERIODS while the run goes on: the heights
    are the same, to the bit, as those of the whole program cut in one batch at the end (rounding to float32
    is monotone), through a tool change (each batch keeps the cutter it was handed over with)."""
    tools = {1: Tool(ball_radius_mm=1.0, diameter_mm=2.0, flutes=2), 2: Tool(shape="flat", diameter_mm=1.5, flutes=2)}
    raster = raster_program(0.3, 7, 5.0, 0.5, 1500.0).replace("G0 Z5\nM2", "G0 Z5\nT2 M6\nG0 X1 Y2\nG1 Z-0.7 X4 Y3\nG0 Z5\nM2")
    surfaces = {}
    for handoff in (1 << 30, 150, 1):
        monkeypatch.setattr(zmap, "HANDOFF_PERIODS", handoff)
        surfaces[handoff] = cut(tmp_path, raster, "0,0,-2,5,4,0", 20.0, tools=tools)
    whole = surfaces[1 << 30]
    assert whole.z_mm.min() < -0.6  # the flat T2's ramp cut after the change (the raster is 0.5 deep)
    for handoff in (150, 1):
        assert np.array_equal(surfaces[handoff].z_mm, whole.z_mm)


def test_a_batch_planned_ahead_on_another_thread_is_cut_the_same():
    """removal.cut with the batch's plan made ahead (removal.timed_plan on a thread of its own, as zmap does when
    the run ends) gives the bits of the plan made in cut, lines included, and counts the plan's CPU time."""
    path = np.round(np.cumsum(np.random.default_rng(5).normal(0, 0.05, (300, 3)), axis=0) + [2.0, 2.0, -0.5], 3)
    lines = np.arange(1, len(path), dtype=np.int32)
    results = []
    for ahead in (False, True):
        zm = ZMap(np.zeros((80, 80), np.float32), np.zeros((80, 80), np.int32), np.zeros((10, 10)), 0.0, 0.0, 0.05,
                  -2.0)
        batch = Batch(path, lines, 0.0, 1.0013, True)
        planned = None
        if ahead:
            with ThreadPoolExecutor(1) as planner:
                planned = planner.submit(removal.timed_plan, zm, batch)
                planned.result()
        cpu_s = cut_batch(zm, batch, np.zeros(COUNTS, np.int64), 1, planned)
        assert cpu_s >= (planned.result()[1] if ahead else 0.0)
        results.append((zm.z, zm.line))
    assert np.array_equal(results[0][0], results[1][0]) and np.array_equal(results[0][1], results[1][1])
    assert (results[0][1] > 0).any()  # the path cut the stock


def test_batches_handed_over_while_the_removal_thread_was_busy_are_joined():
    """Consecutive batches that continue one another with one cutter are cut as one: the whole path, its lines,
    the first batch's stamp; a batch with another cutter, or one that starts elsewhere (another tool length),
    stays apart."""
    path = np.cumsum(np.random.default_rng(3).normal(0, 0.1, (12, 3)), axis=0)
    lines = np.arange(1, 12, dtype=np.int32)
    ball = (0.0, 1.0)
    parts = [Batch(path[:4], lines[:3], *ball, True), Batch(path[3:8], lines[3:7], *ball, False),
             Batch(path[7:10], lines[7:9], *ball, False)]
    flat = Batch(path[9:11], lines[9:10], 1.0, 0.0, False)
    longer = Batch(path[10:] - [0.0, 0.0, 0.5], lines[10:], 1.0, 0.0, False)
    joined = zmap.joined_batches(parts + [flat, longer])
    assert len(joined) == 3 and joined[1] is flat and joined[2] is longer
    assert np.array_equal(joined[0].pos, path[:10]) and np.array_equal(joined[0].lines, lines[:9])
    assert joined[0].stamp_first and (joined[0].core, joined[0].corner) == ball


@pytest.mark.parametrize("compensation, depth_mm", [("G43 H2", 1.0), ("G49", 1.5), ("G43.1 Z0.3", 1.2)])
def test_the_tip_cuts_where_the_tool_length_puts_it(tmp_path, compensation, depth_mm):
    """T2 is 0.5 mm long below the gauge line the machine positions: G43 H2 compensates it exactly (the
    plunge to Z-1 reaches -1), without compensation the tip goes 0.5 mm deeper than programmed, and a
    dynamic offset of 0.3 mm leaves it 0.2 mm deeper. (The machine starts at its zero, the tip 0.5 mm
    below: the stock's top is below that.)"""
    tools = {2: Tool(shape="flat", diameter_mm=4.0, flutes=2, length_mm=0.5)}
    text = f"G21 G90 G94 T2 M6\n{compensation}\nG0 X5 Y5 Z1\nG1 Z-1 F300\nG0 Z5\nM2\n"
    surf = cut(tmp_path, text, "0,0,-5,10,10,-0.6", 20.0, tools=tools)
    X, Y = np.meshgrid(surf.x_mm, surf.y_mm)
    inside = np.hypot(X - 5, Y - 5) < 2.0 - 1e-6
    assert np.allclose(surf.z_mm[inside], -depth_mm, atol=F32_MM)
    assert np.all(surf.z_mm[np.hypot(X - 5, Y - 5) > 2.0 + 1e-6] == np.float32(-0.6))


def test_a_tip_starting_inside_the_stock_is_said(tmp_path):
    """The machine starts at its zero and T2 is 0.5 mm long, so its tip starts 0.5 mm into a stock whose
    top is Z0 (work): building the workpiece says so; with the top at Z-0.6 it says nothing."""
    config = dataclasses.replace(default_config(),
                                 tools={2: Tool(shape="flat", diameter_mm=4.0, flutes=2, length_mm=0.5)})
    path = tmp_path / "p.nc"
    path.write_text("G21 G90 G94 T2 M6\nG43 H2\nG0 X5 Y5 Z1\nM2\n")
    program = Controller(config).check(path)
    inside, below = (build_workpiece(program, config, start_position(program), stock_text=s)[1]
                     for s in ("0,0,-5,10,10,0", "0,0,-5,10,10,-0.6"))
    assert "tip starts 0.500 mm below the stock's top, at X0.000 Y0.000 Z-0.500" in inside
    assert "warning" not in below


def test_compare_says_when_a_tip_starts_inside_the_stock(tmp_path):
    """The same start as above through `vcnc compare --stock`: each program's warning reaches the user."""
    from click.testing import CliRunner

    from machine.cli import main

    a = tmp_path / "a.nc"
    a.write_text("G21 G90 G94\nG0 X5 Y5 Z1\nG1 X6 F300\nM2\n")
    res = CliRunner().invoke(main, ["compare", str(a), str(a), "--stock", "0,0,-5,10,10,0.5", "--grid-um", "200",
                                    "--tool", "1"])
    assert res.exit_code == 0, res.output
    assert res.stderr.count("tip starts 0.500 mm below the stock's top, at X0.000 Y0.000 Z0.000") == 2
