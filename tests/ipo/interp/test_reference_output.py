"""Reference-word and reference-pulse outputs (000 §2.3-2.4) against hand-computed values,
analytic circles and a densely sampled NURBS (scipy KD-tree as the brute-force reference)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from ipr.entities import Arc, Nurbs
from ipo.interp.line_arc import ArcStepper
from ipo.nurbs.kernel import curve_points
from ipo.interp.reference_pulse import pulse_deviation_blu, pulse_path, pulses
from ipo.interp.reference_word import checked_points, quantise

BLU_MM = 1e-3


# ---------------------------------------------------------------- reference word

def test_quantise_hand_computed():
    pos = np.array([[0.0014, 0.0, -0.0026], [0.0031, 0.0005, -0.0024]])
    inc, end = quantise(pos, 1e-3, np.array([0, 0, 0]))
    # positions round to (1,0,-3) then (3,0 or 1,-2); 0.5 rounds to even (0)
    assert inc.dtype == np.int64
    assert inc.tolist() == [[1, 0, -3], [2, 0, 1]]
    assert end.tolist() == [3, 0, -2]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quantise_random_walk_sums_exactly(seed):
    rng = np.random.default_rng(seed)
    pos = np.array([12.3456789, -4.0, 250.0]) + np.cumsum(rng.normal(0, 0.037, (20000, 3)), axis=0)
    start_blu = np.array([12000, -4100, 250007])  # the machine stands elsewhere: first increment jumps
    inc, end = quantise(pos, BLU_MM, start_blu)
    commanded = start_blu + np.cumsum(inc, axis=0)
    assert np.array_equal(commanded[-1], end)
    assert np.array_equal(end, [round(c / BLU_MM) for c in pos[-1]])
    assert np.abs(commanded * BLU_MM - pos).max() <= 0.5 * BLU_MM * (1 + 1e-9)
    # chaining chunks gives the same increments as one call
    inc_a, end_a = quantise(pos[:7000], BLU_MM, start_blu)
    inc_b, end_b = quantise(pos[7000:], BLU_MM, end_a)
    assert np.array_equal(np.vstack([inc_a, inc_b]), inc) and np.array_equal(end_b, end)


def test_quantise_circle_within_half_blu():
    arc = Arc(1, (10, 0, 0), (10, 0, 0), (0, 0, 0), "XY", True, 50.0)
    pos = ArcStepper(arc).advance(np.full(1300, 0.05)).pos_mm
    inc, end = quantise(pos, BLU_MM, np.array([10000, 0, 0]))
    assert end.tolist() == [10000, 0, 0] and inc.sum(axis=0).tolist() == [0, 0, 0]
    commanded = np.array([10000, 0, 0]) + np.cumsum(inc, axis=0)
    assert np.abs(commanded * BLU_MM - pos).max() <= 0.5 * BLU_MM


def test_quantise_empty_and_bad_input():
    inc, end = quantise(np.empty((0, 3)), BLU_MM, np.array([5, 6, 7]))
    assert inc.shape == (0, 3) and end.tolist() == [5, 6, 7]
    with pytest.raises(ValueError):
        quantise(np.zeros((2, 2)), BLU_MM, np.array([0, 0, 0]))
    with pytest.raises(ValueError):
        quantise(np.zeros((2, 3)), 0.0, np.array([0, 0, 0]))
    with pytest.raises(ValueError):
        quantise(np.zeros((2, 3)), BLU_MM, np.array([0.0, 0, 0]))
    with pytest.raises(ValueError):
        quantise(np.array([[np.nan, 0, 0]]), BLU_MM, np.array([0, 0, 0]))


def axis_velocities(pos_mm: np.ndarray, feed_mm_s: np.ndarray, start_mm: np.ndarray) -> np.ndarray:
    """Axis velocities (N, 3) in mm/s: V * dX / DS per period (000 eq. 16), 0 where DS = 0; the
    reference word's second half, which the stream carries as the feed and the increments."""
    pos = checked_points(pos_mm, "pos_mm")
    start = np.asarray(start_mm, dtype=np.float64)
    if start.shape != (3,) or not np.isfinite(start).all():
        raise ValueError(f"start_mm must be three finite numbers, got {start_mm!r}")
    feed = np.asarray(feed_mm_s, dtype=np.float64)
    if feed.shape != (len(pos),) or not np.isfinite(feed).all():
        raise ValueError(f"feed_mm_s must be {len(pos)} finite numbers, got shape {feed.shape}")
    delta = np.diff(pos, axis=0, prepend=start[None, :])
    ds = np.sqrt(np.einsum("ij,ij->i", delta, delta))  # 000 eq. 16, DS(j+1)
    scale = np.divide(feed, ds, out=np.zeros_like(ds), where=ds > 0)
    return delta * scale[:, None]  # 000 eq. 16


