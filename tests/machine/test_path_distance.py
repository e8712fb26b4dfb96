"""machine.path_distance against a brute-force distance to every segment, and an analytic raster whose
two versions differ in length by far more than any arc-length window (the drift `vcnc compare` had)."""
import math

import numpy as np
import pytest

from machine import path_distance
from machine.path_distance import polyline_distances_mm


def brute_mm(points, path):
    a, b = path[:-1], path[1:]
    d = b - a
    out = np.empty(len(points))
    for i, q in enumerate(points):
        t = np.clip(np.einsum("ij,ij->i", q - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1)
        out[i] = np.linalg.norm(q - a - t[:, None] * d, axis=1).min()
    return out


def random_path(rng, m, scale):
    steps = rng.normal(size=(m, 3)) * rng.choice([1e-3, 0.05, 1.0, 5.0], size=(m, 1)) * scale
    steps[rng.random(m) < 0.1] = 0.0  # standing still
    return np.cumsum(steps, axis=0)


@pytest.mark.parametrize("seed", range(4))
def test_random_paths_match_brute_force(seed):
    rng = np.random.default_rng(seed)
    path = random_path(rng, 400, 1.0)
    near = path[rng.integers(0, len(path), 300)] + rng.normal(size=(300, 3)) * 0.05
    far = rng.normal(size=(50, 3)) * 30.0
    points = np.vstack([near, far, path[:20]])
    assert np.allclose(polyline_distances_mm(points, path), brute_mm(points, path), rtol=0, atol=1e-12)


@pytest.mark.parametrize("first_k, ball_k", [(2, 2), (2, 8)])
def test_every_branch_is_exact(monkeypatch, first_k, ball_k):
    """Few candidates first, so that points reach the ball query and the all-pieces branch."""
    monkeypatch.setattr(path_distance, "FIRST_K", first_k)
    monkeypatch.setattr(path_distance, "BALL_K", ball_k)
    rng = np.random.default_rng(7)
    path = random_path(rng, 200, 1.0)
    points = np.vstack([path + rng.normal(size=path.shape) * 0.3, rng.normal(size=(40, 3)) * 20])
    assert np.allclose(polyline_distances_mm(points, path), brute_mm(points, path), rtol=0, atol=1e-12)
    assert np.allclose(polyline_distances_mm(points, path[:3]), brute_mm(points, path[:3]), rtol=0, atol=1e-12)


def test_degenerate_paths():
    q = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    assert polyline_distances_mm(q, np.zeros((1, 3))).tolist() == [5.0, 0.0]
    assert polyline_distances_mm(q, np.zeros((5, 3))).tolist() == [5.0, 0.0]


def raster(passes, length_mm, pick_mm, chamfer_mm, step_mm, chamfered=0):
    """A zig-zag raster sampled every step_mm (as periods are), its first `chamfered` corners cut by
    45-degree chamfers of legs chamfer_mm."""
    corners = []
    for k in range(passes):
        xs = (0.0, length_mm) if k % 2 == 0 else (length_mm, 0.0)
        corners += [(xs[0], k * pick_mm), (xs[1], k * pick_mm)]
    corners = np.array(corners)
    if chamfered:
        cut = [corners[0]]
        for i in range(1, chamfered + 1):
            u = corners[i] - corners[i - 1]
            v = corners[i + 1] - corners[i]
            cut += [corners[i] - chamfer_mm * u / np.linalg.norm(u), corners[i] + chamfer_mm * v / np.linalg.norm(v)]
        corners = np.array(cut + list(corners[chamfered + 1:]))
    pts = [corners[0]]
    for a, b in zip(corners[:-1], corners[1:]):
        n = max(1, math.ceil(np.linalg.norm(b - a) / step_mm))
        pts.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    pts = np.vstack(pts)
    return np.column_stack([pts, np.zeros(len(pts))])


def test_raster_against_its_chamfered_copy():
    """Sharp raster a, the same raster with its first half's corners cut by 0.05 mm chamfers b: the largest
    distance from a to b is a corner's to its chamfer, c / sqrt 2; from b to a a chamfer's middle to the
    corner's legs, c / 2. The paths differ in length by (2 - sqrt 2) c a corner, 5.8 mm over the first half
    and none over the second: matching points by their proportional arc length, as compare did, put them
    ~2.9 mm apart in the middle, beyond its 2 mm window (it reported 0.90 mm)."""
    c = 0.05
    a = raster(200, 10.0, 0.2, 0.0, 0.05)
    b = raster(200, 10.0, 0.2, c, 0.05, chamfered=199)
    length = [np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in (a, b)]
    assert length[0] - length[1] == pytest.approx(199 * (2 - math.sqrt(2)) * c, rel=1e-9)
    assert polyline_distances_mm(a, b).max() == pytest.approx(c / math.sqrt(2), abs=1e-12)
    assert polyline_distances_mm(b, a).max() == pytest.approx(c / 2, abs=1e-12)
