"""Finishing passes across a C0 crease: the ball centre rolls about the crease and never gouges."""
from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial import cKDTree

from ipo.surface.iges import write_iges
from ipo.nurbs.kernel import curve_points
from ipo.surface.evaluation import RationalSurface, c0_knots, grid, split_u, surface_points, swap_uv
from ipo.surface.toolpath import ToolpathSettings, centres_at, plan_passes, program_text
from ipr import parse_file
from ipr.entities import Nurbs
from machine.cli import main

R, PICK, TOL = 3.0, 1.0, 0.005
CUBIC_C0_KNOTS = np.array([0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2.0])  # degree 3, crease at u = 1
LINEAR_KNOTS = np.array([0, 0, 1, 1.0])


def roof_planes(alpha_deg: float = 15.0, skew: float = 2.0, half: float = 10.0, width: float = 10.0,
                ridge: float = 5.0) -> tuple[RationalSurface, np.ndarray, np.ndarray]:
    """Two planes falling at alpha on either side of a ridge line from (-skew, 0, ridge) to (skew, width,
    ridge) (oblique to the passes): a cubic in u with a triple knot at the ridge, linear in v. The normals
    differ by 2 alpha. Returns the surface and the ridge's end points."""
    k0, k1 = np.array([-skew, 0.0, ridge]), np.array([skew, width, ridge])
    d = (k1 - k0)[:2] / np.linalg.norm((k1 - k0)[:2])
    across = np.array([d[1], -d[0]])  # horizontal unit vector across the ridge

    def on_roof(x, y):
        return np.array([x, y, ridge - np.tan(np.radians(alpha_deg)) * abs(across @ (np.array([x, y]) - k0[:2]))])

    rows = []
    for y, k in ((0.0, k0), (width, k1)):
        a, b = on_roof(-half, y), on_roof(half, y)
        rows.append([a + i / 3 * (k - a) for i in range(4)] + [k + i / 3 * (b - k) for i in range(1, 4)])
    points = np.array(rows).transpose(1, 0, 2).copy()
    return RationalSurface(3, 1, CUBIC_C0_KNOTS, LINEAR_KNOTS, np.ones((7, 2)), points), k0, k1


RHO, OFF, HALF = 20.0, 5.0, 10.0  # cylinder radius, axis offset from the ridge, half width in x


def roof_cylinders(width: float = 10.0) -> RationalSurface:
    """Two cylinders of radius RHO (axes along y at x = +OFF and x = -OFF) meeting at a ridge at x = 0;
    each side an exact rational quadratic arc, the double knot u = 1 the crease (normals differ by
    2 asin(OFF / RHO) = 29 deg)."""
    phi0, phi1 = np.arccos(-OFF / RHO), np.arccos((-HALF - OFF) / RHO)
    h = (phi1 - phi0) / 2
    ang = np.array([phi1, phi1 - h, phi0])
    rad = np.array([RHO, RHO / np.cos(h), RHO])
    left = np.c_[OFF + rad * np.cos(ang), rad * np.sin(ang)]
    xz = np.vstack([left, (left * [-1.0, 1.0])[::-1][1:]])
    w = np.array([1.0, np.cos(h), 1.0, np.cos(h), 1.0])
    points = np.array([[[x, y, z] for y in (0.0, width)] for x, z in xz])
    return RationalSurface(2, 1, np.array([0, 0, 0, 1, 1, 2, 2, 2.0]), LINEAR_KNOTS,
                           np.repeat(w[:, None], 2, axis=1), points)


def cylinder_roof_distance(p: np.ndarray) -> np.ndarray:
    """Exact distance in xz of points to the two arcs (the passes stay within the roof's y range)."""
    out = np.full(len(p), np.inf)
    phi0, phi1 = np.arccos(-OFF / RHO), np.arccos((-HALF - OFF) / RHO)
    for side in (1.0, -1.0):  # the left arc about x = +OFF, then its mirror image
        q = np.c_[side * p[:, 0] - OFF, p[:, 2]]
        ang = np.arctan2(q[:, 1], q[:, 0])
        inside = (ang >= phi0) & (ang <= phi1)
        ends = [RHO * np.array([np.cos(a), np.sin(a)]) for a in (phi0, phi1)]
        to_ends = np.minimum(*(np.linalg.norm(q - e, axis=1) for e in ends))
        out = np.minimum(out, np.where(inside, np.abs(np.linalg.norm(q, axis=1) - RHO), to_ends))
    return out


def written_centres(path) -> tuple[np.ndarray, list[Nurbs]]:
    nurbs = [e for e in parse_file(path).entities if isinstance(e, Nurbs)]
    pts = np.concatenate([curve_points(e.degree, e.knots, e.weights, e.points,
                                       np.linspace(e.knots[0], e.knots[-1], 400)) for e in nurbs])
    return pts, nurbs


