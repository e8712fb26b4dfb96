"""Ball-end finishing passes from a skinned surface, written as G06.2 groups."""
from __future__ import annotations

import json
from pathlib import Path


import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial import cKDTree

from ipo.surface.iges import write_iges
from ipo.nurbs.kernel import curve_points
from ipo.surface.section_fit import fit_shared
from ipo.surface.skinning import skin
from ipo.surface.evaluation import closest_points, grid, surface_points, swap_uv, unit_normals
from ipo.surface.toolpath import ToolpathSettings, pass_values, plan_passes, program_text
from ipr import parse_file
from ipr.entities import Nurbs
from machine.cli import main
from surface_cases import bump, cylinder

MACHINE = Path(__file__).resolve().parents[3] / "programs" / "finish_machine.toml"
R, PICK, TOL = 3.0, 2.5, 0.005


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    surf, _ = skin(fit_shared(bump().sections, 8).fits)
    settings = ToolpathSettings(R, PICK, TOL, feed_mm_min=3000, spindle_rpm=12500)
    passes = plan_passes(surf, settings)
    path = tmp_path_factory.mktemp("tp") / "finish.nc"
    path.write_text(program_text(passes, settings, "bump"))
    return surf, passes, path


def test_every_tool_centre_point_is_r_from_the_surface_along_the_normal(finished):
    surf, passes, path = finished
    nurbs = [e for e in parse_file(path).entities if isinstance(e, Nurbs)]
    assert len(nurbs) == sum(len(p.pieces) for p in passes)
    pts = np.concatenate([curve_points(e.degree, e.knots, e.weights, e.points,
                                       np.linspace(e.knots[0], e.knots[-1], 400)) for e in nurbs])
    # brute force: the nearest of 250 000 surface points (spacing ~0.04 mm: the distance of a point
    # 3 mm away is overstated by at most ~0.3 um)
    gu, gv = np.meshgrid(np.linspace(*surf.u_range, 500), np.linspace(*surf.v_range, 500), indexing="ij")
    cloud = surface_points(surf, gu.ravel(), gv.ravel())
    d_grid, idx = cKDTree(cloud).query(pts)
    print(f"\n{len(pts)} tool-centre points: | distance - r | max {np.abs(d_grid - R).max() * 1e3:.2f} um "
          f"(brute force), tolerance {TOL * 1e3:.1f} um")
    assert np.abs(d_grid - R).max() <= TOL + 0.0005
    # the offset is along the normal: the foot point's normal points at the tool centre
    u, v, d = closest_points(surf, pts, gu.ravel()[idx], gv.ravel()[idx])
    foot, n = unit_normals(surf, u, v)
    along = np.einsum("ij,ij->i", (pts - foot) / d[:, None], n)
    assert np.abs(d - R).max() <= TOL
    assert along.min() > 1 - 1e-6


def test_program_structure(finished):
    _, passes, path = finished
    text = path.read_text()
    ents = parse_file(path).entities
    assert sum(line.startswith("G06.2") for line in text.splitlines()) == sum(len(p.pieces) for p in passes)
    plunges = [e for e in ents if type(e).__name__ == "Line"]
    assert len(plunges) == len(passes)
    for p, line in zip(passes, plunges):
        assert np.allclose(line.end, p.centres[0], atol=1e-4) and line.start[:2] == line.end[:2]
    motions = [e for e in ents if type(e).__name__ in ("Line", "Nurbs")]
    for a, b in zip(motions, motions[1:]):
        if isinstance(b, Nurbs):  # a group starts where the plunge or the previous group ended
            assert np.allclose(b.start, a.end, atol=1e-9)
    starts_x = [p.centres[0, 0] for p in passes]
    assert all(np.sign(a) != np.sign(b) for a, b in zip(starts_x, starts_x[1:]))  # zig-zag
    assert all(p.deviation_mm <= TOL for p in passes)


def test_passes_are_at_most_a_pick_feed_apart_on_a_cylinder():
    surf, _ = skin(fit_shared(cylinder().sections, 6).fits)  # arcs at y = 0..30, axis along y
    v = pass_values(surf, PICK)
    y = surface_points(surf, np.full(len(v), 0.7), v)[:, 1]
    gaps = np.diff(y)
    print(f"\npasses along the arcs: {len(v)}, gaps {gaps.min():.3f}..{gaps.max():.3f} mm (pick {PICK})")
    assert gaps.max() <= PICK and gaps.min() > 0.85 * PICK
    u = pass_values(swap_uv(surf), PICK)
    s = surface_points(surf, u, np.full(len(u), 1.0))
    angle_gaps = np.diff(np.arctan2(s[:, 0], s[:, 2])) * 20.0  # arc length on the 20 mm radius
    assert angle_gaps.max() <= PICK * (1 + 1e-3) and angle_gaps.min() > 0.85 * PICK


def test_errors_for_pick_gouge_and_undercut():
    surf, _ = skin(fit_shared(bump().sections, 8).fits)
    with pytest.raises(ValueError, match="ball diameter"):
        plan_passes(surf, ToolpathSettings(1.0, 2.0))
    valley = cylinder(radius=2.0, length=6.0, sweep_deg=90.0)
    flipped = [q * np.array([1.0, 1.0, -1.0]) for q in valley.sections]  # concave, radius 2
    concave, _ = skin(fit_shared(flipped, 6).fits)
    with pytest.raises(ValueError, match="folds back"):
        plan_passes(concave, ToolpathSettings(3.0, 1.0))
    over, _ = skin(fit_shared(cylinder(sweep_deg=220.0, length=6.0).sections, 8).fits)
    with pytest.raises(ValueError, match="undercut"):
        plan_passes(over, ToolpathSettings(3.0, 1.0))


def test_program_runs_in_vcnc_run_with_the_roughness_limiter(finished):
    _, _, path = finished
    result = CliRunner().invoke(main, ["run", str(path), "--machine", str(MACHINE), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output.strip().splitlines()[-1])
    assert summary["state"] == "completed" and summary["limit_violations"] == 0


def test_cli_toolpath_from_iges(tmp_path):
    surf, _ = skin(fit_shared(cylinder().sections, 6).fits)
    igs = tmp_path / "cyl.igs"
    write_iges(igs, [surf])
    out = tmp_path / "finish.nc"
    result = CliRunner().invoke(main, ["toolpath", str(igs), "--ball-mm", "3", "--pick-mm", "5", "-o", str(out),
                                       "--feed-mm-min", "2000", "--spindle-rpm", "12000"])
    assert result.exit_code == 0, result.output
    assert "passes 8 along u" in result.output
    ents = parse_file(out).entities
    nurbs = [e for e in ents if isinstance(e, Nurbs)]
    assert nurbs and all(abs(e.feed_mm_s - 2000 / 60) < 1e-9 for e in nurbs)
    # every centre point lies on the cylinder of radius 20 + 3 (a cylinder's offset is a cylinder),
    # within the tolerance plus the skinned surface's own distance from the true cylinder
    pts = np.concatenate([curve_points(e.degree, e.knots, e.weights, e.points, np.linspace(0, e.knots[-1], 200))
                          for e in nurbs])
    s = surface_points(surf, *grid(surf, 60, 60))
    surface_err = np.abs(np.hypot(s[:, 0], s[:, 2]) - 20.0).max()
    assert np.abs(np.hypot(pts[:, 0], pts[:, 2]) - 23.0).max() <= TOL + surface_err
    bad = CliRunner().invoke(main, ["toolpath", str(igs), "--ball-mm", "3", "--pick-mm", "7", "-o", str(out)])
    assert bad.exit_code != 0 and "ball diameter" in bad.output
