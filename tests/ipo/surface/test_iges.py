"""IGES 5.3 export (entity 128 surface, 126 curve) read back by an independent reader (pyiges).

pyiges parses the parameter records; the points are then evaluated with geomdl's NURBS
classes from pyiges's knots, weights and control points. pyiges's own
RationalBSplineSurface.to_geomdl cannot be used for that: it builds a non-rational
geomdl BSpline.Surface (whose weights setter ignores the weights), it needs pyvista
(not installed), and its u0/u1/v0/v1 are read from the wrong parameter indices
(parameters[-3..-0], the last being the entity type). Knots, weights and control
points, which it reads correctly, are what this test uses.
"""
from __future__ import annotations



import numpy as np
import pytest
import pyiges
from geomdl import NURBS

from ipo.surface.iges import IgesError, RationalCurve, iges_text, read_surfaces, real, write_iges
from ipo.nurbs.kernel import curve_points
from ipo.surface.section_fit import fit_shared
from ipo.surface.skinning import skin
from ipo.surface.evaluation import grid, surface_points
from surface_cases import geomdl_surface
from surface_cases import bump, cylinder


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    fits = fit_shared(cylinder(0.002).sections, 6)  # rational: weights differ from 1
    surf, _ = skin(fits.fits)
    curves = [RationalCurve(f.degree, f.knots, f.weights, f.points) for f in fits.fits]
    path = tmp_path_factory.mktemp("iges") / "cyl.igs"
    write_iges(path, [surf], curves)
    return path, surf, curves




def test_pyiges_reads_the_rational_surface_back(written):
    path, surf, _ = written
    iges = pyiges.read(str(path))
    surfaces = iges.bspline_surfaces()
    assert len(surfaces) == 1
    b = surfaces[0]
    assert not b.flag3  # PROP3 = 0: rational
    assert np.ptp(b.weights) > 1e-3
    u, v = grid(surf, 25, 25)
    g = geomdl_surface(b)
    ref = np.array(g.evaluate_list(list(zip(u / b.knot1[-1], v / b.knot2[-1]))))
    err = np.abs(ref - surface_points(surf, u, v)).max()
    print(f"\nIGES 128 round trip via pyiges + geomdl: {err:.2e} mm")
    assert err < 1e-9


def test_pyiges_reads_the_section_curves_back(written):
    path, _, curves = written
    got = pyiges.read(str(path)).bsplines()
    assert len(got) == len(curves)
    for c, ours in zip(got, curves):
        g = NURBS.Curve()
        g.degree = c.M
        pts, w = np.array(c.control_points), np.array(c.W)
        g.ctrlptsw = np.c_[pts * w[:, None], w].tolist()
        g.knotvector = list(np.array(c.T) / c.T[-1])
        t = np.linspace(0, 1, 40)
        ref = np.array(g.evaluate_list(list(t)))
        mine = curve_points(ours.degree, ours.knots, ours.weights, ours.points, t * ours.knots[-1])
        assert np.abs(ref - mine).max() < 1e-9
        assert (c.V0, c.V1) == (ours.knots[0], ours.knots[-1])
        assert c.planar_curve and abs(abs(c.YNORM) - 1) < 1e-9  # sections lie in planes y = const


def test_file_has_fixed_80_column_records_in_order(written):
    path, _, _ = written
    lines = path.read_text().splitlines()
    assert all(len(line) == 80 for line in lines)
    letters = "".join(line[72] for line in lines)
    counts = {c: letters.count(c) for c in "SGDPT"}
    assert letters == "".join(c * counts[c] for c in "SGDPT") and counts["T"] == 1
    for c in "SGDP":
        seq = [int(line[73:]) for line in lines if line[72] == c]
        assert seq == list(range(1, len(seq) + 1))
    t = lines[-1]
    assert t[:32] == f"S{counts['S']:7d}G{counts['G']:7d}D{counts['D']:7d}P{counts['P']:7d}"
    d_lines = [line for line in lines if line[72] == "D"]
    for k in range(0, counts["D"], 2):  # each D pair points at its P lines, which point back
        d1, d2 = d_lines[k:k + 2]
        first, count = int(d1[8:16]), int(d2[24:32])
        p_lines = [line for line in lines if line[72] == "P"][first - 1:first - 1 + count]
        assert {int(line[64:72]) for line in p_lines} == {k + 1}
        assert p_lines[-1][:64].rstrip().endswith(";")


def test_own_reader_round_trip_is_exact(written):
    path, surf, _ = written
    back = read_surfaces(path)[0]
    for a in ("knots_u", "knots_v", "weights", "points"):
        np.testing.assert_array_equal(getattr(back, a), getattr(surf, a))


def test_reals_always_have_a_point_and_read_back_exactly():
    rng = np.random.default_rng(0)
    values = np.concatenate([rng.normal(0, 1, 200) * 10.0 ** rng.integers(-12, 12, 200), [0.0, 1.0, -3.0, 1e-20]])
    for x in values:
        s = real(x)
        assert "." in s and float(s) == x


def test_reader_errors(tmp_path):
    bad = tmp_path / "bad.igs"
    bad.write_text("not iges\n")
    with pytest.raises(IgesError, match="bad.igs:1"):
        read_surfaces(bad)
    curve_only = tmp_path / "curve.igs"
    f = fit_shared(bump().sections[:1], 5).fits[0]
    curve_only.write_text(iges_text([], [RationalCurve(f.degree, f.knots, f.weights, f.points)]))
    with pytest.raises(IgesError, match="no rational B-spline surface"):
        read_surfaces(curve_only)
