"""001 rational B-spline approximation and the tolerance-driven fit, against analytic curves,
brute-force distances and geomdl's non-rational least squares."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from ipo.fit.tolerance import FitSettings, fewest_ctrl, max_deviation
from ipo.fit.rational import basis_matrix, evaluate, fit_rational, uniform_knots
from tests.ipo.fit.polyline_fit import fit_polyline


def _arc(radius, a0, a1, n, z=0.0):
    t = np.linspace(a0, a1, n)
    return np.c_[radius * np.cos(t), radius * np.sin(t), np.full(n, z)]


def _point_to_polyline(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Exact distance from each point to a polyline, by brute force over all segments."""
    a, ab = poly[:-1], np.diff(poly, axis=0)
    len2 = np.maximum(np.einsum("sd,sd->s", ab, ab), 1e-300)
    out = []
    for chunk in np.array_split(pts, max(1, len(pts) // 200)):
        t = np.clip(np.einsum("psd,sd->ps", chunk[:, None, :] - a[None], ab) / len2, 0, 1)
        foot = a[None] + t[..., None] * ab[None]
        out.append(np.linalg.norm(chunk[:, None, :] - foot, axis=2).min(axis=1))
    return np.concatenate(out)


def _brute_two_way(curve_pts: np.ndarray, q: np.ndarray) -> float:
    """Hausdorff distance between a densely sampled curve (its fine polyline: sagitta < 1e-5 mm
    in these tests) and the polyline q, both ways, brute force."""
    seg_t = np.linspace(0, 1, 9)
    poly = (q[:-1, None, :] + seg_t[None, :, None] * np.diff(q, axis=0)[:, None, :]).reshape(-1, q.shape[1])
    return float(max(_point_to_polyline(curve_pts, q).max(), _point_to_polyline(poly, curve_pts).max()))


def test_uniform_knots_match_001_range():
    # 001: m control points, order k, parameter range [0, n - k + 2] with n = m - 1
    kn = uniform_knots(8, 3)
    assert kn.tolist() == [0, 0, 0, 0, 1, 2, 3, 4, 5, 5, 5, 5]


def test_basis_matrix_partition_of_unity_and_shape():
    u = np.linspace(0, 5, 37)
    n_mat = basis_matrix(uniform_knots(8, 3), 3, u, 8)
    assert n_mat.shape == (37, 8)
    assert np.allclose(n_mat.sum(axis=1), 1.0)
    assert n_mat[0, 0] == 1.0 and n_mat[-1, -1] == 1.0


def test_quarter_circle_recovers_the_exact_conic():
    # a quarter circle is a rational quadratic with weights (1, cos 45°, 1) and corner control point
    q = _arc(1.0, 0.0, np.pi / 2, 40)[:, :2]
    fit = fit_rational(q, 3, 2, max_iter=200, rel_delta=1e-7)
    dense = evaluate(fit, np.linspace(0, fit.knots[-1], 2001))
    assert np.abs(np.linalg.norm(dense, axis=1) - 1.0).max() < 3e-4
    assert fit.weights[1] == pytest.approx(np.sqrt(0.5), abs=5e-3)
    assert np.allclose(fit.points[1], [1.0, 1.0], atol=5e-3)


def test_ends_are_pinned_exactly():
    q = _arc(7.0, 0.3, 2.5, 60, z=1.5)
    fit = fit_rational(q, 6, 3)
    ends = evaluate(fit, np.array([0.0, fit.knots[-1]]))
    assert np.array_equal(fit.points[0], q[0]) and np.array_equal(fit.points[-1], q[-1])
    assert np.allclose(ends, q[[0, -1]], atol=1e-12, rtol=0)


def test_001_figure_14_points_8_control_points_rms_decreases():
    # 001 Fig. 3: 14 digitised points of a section curve, 8 control points
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 130.0, 14)
    q = np.c_[x, 20 * np.sin(x / 130 * np.pi) ** 2 + 8 * np.exp(-((x - 90) / 15) ** 2), 5 + 0.02 * x]
    q += rng.normal(0.0, 0.05, q.shape)
    fit = fit_rational(q, 8, 3, max_iter=30, rel_delta=1e-4)
    hist = fit.rms_history
    assert len(hist) >= 10
    assert np.all(np.diff(hist) < 0), hist
    assert hist[-1] < 0.3 * hist[0]
    assert np.all(fit.weights > 0) and fit.weights.max() == pytest.approx(1.0)
    # f_l is the RMS of the distances from the data to C(u_j) (001 App. I step 5)
    err = q - evaluate(fit, fit.params)
    assert np.sqrt(np.sum(err**2) / 13) == pytest.approx(hist.min(), rel=1e-9)



def _section_001(seed: int, n: int = 14) -> np.ndarray:
    """The 001 Fig. 3 style section curve: smooth, with 0.05 mm noise."""
    x = np.linspace(0.0, 130.0, n)
    q = np.c_[x, 20 * np.sin(x / 130 * np.pi) ** 2 + 8 * np.exp(-((x - 90) / 15) ** 2), 5 + 0.02 * x]
    return q + np.random.default_rng(seed).normal(0.0, 0.05, q.shape)


def _weights_1_errors(q: np.ndarray, n_ctrl: int, degree: int = 3) -> np.ndarray:
    """|Q_j - C(u_j)| of the plain least-squares B-spline (all weights 1) at chord-length parameters
    with pinned ends, built from scipy's B-spline design matrix (001 App. I step 2)."""
    bspline = pytest.importorskip("scipy.interpolate").BSpline
    knots = uniform_knots(n_ctrl, degree)
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    u = np.minimum(knots[-1] * np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum(), knots[-1])  # rounding
    n_mat = bspline.design_matrix(u, knots, degree).toarray()
    rhs = q - np.outer(n_mat[:, 0], q[0]) - np.outer(n_mat[:, -1], q[-1])
    ctrl = np.vstack([q[0], np.linalg.lstsq(n_mat[:, 1:-1], rhs, rcond=None)[0], q[-1]])
    return np.linalg.norm(q - n_mat @ ctrl, axis=1)


@pytest.mark.parametrize("seed", [7, 11, 23])
def test_as_many_control_points_as_points_interpolates(seed):
    # the weights-1 solve interpolates 14 points with 14 control points; the weight step and the
    # parameter correction used to move away from it (1.1 um off here, 90 um on a surface section)
    q = _section_001(seed)
    assert _weights_1_errors(q, 14).max() < 1e-9
    fit = fit_rational(q, 14, 3)
    assert np.linalg.norm(q - evaluate(fit, fit.params), axis=1).max() < 1e-9


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), n_pts=st.integers(5, 20), data=st.data())
def test_fit_is_never_worse_than_the_weights_1_solve(seed, n_pts, data):
    n_ctrl = data.draw(st.integers(4, n_pts))
    rng = np.random.default_rng(seed)
    q = np.cumsum(rng.normal(0, 1, (n_pts, 3)), axis=0)
    # chord-length parameters can leave a knot span without data (Schoenberg-Whitney fails): the
    # weights-1 solve is then (near) singular and two least-squares codes legitimately disagree on it
    knots = uniform_knots(n_ctrl, 3)
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    assume(np.linalg.cond(basis_matrix(knots, 3, u / u[-1] * knots[-1], n_ctrl)[:, 1:-1]) < 1e6)
    start = _weights_1_errors(q, n_ctrl)
    fit = fit_rational(q, n_ctrl, 3, max_iter=12)
    got = np.linalg.norm(q - evaluate(fit, fit.params), axis=1)
    # the iteration keeps the best f_l (001 App. I step 5, an RMS), so that is what cannot grow;
    # where the weights-1 solve interpolates, its max error of ~0 cannot grow either; the slack is
    # rounding: two least-squares solves of the same interpolation agree to ~1e-12 of the extent
    noise_mm = 1e-9 * np.ptp(q, axis=0).max()
    assert np.sqrt(np.sum(got**2) / (n_pts - 1)) <= np.sqrt(np.sum(start**2) / (n_pts - 1)) * (1 + 1e-9) + noise_mm
    if n_ctrl == n_pts:
        assert got.max() < noise_mm


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n_ctrl=st.integers(4, 9))
def test_weights_stay_positive_with_fixed_scale(seed, n_ctrl):
    rng = np.random.default_rng(seed)
    q = np.cumsum(rng.normal(0, 1, (40, 3)), axis=0)  # a rough random walk: the worst case for weights
    fit = fit_rational(q, n_ctrl, 3, max_iter=12)
    assert np.all(fit.weights > 0)
    assert fit.weights.max() == pytest.approx(1.0)
    assert np.all(np.isfinite(fit.points))


