"""The faster pieces of the corner check next to arcs (issue 22: 17,597 such corners in
g1_stellabee1 cost ~3 s of NumPy calls): each gives the same bits as the array expression it
replaced, and the right number against an independent computation.

- cubic_points: de Casteljau's construction (a different algorithm) and the Bernstein sum;
- blend_deviation: brute-force distances to densely sampled segments, and numpy's
  minimum / max / norm expression bit for bit, NaN included;
- polyline_distance, which skips the blocks of segments whose bounding box is farther than the
  best so far: the minimum over every segment bit for bit, and numpy's closest points;
- bezier_points_runs (an emission batch's blends in one call): bezier_points_at blend by blend;
- analytic.points_along_piece / point_tangent: evaluate and frame with numpy's linspace, bit for bit,
  and the points on the circle (radius, angle) by hand.
"""
from __future__ import annotations

import numpy as np
import pytest

from ipo.feed.analytic import Geometry, evaluate, frame, point_tangent, points_along_piece
from ipo.feed.blends.compiled import (bezier_points_at, bezier_points_runs, bezier_tables, blend_deviation,
                                      cubic_points, polyline_distance)
from ipo.feed.sampling import GAUSS_W, GAUSS_X
from ipo.segments import segment_distance
from ipo.feed.blends.curve_corner import _CHECK_BASIS, _bernstein3, arc_cubic
from ipo.numpy_kernels import dot3

RNG = np.random.default_rng(22)


def _de_casteljau(ctrl: np.ndarray, u: float) -> np.ndarray:
    p = ctrl.copy()
    for k in range(3, 0, -1):
        p = (1 - u) * p[:k] + u * p[1:k + 1]
    return p[0]


def test_cubic_points_are_the_bezier_and_the_array_expressions_bits():
    for _ in range(50):
        ctrl = RNG.normal(size=(4, 3)) * 10 ** RNG.uniform(-3, 2)
        q = cubic_points(_CHECK_BASIS, ctrl)
        u = np.linspace(0.0, 1.0, len(_CHECK_BASIS))
        ref = np.array([_de_casteljau(ctrl, x) for x in u])
        np.testing.assert_allclose(q, ref, rtol=0, atol=1e-13 * np.abs(ctrl).max())
        assert np.array_equal(q[[0, -1]], ctrl[[0, 3]])
        b = _bernstein3(u)  # what curve_corner evaluated before: the same products, summed in order
        expr = b[:, :1] * ctrl[0] + b[:, 1:2] * ctrl[1] + b[:, 2:3] * ctrl[2] + b[:, 3:] * ctrl[3]
        assert np.array_equal(q, expr)


def _brute(q: np.ndarray, poly: np.ndarray, samples: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, samples)[:, None]
    dense = np.vstack([a + t * (b - a) for a, b in zip(poly[:-1], poly[1:])])
    return np.array([np.linalg.norm(dense - p, axis=1).min() for p in q])


def _numpy_form(q, side_a, side_b, corner) -> float:
    """What curve_corner.deviation computed before the kernel."""
    from_path = np.minimum(polyline_distance(q, side_a), polyline_distance(q, side_b))
    return max(float(from_path.max()), float(np.linalg.norm(q - corner, axis=1).min()))


def test_blend_deviation_against_brute_force_and_numpys_bits():
    for _ in range(5):
        q = RNG.normal(size=(33, 3))
        side_a, side_b = np.cumsum(RNG.normal(size=(65, 3)) * 0.1, axis=0), RNG.normal(size=(2, 3))
        corner = RNG.normal(size=3)
        got = blend_deviation(q, side_a, side_b, corner)
        from_path = np.minimum(_brute(q, side_a, 2001), _brute(q, side_b, 20001))
        expected = max(from_path.max(), np.linalg.norm(q - corner, axis=1).min())
        assert got <= expected and got == pytest.approx(expected, abs=2e-4)  # the samples' spacing / 2
        assert got == _numpy_form(q, side_a, side_b, corner)