def test_axis_velocities_eq16_hand_computed():
    pos = np.array([[3.0, 4.0, 0.0], [3.0, 4.0, 0.0], [3.0, 4.0, -2.0]])
    v = axis_velocities(pos, np.array([10.0, 10.0, 6.0]), np.zeros(3))
    np.testing.assert_allclose(v, [[6.0, 8.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -6.0]])
    with pytest.raises(ValueError):
        axis_velocities(pos, np.array([10.0, 10.0]), np.zeros(3))


def test_axis_velocities_circle_speed_and_direction():
    arc = Arc(1, (0, 0, 2), (0, 0, 2), (0, 3, 2), "XY", False, 50.0)
    pos = ArcStepper(arc).advance(np.full(500, 0.05)).pos_mm
    feed = np.full(len(pos), 50.0)
    v = axis_velocities(pos, feed, np.array([0.0, 0.0, 2.0]))
    np.testing.assert_allclose(np.linalg.norm(v[:-1], axis=1), 50.0, rtol=1e-12)
    # in the period's chord direction: v * T reproduces the 0.05 mm chords at T = 1 ms
    chords = np.diff(np.vstack([[0, 0, 2], pos]), axis=0)
    np.testing.assert_allclose(v[:-1] * 1e-3, chords[:-1], atol=1e-12)


# ---------------------------------------------------------------- reference pulse

# The seven axis sets of 000 §2.4: x, y, z, xy, xz, yz, xyz.
SEVEN = {(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1)}


def check_steps(steps):
    assert steps.dtype == np.int8
    assert set(np.unique(steps)) <= {-1, 0, 1}
    assert {tuple(r) for r in (steps != 0).astype(int).tolist()} <= SEVEN


def test_pulses_hand_computed():
    # BLU = 1 mm keeps the halves exact
    pts = np.array([[0.6, 0.2, 0.0], [1.4, 0.6, -0.5], [1.6, 0.4, -0.7], [3.0, 0.4, -0.7]])
    st = pulses(pts, 1.0, np.array([0, 0, 0]))
    # x +0.6; then y +0.6 (x 0.4 and z exactly -0.5 stay); then x +0.6, y -0.6, z -0.7;
    # then x exactly 1.0 ahead: one step leaves it on the point
    assert st.tolist() == [[1, 0, 0], [0, 1, 0], [1, -1, -1], [1, 0, 0]]
    path = pulse_path(np.array([0, 0, 0]), st)
    assert path.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 0, -1], [3, 0, -1]]


def test_pulses_exact_half_does_not_chatter():
    st = pulses(np.array([[0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, -0.5, 0.0]]), 1.0, np.array([0, 0, 0]))
    assert st.tolist() == [[1, 0, 0]]


def per_point_positions(points_mm, start_blu):
    """Chain pulses() one point at a time: the BLU position after each point."""
    cur = np.array(start_blu, dtype=np.int64)
    out = np.empty((len(points_mm), 3), dtype=np.int64)
    for j in range(len(points_mm)):
        cur = pulse_path(cur, pulses(points_mm[j:j + 1], BLU_MM, cur))[-1]
        out[j] = cur
    return out


def circle_case(radius_mm):
    arc = Arc(1, (radius_mm, 0, 0), (radius_mm, 0, 0), (0, 0, 0), "XY", True, 1.0)
    pts = ArcStepper(arc).advance(np.full(int(7 * radius_mm / BLU_MM), BLU_MM)).pos_mm
    start = np.array([round(radius_mm / BLU_MM), 0, 0])
    return pts, start