def test_max_deviation_is_a_tight_upper_bound_of_brute_force():
    q = _arc(20.0, 0.0, 1.2, 80) + np.c_[np.zeros(80), np.zeros(80), np.linspace(0, 2, 80)]
    fit = fit_rational(q, 6, 3)
    dense = evaluate(fit, np.linspace(0, fit.knots[-1], 3001))
    brute = _brute_two_way(dense, q)
    checked = max_deviation(fit, q)
    assert brute - 1e-9 <= checked <= brute * 1.02 + 1e-9


@pytest.mark.parametrize("tol_mm", [0.001, 0.01])
def test_ellipse_polyline_fit_stays_within_tolerance_of_polyline_and_ellipse(tol_mm):
    t = np.linspace(0.0, 1.5 * np.pi, 240)
    q = np.c_[12 * np.cos(t), 5 * np.sin(t), np.zeros_like(t)]
    pieces = fit_polyline(q, FitSettings(tol_mm))
    assert pieces[0].first == 0 and pieces[-1].last == len(q) - 1
    assert all(a.last == b.first for a, b in zip(pieces, pieces[1:]))
    fitted = [p for p in pieces if p.fit is not None]
    assert fitted, "an ellipse polyline must be worth fitting"
    sagitta = 12 * (1 - np.cos(np.diff(t).max() / 2)) * (12 / 5) ** 2  # polyline's chord error bound
    for p in fitted:
        sub = q[p.first:p.last + 1]
        dense = evaluate(p.fit, np.linspace(0, p.fit.knots[-1], 2001))
        assert _brute_two_way(dense, sub) <= tol_mm
        # against the analytic ellipse: x^2/a^2 + y^2/b^2 = 1, distance ~ |F| / |grad F|
        f = dense[:, 0] ** 2 / 144 + dense[:, 1] ** 2 / 25 - 1
        grad = np.hypot(2 * dense[:, 0] / 144, 2 * dense[:, 1] / 25)
        assert np.max(np.abs(f) / grad) <= tol_mm + sagitta
    blocks = sum(len(p.fit.points) + 5 if p.fit else p.last - p.first for p in pieces)
    assert blocks < (len(q) - 1) / 4


