"""The smoothing fit of the G2 chains' runs (ipo.feed.blends.chain_fit), against independent
references: the fit against numpy's least squares of the stated objective (its third divided
differences from the interpolating cubics' Vandermonde systems), the bound and the kept ends as
hard properties, and on a line that meets an arc within one move: the curvature's rate through
scipy's BSpline derivatives, P both ways by brute force, v/a/j by finite differences and the run's
periods, each against the same run through the programmed midpoints."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

import ipo.feed.blends.g2_chains as g2_chains
import ipr
from ipo.contracts import PeriodBatch
from ipo.feed.blends.chain_fit import FIT_SHARE, SMOOTH_MM, _fit, fitted_midpoints
from ipo.feed.planner import plan_periods
from ipr.entities import Arc, Line, Rapid
from tests.ipo.feed.test_g2_chain import curvature, polyline
from tests.ipo.feed.test_g2_joint_blend import BEZIER5, assert_within_p, built
from tests.ipo.feed.test_jerk_profile import CFG, assert_within_limits, run

_SPACING_MIN_MM = 0.05  # as chain_fit's: spacings below it count as this


def _lstsq_fit(p, lam, n_lo, n_hi):
    """The stated objective solved by numpy: rows sqrt(w_i) (q_i - p_i) and sqrt(lam h_r) times
    6 x the third divided difference, i.e. 6 x the leading coefficient of the cubic through four
    consecutive points (from the inverse of their Vandermonde matrix), the kept points fixed."""
    m = len(p)
    s = np.concatenate([[0.0], np.cumsum(np.maximum(np.linalg.norm(np.diff(p, axis=0), axis=1), _SPACING_MIN_MM))])
    w = 0.5 * (s[np.minimum(np.arange(m) + 1, m - 1)] - s[np.maximum(np.arange(m) - 1, 0)])
    free = np.arange(n_lo, m - n_hi)
    rows, rhs = [], []
    for i in free:
        row = np.zeros(m)
        row[i] = np.sqrt(w[i])
        rows.append(row)
        rhs.append(np.sqrt(w[i]) * p[i])
    for r in range(m - 3):
        lead = np.linalg.inv(np.vander(s[r:r + 4], 4))[0]  # the cubic's s^3 coefficient from its values
        row = np.zeros(m)
        row[r:r + 4] = np.sqrt(lam * (s[r + 3] - s[r]) / 3.0) * 6.0 * lead
        rows.append(row)
        rhs.append(np.zeros(3))
    a, b = np.array(rows), np.array(rhs)
    kept = np.setdiff1d(np.arange(m), free)
    sol = np.linalg.lstsq(a[:, free], b - a[:, kept] @ p[kept], rcond=None)[0]
    q = p.copy()
    q[free] = sol
    return q


@pytest.mark.parametrize("seed", range(3))
def test_the_fit_solves_the_stated_least_squares(seed):
    """Random 3-D points 0.02-1 mm apart (spacings under the floor too), no bound in reach."""
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.uniform(0.02, 1.0, (40, 1)) * rng.normal(size=(40, 3)) / np.sqrt(3), axis=0)
    lam = 1.5**6
    q = np.empty_like(p)
    _fit(p, 1e9, lam, 3, 3, q)
    np.testing.assert_allclose(q, _lstsq_fit(p, lam, 3, 3), atol=1e-9)


def test_the_fit_keeps_its_bound_and_its_ends():
    """Points of a noisy zigzag under a bound far tighter than the fit would move them: every
    point within the bound (the reweighting and the last pull-back), the kept ones exact."""
    rng = np.random.default_rng(7)
    t = np.linspace(0, 20, 81)
    p = np.c_[t, 0.3 * (-1.0) ** np.arange(81) + rng.normal(0, 0.05, 81), np.zeros(81)]
    q = np.empty_like(p)
    _fit(p, 0.02, 2.0**6, 3, 3, q)
    moved = np.linalg.norm(q - p, axis=1)
    assert moved.max() <= 0.02 * (1 + 1e-12)
    assert moved.max() > 0.019  # the bound is what held it
    np.testing.assert_array_equal(q[:3], p[:3])
    np.testing.assert_array_equal(q[-3:], p[-3:])


def line_into_arc(tol):
    """CAM-like: 0.5 mm moves along a line, then 0.2 mm moves around a quarter of R 2.5 (4.6
    degrees each; curvature 0 to 0.4 /mm within one move), then a line again, under G64 P tol."""
    turn = 0.2 / 2.5
    pts = [np.array([-5.0 + 0.5 * i, 0.0, 0.0]) for i in range(11)]
    head = 0.0
    while head < np.pi / 2 - 1e-9:
        head += turn
        pts.append(pts[-1] + 0.2 * np.array([np.cos(head - turn / 2), np.sin(head - turn / 2), 0.0]))
    for _ in range(10):
        pts.append(pts[-1] + 0.5 * np.array([np.cos(head), np.sin(head), 0.0]))
    return polyline(np.round(np.array(pts), 3), tol)


def _programmed(start, unit, length, chain, tol, share, lam):
    return start + 0.5 * length[:, None] * unit, unit.copy()


def test_a_line_into_an_arc_eases_its_curvature_within_p_and_runs_faster(monkeypatch):
    """The chain over the fitted points changes its curvature at about half the rate the chain
    through the programmed midpoints needs (scipy's derivatives, 65 points per quintic),
    keeps P both ways and v/a/j, and takes fewer periods."""
    ents = line_into_arc(0.1)

    def rates():
        _, quintics = built(ents)
        out = []
        for q in quintics:
            ctrl = np.asarray(q.points, float)
            u = np.linspace(0, 1, 65)
            pts = BSpline(BEZIER5, ctrl, 5)(u)
            k = curvature(ctrl, u)[1]
            out.append(np.abs(np.diff(k)) / np.linalg.norm(np.diff(pts, axis=0), axis=1))
        return np.concatenate(out).max()

    fitted = rates()
    pos = run(ents)
    assert_within_limits(pos)
    assert_within_p(pos, ents, 0.1)
    np.testing.assert_allclose(pos[-1], ents[-1].end, atol=1e-6)
    with monkeypatch.context() as m:
        m.setattr(g2_chains, "fitted_midpoints", _programmed)
        own = rates()
        pos_own = run(ents)
    assert fitted <= 0.6 * own  # 1.57 against 3.17 /mm^2
    assert len(pos) < len(pos_own)  # 339 against 367


def test_midpoints_outside_runs_and_on_run_ends_stay_the_programmed_ones():
    """fitted_midpoints on the line into the arc with two runs: every line outside a run and
    each run's two end lines keep their midpoint and direction bit for bit; the others moved
    within FIT_SHARE x P."""
    ents = line_into_arc(0.1)
    start = np.array([e.start for e in ents])
    end = np.array([e.end for e in ents])
    length = np.linalg.norm(end - start, axis=1)
    unit = (end - start) / length[:, None]
    chain = np.ones(len(ents) - 1, bool)
    chain[[0, 15]] = False  # runs: corners 1-14 (lines 1-15) and 16-end
    mid, tan = fitted_midpoints(start, unit, length, chain, np.full(len(chain), 0.1), FIT_SHARE, SMOOTH_MM**6)
    own = start + 0.5 * length[:, None] * unit
    for k in (0, 1, 15, 16, len(ents) - 1):
        np.testing.assert_array_equal(mid[k], own[k])
        np.testing.assert_array_equal(tan[k], unit[k])
    moved = np.linalg.norm(mid - own, axis=1)
    assert 0 < moved.max() <= FIT_SHARE * 0.1 * (1 + 1e-12)


@pytest.mark.slow
def test_lhchips4_plans_through_its_fitted_chains():
    """LinuxCNC's lhchips4 (CAM output), its first 4400 lines in S-curve mode: with the fitted
    chains it cruises at 115 mm/s into curves near v^2 kappa = A, where braking keeps only a
    share of the axes' acceleration. Each window commits no later than a stop from its top speed
    at half the acceleration and jerk (ipo.feed.scurve.stop_reach_mm); with the whole
    acceleration, line 4331 found no jerk-limited profile. Every period keeps v/a/j (finite
    differences) and the run ends where the program does."""
    from conftest import require_corpus

    prog = ipr.parse_file(require_corpus() / "g1_lhchips4.ngc")
    ents = [e for e in prog.entities if getattr(e, "line", 0) <= 4400]
    moves = [e for e in ents if isinstance(e, (Line, Rapid, Arc))]
    pos = np.vstack([np.asarray(moves[0].start, float)[None],
                     *[b.pos_mm for b in plan_periods(ents, CFG, start_mm=moves[0].start)
                       if isinstance(b, PeriodBatch)]])
    assert_within_limits(pos)
    np.testing.assert_allclose(pos[-1], moves[-1].end, atol=1e-6)
