"""Digitised sections -> rational section fits -> skinned, merged surface (001 §2–4)."""
from __future__ import annotations



import numpy as np
import pytest
from click.testing import CliRunner
from geomdl import NURBS

from ipo.surface.iges import read_surfaces
from ipo.fit.rational import fit_rational
from ipo.surface.section_fit import fit_sections, fit_shared, section_error
from ipo.surface.sections import SectionsError, orient_like_first, parse_sections
from ipo.surface.skinning import deviation_from_points, merge_v, skin, skin_patches
from ipo.surface.evaluation import RationalSurface, grid, surface_derivs, surface_points, unit_normals
from machine.cli import main
from surface_cases import bump, csv_text, cylinder, saddle


# ---------------------------------------------------------------- input
def test_sections_from_a_section_column():
    text = "# probe run 3\nX,Y,Section,Z\n0,0,a,1\n1,0,a,2\n2,0,a,3\n\n0,1,b,4\n1,1,b,5\n2,1,b,6\n"
    s = parse_sections(text)
    assert s.labels == ["a", "b"] and s.first_lines == [3, 7]
    np.testing.assert_array_equal(s.points[1], [[0, 1, 4], [1, 1, 5], [2, 1, 6]])


def test_sections_from_blank_lines_in_xyz_text():
    text = "0 0 0\n1 0 1\n2 0 0\n\n\n0 5 1\n1 5 2\n2 5 1\n"
    s = parse_sections(text, min_points=3)
    assert len(s) == 2 and s.first_lines == [1, 6]
    np.testing.assert_array_equal(s.points[0][:, 2], [0, 1, 0])


@pytest.mark.parametrize("text, where, words", [
    ("0 0 0\n1 0 1\n2 0\n", ":3:", "2 values"),
    ("x,y,z\n0,0,0\n1,0,nan\n", ":3:", "NaN"),
    ("x,y,z\n0,0,0\n1,0,inf\n", ":3:", "not a finite"),
    ("0 0 0\n1 0 1\n2 0 0\n\n0 1 0\n1 1 1\n", ":5:", "has 2 point"),
    ("section,x,y,z\n1,0,0,0\n1,1,0,0\n2,0,1,0\n1,2,0,0\n", ":5:", "resumes"),
    ("1 0 0 0\n", ":1:", "without a header"),
    ("x,y,z,w\n0,0,0,1\n", ":1:", "unknown column"),
    ("0 0 0\n1 zero 1\n", ":2:", "not a number"),
])
def test_sections_errors_name_the_line(text, where, words):
    with pytest.raises(SectionsError) as err:
        parse_sections(text, "pts.xyz", min_points=3)
    assert where in str(err.value) and words in str(err.value)


def test_zig_zag_sections_are_turned_to_run_alike(tmp_path):
    case = saddle(0.005)
    zig = [q[::-1] if h % 2 else q for h, q in enumerate(case.sections)]
    s, flipped = orient_like_first(parse_sections(csv_text(zig)))
    assert flipped == [1, 3, 5, 7]
    for got, q in zip(s.points, case.sections):
        np.testing.assert_allclose(got, q)
    pts = tmp_path / "zig.csv"
    pts.write_text(csv_text(zig))
    result = CliRunner().invoke(main, ["surface", str(pts), "-o", str(tmp_path / "z.igs"), "--tol-mm", "0.02"])
    assert result.exit_code == 0 and "sections 2, 4, 6, 8" in result.output