def test_blend_deviation_treats_nan_as_numpys_expression_did():
    q = RNG.normal(size=(33, 3))
    side = RNG.normal(size=(5, 3))
    corner = np.array([np.nan, 0.0, 0.0])
    assert blend_deviation(q, side, side, corner) == _numpy_form(q, side, side, corner)
    q[7, 1] = np.nan
    assert blend_deviation(q, side, side, np.zeros(3)) == _numpy_form(q, side, side, np.zeros(3))


def _closest(q: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each q from the polyline: the closest point of every segment, in numpy."""
    a, ab = poly[:-1], np.diff(poly, axis=0)
    out = []
    for p in q:
        f = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
        out.append(np.linalg.norm(a + f[:, None] * ab - p, axis=1).min())
    return np.array(out)


def test_polyline_distance_is_the_minimum_over_every_segment():
    """Long polylines measured against each other (the G2 joints' case: the skipping matters)
    and scattered points, at coordinates up to 500 mm: the smallest segment_distance over all
    segments, to the bit, and numpy's closest points to rounding; a NaN point is skipped as
    the minimum skipped it."""
    worst = 0.0
    for k in range(12):
        t = np.linspace(0.0, RNG.uniform(0.5, 6.0), int(RNG.integers(2, 700)))
        r = 10 ** RNG.uniform(-2, 2)
        poly = np.c_[r * np.cos(t), r * np.sin(t), 0.05 * r * t] + RNG.uniform(-500, 500, 3)
        near = poly[RNG.integers(0, len(poly), 40)] + RNG.normal(size=(40, 3)) * r * 10 ** RNG.uniform(-9, -1)
        q = np.vstack([near, RNG.normal(size=(10, 3)) * 3 * r + poly.mean(axis=0)])
        if k % 4 == 3:
            poly[len(poly) // 2, 1] = np.nan
        got = polyline_distance(q, poly)
        every = [min([segment_distance(p, poly[i], poly[i + 1]) for i in range(len(poly) - 1)], default=np.inf,
                     key=lambda d: (d != d, d)) for p in q]  # NaN distances lose, as in the kernel
        assert got.tobytes() == np.array(every).tobytes()
        if k % 4 != 3:
            worst = max(worst, float(np.max(np.abs(got - _closest(q, poly)) / (1.0 + np.abs(poly).max()))))
    assert worst < 1e-13


def test_blend_points_of_many_blends_in_one_call_are_each_blends_bits():
    ctrls = [np.cumsum(RNG.normal(size=(n, 3)), axis=0) for n in (4, 6, 4, 4, 6)]
    tabs = []
    for c in ctrls:
        s, u, _, _, _, first, ok = bezier_tables(c[None], 16, 6, 0.03, 2.0)
        assert ok[0]
        tabs.append((s, u))
    arc = [np.sort(RNG.uniform(-0.1, 1.05, int(RNG.integers(1, 30)))) * s[-1] for s, _ in tabs]
    first = lambda parts: np.cumsum([0] + [len(x) for x in parts])
    got = bezier_points_runs(np.concatenate(ctrls), first(ctrls), np.concatenate([s for s, _ in tabs]),
                             np.concatenate([u for _, u in tabs]), first([s for s, _ in tabs]), np.concatenate(arc),
                             first(arc), GAUSS_X, GAUSS_W)
    want = np.vstack([bezier_points_at(c, s, u, a, GAUSS_X, GAUSS_W) for c, (s, u), a in zip(ctrls, tabs, arc)])
    assert got.tobytes() == want.tobytes()


def _helix() -> Geometry:
    """Piece 0 a helix of radius 2 about z by arc length (omega 0.4 rad/mm: 0.8 mm/mm about the
    axis, 0.6 mm/mm along it); piece 1 a line."""
    e1 = np.array([[1.0, 0, 0], [1, 0, 0]])
    e2 = np.array([[0.0, 1, 0], [0, 1, 0]])
    return Geometry(c=np.array([[1.0, -1, 0.5], [0, 0, 0]]), e1=e1, e2=e2,
                    w=np.array([[0.0, 0, 0.6], [0.6, 0.8, 0]]), radius=np.array([2.0, 0.0]),
                    dr=np.zeros(2), omega=np.array([0.4, 0.0]))


@pytest.mark.parametrize("i", [0, 1])
@pytest.mark.parametrize("base, sign", [(0.0, 1.0), (3.7, -1.0)])
@pytest.mark.parametrize("x, n", [(1.3, 65), (0.2, 2), (0.0, 65), (1e-310, 65), (0.5, 1)])
def test_points_along_piece_is_evaluate_over_numpys_linspace(i, base, sign, x, n):
    g = _helix()
    got = points_along_piece(g, i, base, sign, x, n)
    assert np.array_equal(got, evaluate(g, np.full(n, i), base + sign * np.linspace(0.0, x, n)))
    if i == 0:  # on the helix: 2 mm from its axis, at angle omega sigma, z = 0.5 + 0.6 sigma
        sigma = base + sign * np.linspace(0.0, x, n)
        np.testing.assert_allclose(np.hypot(got[:, 0] - 1, got[:, 1] + 1), 2.0, rtol=1e-14)
        np.testing.assert_allclose(got[:, 0], 1 + 2 * np.cos(0.4 * sigma), atol=1e-14)
        np.testing.assert_allclose(got[:, 2], 0.5 + 0.6 * sigma, atol=1e-14)


@pytest.mark.parametrize("i", [0, 1])
def test_point_tangent_is_evaluate_and_frame(i):
    g = _helix()
    for sigma in (0.0, 0.7, 5.25):
        p, t = point_tangent(g, i, sigma)
        assert np.array_equal(p, evaluate(g, np.array([i]), np.array([sigma]))[0])
        assert np.array_equal(t, frame(g, np.array([i]), np.array([sigma]))[0][0])
        assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-15)
        if i == 0:  # d/dsigma of the helix: 0.8 (-sin, cos) about the axis, 0.6 along it
            np.testing.assert_allclose(t, [-0.8 * np.sin(0.4 * sigma), 0.8 * np.cos(0.4 * sigma), 0.6], atol=1e-15)


def test_arc_cubic_keeps_the_bits_of_clip_and_the_length_and_makes_the_arcs_handles():
    for k in range(2000):
        a, b = RNG.normal(size=3) * 10 ** RNG.uniform(-3, 2), RNG.normal(size=3)
        ta, tb = RNG.normal(size=3), RNG.normal(size=3)
        ta, tb = ta / np.linalg.norm(ta), tb / np.linalg.norm(tb)
        tb = ta.copy() if k % 3 == 0 else (-ta if k % 7 == 0 else tb)  # dot(ta, tb) at +-1 and beyond by rounding
        phi = np.arccos(np.clip(dot3(ta, tb), -1.0, 1.0))
        h = np.sqrt(dot3(b - a, b - a)) / (3.0 * np.cos(0.25 * phi) ** 2)
        assert np.array_equal(arc_cubic(a, ta, b, tb), np.array([a, a + h * ta, b - h * tb, b]))
    # a quarter circle of radius 1: the handles 4/3 tan(pi/8), the midpoint on the circle and at
    # most 0.027253 % off it elsewhere (the known error of this cubic)
    ctrl = arc_cubic(np.array([1.0, 0, 0]), np.array([0.0, 1, 0]), np.array([0.0, 1, 0]), np.array([-1.0, 0, 0]))
    assert ctrl[1] == pytest.approx([1.0, 4 / 3 * np.tan(np.pi / 8), 0], abs=1e-15)
    assert np.linalg.norm(_de_casteljau(ctrl, 0.5)) == pytest.approx(1.0, abs=1e-15)
    radial = [np.linalg.norm(_de_casteljau(ctrl, u)) - 1 for u in np.linspace(0, 1, 2001)]
    assert max(radial) == pytest.approx(2.7253e-4, abs=1e-8)