def point_line_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = (b - a) / np.linalg.norm(b - a)
    rel = p - a
    return np.linalg.norm(rel - (rel @ d)[:, None] * d, axis=1)


def test_c0_knots_and_split_against_the_whole_surface():
    surf, _, _ = roof_planes()
    assert list(c0_knots(surf.knots_u, 3)) == [1.0] and len(c0_knots(surf.knots_v, 1)) == 0
    left, right = split_u(surf, 1.0)
    u, v = np.linspace(0.0, 1.0, 9), np.linspace(0.0, 1.0, 9)
    assert np.allclose(surface_points(left, u, v), surface_points(surf, u * (1 - 1e-15), v), atol=1e-12)
    assert np.allclose(surface_points(right, u + 1, v), surface_points(surf, u + 1, v), atol=1e-12)
    with pytest.raises(ValueError, match="multiplicity"):
        split_u(roof_cylinders(), 0.5)


@pytest.mark.parametrize("along", ["u", "v"])
@pytest.mark.slow
def test_oblique_planar_ridge_is_never_gouged(tmp_path, along):
    surf, k0, k1 = roof_planes()
    if along == "v":  # the same ridge, crossed by passes along the surface's v
        surf = swap_uv(surf)
    settings = ToolpathSettings(R, PICK, TOL, along=along)
    passes = plan_passes(surf, settings)
    path = tmp_path / "roof.nc"
    path.write_text(program_text(passes, settings, "roof"))
    pts, nurbs = written_centres(path)
    assert sum(p.rolling_arcs for p in passes) == len(passes)
    arcs = [e for e in nurbs if e.degree == 2]
    assert len(arcs) == len(passes)
    # brute force: the nearest of 321 000 surface points (spacing <= 0.03 mm, the ridge line in the grid):
    # a distance of 3 mm is overstated by at most ~0.1 um
    cloud = surface_points(surf, *grid(surf, 801, 401))
    d, _ = cKDTree(cloud).query(pts)
    print(f"\n{len(pts)} tool-centre points over a 30 deg ridge: distance - r {(d - R).min() * 1e3:.3f}.."
          f"{(d - R).max() * 1e3:.3f} um (tolerance {TOL * 1e3} um)")
    assert (d - R).min() >= -TOL and (d - R).max() <= TOL + 0.0002
    # on the arcs the centre is exactly r from the ridge line (it rolls about it)
    arc_pts = np.concatenate([curve_points(2, e.knots, e.weights, e.points, np.linspace(0, e.knots[-1], 50))
                              for e in arcs])
    assert np.abs(point_line_distance(arc_pts, k0, k1) - R).max() < 1e-4


def test_cylinder_ridge_from_iges_through_the_cli_against_the_exact_arcs(tmp_path):
    igs, out = tmp_path / "roof.igs", tmp_path / "roof.nc"
    write_iges(igs, [roof_cylinders()])
    result = CliRunner().invoke(main, ["toolpath", str(igs), "--ball-mm", str(R), "--pick-mm", str(PICK),
                                       "--tol-mm", str(TOL), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "rolling arcs 12" in result.output
    pts, _ = written_centres(out)
    d = cylinder_roof_distance(pts)
    print(f"\n{len(pts)} tool-centre points over two cylinders: distance - r {(d - R).min() * 1e3:.3f}.."
          f"{(d - R).max() * 1e3:.3f} um (exact)")
    assert np.abs(d - R).max() <= TOL


def test_offsets_joined_across_the_ridge_gouge():
    """What the passes did before: the offsets S + r n sampled across the ridge and joined. The chord
    between the last offset of one side and the first of the other cuts about r (1 - cos 14.5 deg) = 96 um
    into the ridge (103 um with the samples' spacing). The old planner fitted through those offsets; it
    could not fit the corner within 5 um and refused the surface."""
    surf = roof_cylinders()
    u = np.linspace(0.0, 2.0, 401)  # u = 1, the ridge, is a sample: evaluated on the right side
    _, c = centres_at(surf, u, 0.5, R, 1.0)
    t = np.linspace(0.0, 1.0, 50)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(c[:-1], c[1:])])
    gouge = R - cylinder_roof_distance(dense).min()
    print(f"\njoined offsets: {gouge * 1e3:.1f} um into the ridge")
    assert gouge > 90e-3


def test_concave_crease_is_refused_across_and_along_the_passes():
    roof, _, _ = roof_planes()
    valley = RationalSurface(3, 1, roof.knots_u, roof.knots_v, roof.weights, roof.points * [1.0, 1.0, -1.0])
    with pytest.raises(ValueError, match="concave crease .* turns by 30.00 deg"):  # across the passes
        plan_passes(valley, ToolpathSettings(R, PICK, TOL))
    # along the passes: the pass nearest the valley floor, on one side, reaches into the other side
    with pytest.raises(ValueError, match=r"concave crease .* cuts \d+\.\d+ um into the surface"):
        plan_passes(valley, ToolpathSettings(R, PICK, TOL, along="v"))