CONICS = {
    "quarter circle R10": lambda: _arc(10.0, 0.0, np.pi / 2, 120),
    "semicircle R10": lambda: _arc(10.0, 0.0, np.pi, 200),
    "half ellipse 12 x 5": lambda: np.c_[12 * np.cos(np.linspace(0, np.pi, 200)),
                                         5 * np.sin(np.linspace(0, np.pi, 200)), np.zeros(200)],
}


@pytest.mark.parametrize("name", sorted(CONICS))
def test_rational_needs_fewer_control_points_than_non_rational_on_conics(name):
    q = CONICS[name]()
    rational, _ = fewest_ctrl(q, FitSettings(1e-3), 24)
    plain, _ = fewest_ctrl(q, FitSettings(1e-3, rational=False), 24)
    assert len(rational.points) < len(plain.points)
    dense = evaluate(rational, np.linspace(0, rational.knots[-1], 2001))
    assert _brute_two_way(dense, q) <= 1e-3


def test_geomdl_non_rational_least_squares_needs_more_control_points_on_a_semicircle():
    fitting = pytest.importorskip("geomdl.fitting")
    q = CONICS["semicircle R10"]()
    rational, _ = fewest_ctrl(q, FitSettings(1e-3), 24)
    # geomdl's approximate_curve with as many control points misses the tolerance
    curve = fitting.approximate_curve(q.tolist(), 3, ctrlpts_size=len(rational.points))
    curve.sample_size = 2001
    assert _brute_two_way(np.array(curve.evalpts), q) > 1e-3


def test_short_or_straight_polylines_stay_g01():
    q = np.array([[0, 0, 0], [1, 0, 0], [2, 0.5, 0]], dtype=float)
    pieces = fit_polyline(q, FitSettings(0.001))
    assert len(pieces) == 1 and pieces[0].fit is None


def test_bad_input_is_rejected():
    with pytest.raises(ValueError):
        fit_rational(np.zeros((3, 3)), 4, 3)
    with pytest.raises(ValueError):
        fit_rational(np.zeros((10, 3)), 4, 3)
    with pytest.raises(ValueError):
        fit_polyline(_arc(1, 0, 1, 10), FitSettings(0.0))
