"""The NURBS kernel (numpy, compiled Cox-de Boor, span polynomials) against hand-computed
basis functions (000 Fig. 1), geomdl and scipy's BSpline in homogeneous form."""
from __future__ import annotations

import numpy as np
import pytest
from geomdl import NURBS
from scipy.interpolate import BSpline

from ipo.nurbs import kernel as nurbs
from ipo.nurbs import compiled as nj

FIG1_KNOTS = np.array([0, 0, 0, 1, 2, 3, 4, 4, 5, 5, 5], dtype=float)


def fig1_by_hand(u: float) -> np.ndarray:
    """All 8 quadratic basis functions of 000 Fig. 1, piecewise quadratics worked out by hand
    from eq. 2-3 (knots u0..u10 = 0,0,0,1,2,3,4,4,5,5,5)."""
    n = np.zeros(8)
    if 0 <= u < 1:
        n[0], n[1], n[2] = (1 - u) ** 2, 2 * u - 1.5 * u**2, u**2 / 2
    elif 1 <= u < 2:
        n[1], n[2], n[3] = (2 - u) ** 2 / 2, -1.5 + 3 * u - u**2, (u - 1) ** 2 / 2
    elif 2 <= u < 3:
        n[2], n[3], n[4] = (3 - u) ** 2 / 2, -5.5 + 5 * u - u**2, (u - 2) ** 2 / 2
    elif 3 <= u < 4:
        n[3], n[4], n[5] = (4 - u) ** 2 / 2, (4 - u) * ((u - 2) / 2 + (u - 3)), (u - 3) ** 2
    elif 4 <= u <= 5:
        n[5], n[6], n[7] = (5 - u) ** 2, 2 * (u - 4) * (5 - u), (u - 4) ** 2
    return n


def dense_basis(knots, p, u):
    span = nurbs.find_span(knots, p, np.atleast_1d(u))
    b = nurbs.basis(knots, p, np.atleast_1d(u), span)
    out = np.zeros((len(span), len(knots) - p - 1))
    for r in range(p + 1):
        out[np.arange(len(span)), span - p + r] = b[:, r]
    return out


@pytest.mark.parametrize("u, expected", [
    (0.5, {0: 0.25, 1: 0.625, 2: 0.125}),
    (1.5, {1: 0.125, 2: 0.75, 3: 0.125}),
    (2.5, {2: 0.125, 3: 0.75, 4: 0.125}),
    (3.5, {3: 0.125, 4: 0.625, 5: 0.25}),
    (4.0, {5: 1.0}),  # the double knot: the curve passes through B_5
    (4.5, {5: 0.25, 6: 0.5, 7: 0.25}),
    (5.0, {7: 1.0}),
])
def test_fig1_basis_values_by_hand(u, expected):
    want = np.zeros(8)
    for i, v in expected.items():
        want[i] = v
    np.testing.assert_allclose(fig1_by_hand(u), want, atol=1e-15)
    np.testing.assert_allclose(dense_basis(FIG1_KNOTS, 2, u)[0], want, atol=1e-15)


def test_fig1_basis_matches_hand_formulas_everywhere_and_sums_to_one():
    u = np.linspace(0, 5, 501)
    got = dense_basis(FIG1_KNOTS, 2, u)
    want = np.array([fig1_by_hand(x) for x in u])
    np.testing.assert_allclose(got, want, atol=1e-14)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-14)
    # compiled Cox-de Boor, with a deliberately wrong span hint
    out, left, right = np.empty(3), np.empty(3), np.empty(3)
    for x, row in zip(u, want):
        span = nj.find_span(FIG1_KNOTS, 2, x, 0 if x > 2.5 else 7)
        assert span == nurbs.find_span(FIG1_KNOTS, 2, np.array([x]))[0]
        nj.basis(FIG1_KNOTS, 2, span, x, out, left, right)
        np.testing.assert_allclose(out, row[span - 2:span + 1], atol=1e-14)


def random_curve(seed, n=12, p=3, dim=3, spread=3.0):
    rng = np.random.default_rng(seed)
    inner = np.sort(rng.uniform(0.0, 2.0, n - p - 1))
    knots = np.r_[[0.0] * (p + 1), inner, [2.0] * (p + 1)]
    points = rng.normal(size=(n, dim)) * 10.0
    weights = rng.uniform(1.0 / spread, spread, n)
    return p, knots, weights, points


def test_partition_of_unity_random_knots():
    p, knots, _, _ = random_curve(3, n=15, p=4)
    u = np.random.default_rng(1).uniform(0, 2, 400)
    np.testing.assert_allclose(dense_basis(knots, p, u).sum(axis=1), 1.0, atol=1e-13)
    d = nurbs.basis_derivs(knots, p, u, 2)
    np.testing.assert_allclose(d[1].sum(axis=1), 0.0, atol=1e-9)
    np.testing.assert_allclose(d[2].sum(axis=1), 0.0, atol=1e-7)