def test_a_full_multiplicity_knot_without_a_kink_is_no_crease():
    flat, _, _ = roof_planes(alpha_deg=0.0)
    passes = plan_passes(flat, ToolpathSettings(R, PICK, TOL))
    assert sum(p.rolling_arcs for p in passes) == 0
    assert all(len(p.pieces) == 1 for p in passes)  # the two sides fitted as one curve
    centres = np.concatenate([p.centres for p in passes])
    assert np.abs(centres[:, 2] - (5.0 + R)).max() < 1e-9


def test_a_surface_that_jumps_at_a_knot_is_refused():
    roof, _, _ = roof_planes()
    knots = np.array([0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2.0])  # multiplicity 4: the sides may part
    points = np.concatenate([roof.points[:4], roof.points[3:]])
    points[4:, :, 2] += 0.5
    gap = RationalSurface(3, 1, knots, LINEAR_KNOTS, np.ones((8, 2)), points)
    with pytest.raises(ValueError, match="not continuous"):
        plan_passes(gap, ToolpathSettings(R, PICK, TOL))


@pytest.mark.slow
def test_three_ridges_of_a_degree_one_prism(tmp_path):
    """Degree 1 in u: every interior knot is a C0 line, here three convex ridges, all rolled about."""
    xz = np.array([[-10.0, 0.0], [-4.0, 4.0], [4.0, 4.0], [10.0, 0.0], [14.0, -5.0]])
    points = np.array([[[x, y, z] for y in (0.0, 8.0)] for x, z in xz])
    prism = RationalSurface(1, 1, np.array([0, 0, 1, 2, 3, 4, 4.0]), LINEAR_KNOTS, np.ones((5, 2)), points)
    settings = ToolpathSettings(R, PICK, TOL)
    passes = plan_passes(prism, settings)
    path = tmp_path / "prism.nc"
    path.write_text(program_text(passes, settings, "prism"))
    pts, nurbs = written_centres(path)
    assert sum(e.degree == 2 for e in nurbs) == 3 * len(passes)
    d, _ = cKDTree(surface_points(prism, *grid(prism, 1601, 201))).query(pts)  # spacing 0.025 / 0.04 mm
    print(f"\nprism, {len(passes)} passes: distance - r {(d - R).min() * 1e3:.3f}..{(d - R).max() * 1e3:.3f} um")
    assert (d - R).min() >= -TOL and (d - R).max() <= TOL + 0.0002


@pytest.mark.slow
def test_noisy_patches_merged_c0_plan_along_their_joints():
    """`vcnc surface --patch-sections 5` merges C0: the joints run along passes along u and bend by up to
    1.5 deg, some concave. Each pass is checked against the patches on both sides of the joints."""
    from ipo.surface.section_fit import fit_sections
    from ipo.surface.skinning import skin_patches
    from surface_cases import bump

    surf = skin_patches(fit_sections(bump(0.005).sections, tol_mm=0.02).fits, 5, "C0").surface
    assert len(c0_knots(surf.knots_v, surf.degree_v)) == 2
    passes = plan_passes(surf, ToolpathSettings(R, PICK, TOL))
    pts = np.concatenate([curve_points(f.degree, f.knots, f.weights, f.points, np.linspace(0, f.knots[-1], 400))
                          for p in passes for f in p.pieces])
    d, _ = cKDTree(surface_points(surf, *grid(surf, 600, 600))).query(pts)  # spacing 0.034 mm: +0.2 um
    print(f"\nC0-merged bump: distance - r {(d - R).min() * 1e3:.3f}..{(d - R).max() * 1e3:.3f} um")
    assert (d - R).min() >= -TOL and (d - R).max() <= TOL + 0.0002


@pytest.mark.slow
def test_slight_concave_kink_is_joined_through_the_ball_touching_both_sides(tmp_path):
    """A 1.2 deg valley: a ball on one side would cut r (1 - cos 1.2 deg) = 0.66 um into the other, within
    half the tolerance; the offsets' ends give way to the centre touching both planes."""
    valley, _, _ = roof_planes(alpha_deg=-0.6)
    settings = ToolpathSettings(R, PICK, TOL)
    passes = plan_passes(valley, settings)
    assert sum(p.rolling_arcs for p in passes) == 0
    path = tmp_path / "valley.nc"
    path.write_text(program_text(passes, settings, "valley"))
    pts, _ = written_centres(path)
    d, _ = cKDTree(surface_points(valley, *grid(valley, 801, 401))).query(pts)
    print(f"\n1.2 deg valley: distance - r {(d - R).min() * 1e3:.3f}..{(d - R).max() * 1e3:.3f} um")
    assert (d - R).min() >= -TOL and (d - R).max() <= TOL + 0.0002
