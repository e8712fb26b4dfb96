"""S-curve mode's curvature-continuous chains through runs of short lines
(ipo.feed.blends.g2_chains), against independent references: the midpoint curvatures against
numpy's least squares of the same objective, the quintics' curvature through scipy's BSpline
derivatives, the programmed polyline by brute-force distance both ways, v/a/j by finite
differences of the per-period positions, and the run's worth against the same run with the
chains switched off."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import BSpline

import ipo.feed.pieces as pieces
from ipo.feed.blends.g2_chains import (_CURVE_POINTS, _MU2, _SEARCH, _midpoint_curvatures, _nearest_chord,
                                     chain_runs)
from ipo.segments import segment_distance
from ipr.entities import Line, PathControl
from tests.ipo.feed.test_g2_joint_blend import BEZIER5, assert_within_p, built
from tests.ipo.feed.test_jerk_profile import CFG, assert_within_limits, run


def polyline(pts, tol, feed=100.0):
    p = PathControl(blend_tol_mm=tol)
    return [Line(i + 1, tuple(a), tuple(b), feed, p) for i, (a, b) in enumerate(zip(pts[:-1], pts[1:]))]


def noisy_curve(rng, n=60, tol=0.1):
    """A CAM polyline along a curve of varying curvature (g1_lhchips4's kind): moves of
    0.1-1.5 mm turning by up to 4 degrees either way around a slow drift, coordinates
    rounded to 1 um, rising slightly in Z."""
    length = np.exp(rng.uniform(np.log(0.1), np.log(1.5), n))
    drift = np.cumsum(rng.uniform(-0.5, 1.5, n) * np.radians(2.0))
    head = drift + rng.uniform(-1, 1, n) * np.radians(2.0)
    steps = np.c_[length * np.cos(head), length * np.sin(head), rng.uniform(-0.02, 0.02, n) * length]
    pts = np.round(np.vstack([[0.0, 0.0, 0.0], np.cumsum(steps, axis=0)]), 3)
    return polyline(pts, tol)


def curvature(ctrl, u):
    spl = BSpline(BEZIER5, ctrl, 5)
    d1, d2 = spl.derivative(1)(u), spl.derivative(2)(u)
    return np.cross(d1, d2), np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3


def without_chains(monkeypatch, ents):
    with monkeypatch.context() as m:
        m.setattr(pieces, "chain_runs", lambda small, slow: np.zeros(len(small), bool))
        return run(ents)


def test_chain_runs_keep_whole_runs_that_hold_a_slow_corner():
    small = np.array([1, 1, 0, 1, 1, 1, 0, 1, 1], bool)
    slow = np.array([0, 0, 1, 0, 0, 1, 0, 0, 0], bool)
    np.testing.assert_array_equal(chain_runs(small, slow), [0, 0, 0, 1, 1, 1, 0, 0, 0])


@pytest.mark.parametrize("seed", range(3))
def test_midpoint_curvatures_solve_the_stated_least_squares(seed):
    """The midpoint curvature vectors of a run against numpy's lstsq of the docstring's
    objective (the run's inner midpoints free, the others 0), then without the part along the
    move."""
    rng = np.random.default_rng(seed)
    n = 12
    unit = rng.normal(size=(n, 3))
    unit /= np.linalg.norm(unit, axis=1)[:, None]
    length = rng.uniform(0.1, 2.0, n)
    chain = np.ones(n - 1, bool)
    chain[6] = False  # two runs: corners 0-5 and 7-10
    free = [m for m in range(1, n - 1) if chain[m - 1] and chain[m]]
    col = {m: i for i, m in enumerate(free)}
    rows, rhs = [], []
    for j in np.nonzero(chain)[0]:
        ell = 0.5 * (length[j] + length[j + 1])
        c = (unit[j + 1] - unit[j]) / ell
        for weights, target in (((0.5, 0.5), c), ((-np.sqrt(_MU2), np.sqrt(_MU2)), np.zeros(3))):
            row = np.zeros(len(free))
            for m, w in zip((j, j + 1), weights):
                if m in col:
                    row[col[m]] = w / ell
            rows.append(row)
            rhs.append(target / ell)
    sol = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    want = np.zeros((n, 3))
    for m, i in col.items():
        want[m] = sol[i] - (sol[i] @ unit[m]) * unit[m]
    np.testing.assert_allclose(_midpoint_curvatures(unit, length, chain), want, rtol=1e-9, atol=1e-12)


def test_a_polygon_along_a_circle_becomes_one_curve_of_its_curvature():
    """A 1-degree polygon of R 10 (0.17 mm moves, circle360's kind) under G64 P0.01: every
    corner takes a quintic from midpoint to midpoint, consecutive quintics meet at the same
    curvature vector (scipy's derivatives at both ends), and more than 5 mm (30 moves) from the
    run's ends the curvature stays within 1 % of 1/10: nearer, the smoothing fit
    (ipo.feed.blends.chain_fit) eases it in from the ends' flat midpoints (as the line-line
    quintic), over- and undershooting 1/10 on the way."""
    ang = np.radians(np.arange(0, 91))
    ents = polyline(np.c_[10 * np.cos(ang), 10 * np.sin(ang), np.zeros(len(ang))], 0.01, feed=50.0)
    pc, quintics = built(ents)
    assert len(quintics) == 89
    ends = [curvature(np.asarray(q.points, float), np.array([0.0, 1.0])) for q in quintics]
    for (cross_a, _), (cross_b, _) in zip(ends[:-1], ends[1:]):
        np.testing.assert_allclose(cross_a[1] / np.linalg.norm(cross_a[1]), cross_b[0] / np.linalg.norm(cross_b[0]),
                                   atol=1e-9)
    k = np.array([e[1] for e in ends])
    np.testing.assert_allclose(k[:-1, 1], k[1:, 0], rtol=1e-9)
    inner = np.concatenate([curvature(np.asarray(q.points, float), np.linspace(0, 1, 33))[1] for q in quintics[30:-30]])
    np.testing.assert_allclose(inner, 0.1, rtol=0.01)


@pytest.mark.parametrize("seed", range(4))
def test_noisy_curves_keep_the_limits_and_p_and_run_faster(seed, monkeypatch):
    """CAM-like polylines (noisy_curve) under P 0.02-0.1: the chains are taken, the run keeps
    v/a/j (finite differences, BLU slack derived in assert_within_limits) and P + delta both ways
    by brute force, ends on the program, and takes fewer periods than without the chains."""
    rng = np.random.default_rng(100 + seed)
    tol = float(rng.choice([0.02, 0.05, 0.1]))
    ents = noisy_curve(rng, tol=tol)
    _, quintics = built(ents)
    assert len(quintics) > 0.8 * (len(ents) - 1)
    pos = run(ents)
    assert_within_limits(pos)
    assert_within_p(pos, ents, tol)
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=1e-6)
    assert len(pos) < len(without_chains(monkeypatch, ents))  # 0.885-0.99x on seeds 100-107


def test_a_run_crosses_a_feed_change_at_the_lower_feed():
    """A quintic takes half of each of its moves: on the polygon of R 10 with F6000 on its first
    45 moves and F1200 after, the run goes on through the change (its quintics meet at about
    1/10 there, scipy's derivatives) and the quintic across it has the lower feed."""
    ang = np.radians(np.arange(0, 91))
    pts = np.c_[10 * np.cos(ang), 10 * np.sin(ang), np.zeros(len(ang))]
    ents = polyline(pts, 0.01, feed=100.0)
    ents = ents[:45] + [dataclasses.replace(e, feed_mm_s=20.0) for e in ents[45:]]
    pc, quintics = built(ents)
    mids = 0.5 * (pts[:-1] + pts[1:])
    spans = [(int(np.argmin(np.linalg.norm(mids - q.points[0], axis=1))),
              int(np.argmin(np.linalg.norm(mids - q.points[-1], axis=1)))) for q in quintics]
    by_span = dict(zip(spans, quintics))
    k = curvature(np.asarray(by_span[(44, 45)].points, float), np.array([0.0, 1.0]))[1]
    np.testing.assert_allclose(k, 0.1, rtol=0.05)
    assert [by_span[s].feed_mm_s for s in ((43, 44), (44, 45), (45, 46))] == [100.0, 20.0, 20.0]
    pos = run(ents)
    v = np.linalg.norm(np.diff(pos, axis=0), axis=1) / CFG.period_s
    past = np.arctan2(pos[:-1, 1], pos[:-1, 0]) > np.radians(44.5)  # periods from the quintic's start on
    assert v[past].max() <= 20.0 + 2 * CFG.blu_mm / CFG.period_s  # BLU rounding of both ends


def test_nearest_chord_is_the_window_search_to_the_bit():
    """The pruned search gives the chord and distance of measuring every chord of the window
    (the first nearest of ties: points on the polyline's vertices and on its chords included)."""
    rng = np.random.default_rng(7)
    for trial in range(300):
        pts = np.cumsum(rng.normal(size=(_CURVE_POINTS, 3)) * rng.choice([1e-3, 0.1, 1.0]), axis=0)
        pts += rng.normal(size=3) * rng.choice([0.0, 1.0, 500.0])
        chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        size = float(np.abs(pts).max())
        for _ in range(20):
            near = int(rng.integers(0, _CURVE_POINTS - 1))
            i = int(rng.integers(0, _CURVE_POINTS - 1))
            q = rng.choice([pts[i], pts[i] + rng.random() * (pts[i + 1] - pts[i]),
                            pts[i] + rng.normal(size=3) * float(chord[i])])
            want_near, want = near, np.inf
            for k in range(max(near - _SEARCH, 0), min(near + _SEARCH, _CURVE_POINTS - 1)):
                d = segment_distance(q, pts[k], pts[k + 1])
                if d < want:
                    want_near, want = k, d
            assert _nearest_chord(q, pts, chord, near, size) == (want_near, want)