# ---------------------------------------------------------------- surface evaluation
def _random_surface(rng) -> RationalSurface:
    from ipo.fit.rational import uniform_knots
    n_u, n_v = 6, 5
    pts = np.stack(np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij"), axis=2) * 10.0
    pts = np.concatenate([pts, rng.normal(0, 3, (n_u, n_v, 1))], axis=2)
    return RationalSurface(3, 2, uniform_knots(n_u, 3), uniform_knots(n_v, 2), rng.uniform(0.4, 2.0, (n_u, n_v)), pts)


def _geomdl(surf: RationalSurface):
    g = NURBS.Surface()
    g.degree_u, g.degree_v = surf.degree_u, surf.degree_v
    n_u, n_v = surf.weights.shape
    g.ctrlpts_size_u, g.ctrlpts_size_v = n_u, n_v
    pw = surf.homogeneous.reshape(-1, 4)
    g.ctrlptsw = pw.tolist()
    g.knotvector_u = list(surf.knots_u / surf.knots_u[-1])
    g.knotvector_v = list(surf.knots_v / surf.knots_v[-1])
    return g


def test_surface_points_match_geomdl_and_derivatives_match_differences():
    rng = np.random.default_rng(5)
    surf = _random_surface(rng)
    u = rng.uniform(*surf.u_range, 200)
    v = rng.uniform(*surf.v_range, 200)
    ref = np.array(_geomdl(surf).evaluate_list(list(zip(u / surf.knots_u[-1], v / surf.knots_v[-1]))))
    s, s_u, s_v = surface_derivs(surf, u, v)
    assert np.abs(s - ref).max() < 1e-9
    h = 1e-6
    fd_u = (surface_points(surf, u + h, v) - surface_points(surf, u - h, v)) / (2 * h)
    fd_v = (surface_points(surf, u, v + h) - surface_points(surf, u, v - h)) / (2 * h)
    assert np.abs(s_u - fd_u).max() < 1e-5 * np.abs(s_u).max()
    assert np.abs(s_v - fd_v).max() < 1e-5 * np.abs(s_v).max()
    _, n = unit_normals(surf, u, v)
    assert np.allclose(np.linalg.norm(n, axis=1), 1) and np.abs(np.einsum("ij,ij->i", n, s_u)).max() < 1e-9


# ---------------------------------------------------------------- skinning
def test_skinned_surface_passes_through_every_section_curve():
    case = bump()
    fits = fit_shared(case.sections, 8)
    surf, v_h = skin(fits.fits)
    for fit, v in zip(fits.fits, v_h):
        c = NURBS.Curve()  # independent evaluation of the section curve
        c.degree = fit.degree
        c.ctrlptsw = np.c_[fit.points * fit.weights[:, None], fit.weights].tolist()
        c.knotvector = list(fit.knots / fit.knots[-1])
        t = np.linspace(0, 1, 50)
        ref = np.array(c.evaluate_list(list(t)))
        got = surface_points(surf, t * fit.knots[-1], np.full(50, v))
        assert np.abs(got - ref).max() < 1e-9


@pytest.mark.parametrize("make", [cylinder, saddle, bump], ids=["cylinder", "saddle", "bump"])
def test_noisy_digitisation_gives_a_surface_near_the_truth(make):
    noise, tol = 0.005, 0.02
    case = make(noise)
    fits = fit_sections(case.sections, tol_mm=tol)
    res = skin_patches(fits.fits)
    dev = deviation_from_points(res.surface, fits.fits, case.sections, res.section_v)
    u, v = grid(res.surface, 80, 80)
    truth = case.error_to_truth(surface_points(res.surface, u, v))
    print(f"\n{case.name}: {fits.n_ctrl} control points (rational {fits.rational}), section max "
          f"{fits.max_error_mm.max() * 1e3:.1f} um, to input points {dev.max() * 1e3:.1f} um, "
          f"to the true surface max {truth.max() * 1e3:.1f} um rms {np.sqrt(np.mean(truth**2)) * 1e3:.1f} um")
    assert fits.max_error_mm.max() <= tol
    assert dev.max() <= tol + 1e-9  # the skin interpolates the section curves
    assert truth.max() < 0.03  # noise sigma 5 um, tolerance 20 um
    assert np.sqrt(np.mean(truth**2)) < 2 * noise


def test_rational_fit_needs_fewer_control_points_than_polynomial():
    """001's claim on exact cylinder arcs: count the control points each needs for 1 um."""
    case = cylinder()
    tol = 0.001
    rational = fit_sections(case.sections, tol_mm=tol)
    plain_m = next(m for m in range(4, 15) if fit_shared(case.sections, m, rational=False).max_error_mm.max() <= tol)
    print(f"\ncylinder arcs within 1 um: rational {rational.n_ctrl} control points, polynomial {plain_m}")
    assert rational.rational and rational.n_ctrl < plain_m


def test_paper_figure_14_points_8_control_points_converges():
    """001 Fig. 3: 14 digitised points, 8 control points; f_l after each iteration (App. I step 5)."""
    q = bump(0.005, n_points=14).sections[5]
    fit = fit_rational(q, 8, 3, max_iter=30)
    plain = fit_rational(q, 8, 3, max_iter=30, rational=False)
    print("\nRMS f_l per iteration (um):", " ".join(f"{f * 1e3:.3f}" for f in fit.rms_history))
    hist = fit.rms_history
    assert np.all(np.diff(hist) <= 1e-12)  # every iteration lowers f_l
    assert hist[-1] < 0.2 * hist[0]
    assert section_error(fit, q) < section_error(plain, q)


def test_merging_c0_keeps_the_patches_and_c1_makes_the_joint_smooth():
    case = bump(0.0)
    fits = fit_shared(case.sections, 8)
    c0 = skin_patches(fits.fits, 5, "C0")
    c1 = skin_patches(fits.fits, 5, "C1")
    assert c0.patches == [(0, 3), (3, 7), (7, 10)]
    first, last = c0.patches[1]
    patch, _ = skin(fits.fits[first:last + 1], c0.surface.degree_v)
    joint = c0.section_v[first]
    u = np.linspace(*patch.u_range, 40)
    for t in np.linspace(0, patch.v_range[1], 7):
        got = surface_points(c0.surface, u, np.full(40, joint + t))
        assert np.abs(got - surface_points(patch, u, np.full(40, t))).max() < 1e-9  # 001 eq. 17 only
    eps = 1e-7

    def jump(surf):
        left = surface_derivs(surf, u, np.full(40, joint - eps))[2]
        right = surface_derivs(surf, u, np.full(40, joint + eps))[2]
        return np.abs(left - right).max() / np.abs(left).max()

    print(f"\nS_v jump at the joint: C0 {jump(c0.surface):.2e}, C1 {jump(c1.surface):.2e}")
    assert jump(c1.surface) < 1e-5 < jump(c0.surface)
    with pytest.raises(ValueError, match="share a boundary"):
        merge_v(skin(fits.fits[:4])[0], skin(fits.fits[5:9])[0])


# ---------------------------------------------------------------- CLI
def test_cli_surface_writes_iges_and_reports(tmp_path):
    case = saddle(0.005)
    pts = tmp_path / "pts.csv"
    pts.write_text(csv_text(case.sections))
    out = tmp_path / "s.igs"
    result = CliRunner().invoke(main, ["surface", str(pts), "-o", str(out), "--tol-mm", "0.02"])
    assert result.exit_code == 0, result.output
    assert "deviation from all input points: max" in result.output
    assert sum(line.split()[0].isdigit() for line in result.output.splitlines()[3:3 + len(case.sections)]) == 9
    surf = read_surfaces(out)[0]
    u, v = grid(surf, 30, 30)
    assert case.error_to_truth(surface_points(surf, u, v)).max() < 0.03


def test_cli_surface_with_a_fixed_count_and_xyz_text(tmp_path):
    case = cylinder(0.002)
    pts = tmp_path / "pts.xyz"
    pts.write_text("\n\n".join("\n".join(f"{x} {y} {z}" for x, y, z in q) for q in case.sections) + "\n")
    out = tmp_path / "c.igs"
    result = CliRunner().invoke(main, ["surface", str(pts), "-o", str(out), "--ctrl", "6", "--order", "3"])
    assert result.exit_code == 0, result.output
    assert "order 3, 6 control points each" in result.output and "shared rational weights" in result.output
    surf = read_surfaces(out)[0]
    assert (surf.degree_u, surf.weights.shape) == (2, (6, 7))


def test_cli_surface_reports_bad_input_with_its_line(tmp_path):
    pts = tmp_path / "bad.csv"
    pts.write_text("x,y,z\n0,0,0\n1,0\n")
    result = CliRunner().invoke(main, ["surface", str(pts), "-o", str(tmp_path / "s.igs")])
    assert result.exit_code != 0 and "bad.csv:3" in result.output