@pytest.mark.parametrize("radius_mm", [0.02, 1.0])
def test_pulses_on_circle(radius_mm):
    pts, start = circle_case(radius_mm)
    st = pulses(pts, BLU_MM, start)
    check_steps(st)
    path = pulse_path(start, st)
    assert np.array_equal(path[-1], start)  # back where it started
    # the paper's 0.5 BLU holds per axis at every curve point
    after = per_point_positions(pts, start)
    assert np.array_equal(after[-1], path[-1])
    assert np.abs(after - pts / BLU_MM).max() <= 0.5
    # distance from the circle, analytic: | |p| - R | at the path's vertices ...
    r_blu = radius_mm / BLU_MM
    vertex_dev = np.abs(np.hypot(path[:, 0], path[:, 1]) - r_blu).max()
    # ... and brute force along each step (200 samples per step)
    t = np.linspace(0, 1, 201)[:, None, None]
    along = path[:-1][None] + t * (path[1:] - path[:-1])[None]
    seg_dev = np.abs(np.hypot(along[..., 0], along[..., 1]) - r_blu).max()
    th = np.linspace(0, 2 * np.pi, int(2 * np.pi * r_blu * 10) + 1)  # 0.1 BLU apart
    dense = np.c_[radius_mm * np.cos(th), radius_mm * np.sin(th), np.zeros_like(th)]
    assert pulse_deviation_blu(path, dense, BLU_MM, segments=False) == pytest.approx(vertex_dev, abs=1e-4)
    assert pulse_deviation_blu(path, dense, BLU_MM) == pytest.approx(seg_dev, abs=2e-3)
    # The true figure: above the paper's 0.5 BLU but within the per-axis bound sqrt(2)/2.
    assert 0.5 < seg_dev <= np.sqrt(2) / 2


def sample_by_length(nurbs, spacing_mm, n_dense=400_001):
    """Dense samples of the curve and points on it every spacing_mm of arc length."""
    u = np.linspace(nurbs.knots[0], nurbs.knots[-1], n_dense)
    dense = curve_points(nurbs.degree, nurbs.knots, nurbs.weights, nurbs.points, u)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))]
    targets = np.arange(spacing_mm, s[-1], spacing_mm)
    u_t = np.r_[np.interp(targets, s, u), u[-1]]
    return dense, curve_points(nurbs.degree, nurbs.knots, nurbs.weights, nurbs.points, u_t)


def test_pulses_on_3d_nurbs():
    pts = np.array([[0, 0, 0], [0.3, 0.5, 0.1], [0.8, 0.6, 0.4], [1.0, 0.1, 0.5],
                    [1.3, -0.3, 0.2], [1.6, 0.2, -0.2], [1.5, 0.7, 0.1], [1.9, 0.9, 0.3]])
    w = np.array([1.0, 0.6, 2.0, 1.0, 1.5, 0.7, 1.2, 1.0])
    knots = np.r_[np.zeros(4), 0.2, 0.4, 0.5, 0.7, np.ones(4)]
    for a in (pts, w, knots):
        a.flags.writeable = False
    nurbs = Nurbs(1, 3, knots, w, pts, 10.0)
    dense, at_blu = sample_by_length(nurbs, BLU_MM)
    start = np.round(np.array(nurbs.start) / BLU_MM).astype(np.int64)
    st = pulses(at_blu, BLU_MM, start)
    check_steps(st)
    used = {tuple(r) for r in (st != 0).astype(int).tolist()}
    assert (1, 1, 1) in used and len(used) == 7  # the curve exercises every combination
    path = pulse_path(start, st)
    assert np.array_equal(path[-1], np.round(pts[-1] / BLU_MM))
    # brute-force reference for the vertices: nearest dense sample (samples ~0.01 BLU apart)
    ref = cKDTree(dense / BLU_MM).query(path)[0].max()
    dev_v = pulse_deviation_blu(path, dense[::8], BLU_MM, segments=False)
    assert dev_v == pytest.approx(ref, abs=2e-3)
    dev = pulse_deviation_blu(path, dense[::8], BLU_MM)
    assert dev >= dev_v
    # measured 0.81 BLU: the paper's 0.5 BLU fails; within the per-axis 3-D bound sqrt(3)/2
    assert 0.5 < dev <= np.sqrt(3) / 2


def test_coarse_points_get_several_unit_steps():
    st = pulses(np.array([[0.0052, -0.0021, 0.0]]), BLU_MM, np.array([0, 0, 0]))
    check_steps(st)
    assert st.tolist() == [[1, -1, 0], [1, -1, 0], [1, 0, 0], [1, 0, 0], [1, 0, 0]]


def test_pulse_bad_input():
    with pytest.raises(ValueError):
        pulses(np.zeros((3, 2)), BLU_MM, np.array([0, 0, 0]))
    with pytest.raises(ValueError):
        pulses(np.zeros((3, 3)), -1.0, np.array([0, 0, 0]))
    with pytest.raises(ValueError):
        pulses(np.zeros((3, 3)), BLU_MM, np.array([0.5, 0, 0]))
    with pytest.raises(ValueError):
        pulse_deviation_blu(np.zeros((0, 3), dtype=np.int64), np.zeros((5, 3)), BLU_MM)
    with pytest.raises(ValueError):
        pulse_deviation_blu(np.zeros((2, 3), dtype=np.int64), np.zeros((1, 3)), BLU_MM)