def geomdl_curve(p, knots, weights, points):
    c = NURBS.Curve(normalize_kv=False)
    c.degree = p
    c.ctrlpts = points.tolist()
    c.weights = weights.tolist()
    c.knotvector = knots.tolist()
    return c


@pytest.mark.parametrize("seed, p", [(0, 2), (1, 3), (2, 5)])
def test_points_and_derivatives_match_geomdl(seed, p):
    p, knots, weights, points = random_curve(seed, n=11, p=p)
    c = geomdl_curve(p, knots, weights, points)
    u = np.random.default_rng(seed).uniform(0, 2, 60)
    ours = nurbs.curve_derivs(p, knots, weights, points, u, 2)
    for k, x in enumerate(u):
        ref = np.array(c.derivatives(float(x), order=2))
        scale = np.abs(ref).max(axis=1, keepdims=True) + 1.0
        np.testing.assert_allclose(ours[:, k] / scale, ref / scale, atol=1e-10)


def homogeneous_reference(p, knots, weights, points, u):
    """C, C', C'' by scipy's BSpline on (hB, h) and the quotient rule."""
    pw = np.hstack([points * weights[:, None], weights[:, None]])
    spl = BSpline(knots, pw, p)
    a0, a1 = spl(u), spl.derivative(1)(u)
    a2 = spl.derivative(2)(u) if p >= 2 else np.zeros_like(a0)
    w0, w1, w2 = a0[:, 3:], a1[:, 3:], a2[:, 3:]
    c0 = a0[:, :3] / w0
    c1 = (a1[:, :3] - w1 * c0) / w0
    c2 = (a2[:, :3] - 2 * w1 * c1 - w2 * c0) / w0
    return np.stack([c0, c1, c2])


@pytest.mark.parametrize("seed, p", [(4, 1), (5, 3), (6, 4)])
def test_all_paths_match_scipy_homogeneous(seed, p):
    p, knots, weights, points = random_curve(seed, n=14, p=p, spread=10.0)
    u = np.r_[np.random.default_rng(seed).uniform(0, 2, 200), knots[p + 1:-p - 1], 2.0 - 1e-12]
    ref = homogeneous_reference(p, knots, weights, points, u)
    n_d = min(p, 2)
    scale = np.abs(ref).max(axis=(1, 2))[:, None] + 1.0
    ours = nurbs.curve_derivs(p, knots, weights, points, u, 2)
    sc = scale[:n_d + 1, :, None]
    np.testing.assert_allclose(ours[:n_d + 1] / sc, ref[:n_d + 1] / sc, atol=1e-11)
    pw = np.hstack([points * weights[:, None], weights[:, None]])
    breaks, inv_h, coef = nj.compile_curve(p, knots, weights, points)[:3]
    out = np.empty((3, 3))
    pt = np.empty(3)
    span = pspan = 0
    for k, x in enumerate(u):
        span = nj.find_span(knots, p, x, span)
        nj.point(p, knots, pw, x, span, pt)
        np.testing.assert_allclose(pt, ours[0, k], atol=1e-11)
        pspan = nj.poly_span(breaks, x, pspan)
        np.testing.assert_allclose(nj.poly_point(breaks, inv_h, coef, pspan, x), ours[0, k], atol=1e-10)
        nj.poly_derivs2(breaks, inv_h, coef, pspan, x, out)
        np.testing.assert_allclose(out[:n_d + 1] / scale[:n_d + 1], ours[:n_d + 1, k] / scale[:n_d + 1], atol=1e-10)


def test_span_polynomials_end_exactly_on_control_points():
    p, knots, weights, points = random_curve(7)
    curve = nj.compile_curve(p, knots, weights, points)
    breaks, inv_h, coef = curve[:3]
    np.testing.assert_allclose(nj.poly_point(breaks, inv_h, coef, 0, 0.0), points[0], atol=1e-12)
    last = len(breaks) - 2
    np.testing.assert_allclose(nj.poly_point(breaks, inv_h, coef, last, 2.0), points[-1], atol=1e-11)
    assert (curve.u_min, curve.u_max) == (knots[0], knots[-1]) and np.array_equal(curve.end, points[-1])
    assert curve.polygon_mm == pytest.approx(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:])),
                                             rel=1e-14)


def test_rational_quarter_circle_is_exact():
    """Weights 1, sqrt2/2, 1 give an exact circular arc: a reference independent of any library."""
    pts = np.array([[10.0, 0, 0], [10, 10, 0], [0, 10, 0]])
    w = np.array([1, np.sqrt(0.5), 1])
    knots = np.array([0, 0, 0, 1, 1, 1.0])
    u = np.linspace(0, 1, 101)
    d = nurbs.curve_derivs(2, knots, w, pts, u, 2)
    np.testing.assert_allclose(np.linalg.norm(d[0], axis=1), 10.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ij->i", d[0], d[1]), 0.0, atol=1e-10)  # tangent
    np.testing.assert_allclose(nurbs.curvature(2, knots, w, pts, u), 0.1, rtol=1e-10)
    assert nurbs.arc_length(2, knots, w, pts) == pytest.approx(np.pi * 5, rel=1e-10)
