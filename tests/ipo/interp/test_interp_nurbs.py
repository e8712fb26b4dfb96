"""NURBS steppers: the stepper contract, 000 §2.2 equations re-derived with the numpy kernel,
the Taylor update against exact arc length, degenerate curves and the corpus curves."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import corpus_files
from ipo.nurbs import kernel as nurbs
from ipo.interp.line_arc import ArcStepper, LineStepper
from ipo.interp.steppers import make_stepper
from ipo.interp.taylor import taylor_delta_u
from ipr.entities import Arc, Line, Nurbs, Rapid

METHODS = ["recursive", "taylor1", "taylor2", "constant-du"]


def nurbs_entity(points, weights=None, knots=None, degree=3):
    points = np.asarray(points, dtype=float)
    if points.shape[1] == 2:
        points = np.c_[points, np.zeros(len(points))]
    n = len(points)
    if knots is None:
        knots = np.r_[[0.0] * (degree + 1), np.linspace(0, 1, n - degree + 1)[1:-1], [1.0] * (degree + 1)]
    weights = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    return Nurbs(1, degree, np.asarray(knots, dtype=float), weights, points, 10.0)


def curve_of(e):
    return e.degree, e.knots, e.weights, e.points


def run(e, d, limit=200_000, **kw):
    s = make_stepper(e, **kw)
    steps = np.full(4096, d)
    parts = []
    while not s.done:
        parts.append(s.advance(steps))
        assert sum(len(p.u) for p in parts) < limit, "stepper stalls"
    pos = np.vstack([p.pos_mm for p in parts])
    u = np.concatenate([p.u for p in parts])
    ev = np.concatenate([p.evals for p in parts])
    return s, pos, u, ev, parts[-1].carry_mm


QUARTER = nurbs_entity([[10, 0], [10, 10], [0, 10]], [1, np.sqrt(0.5), 1], [0, 0, 0, 1, 1, 1], degree=2)
WAVY = nurbs_entity([[0, 0], [3, 8], [9, -4], [12, 6], [20, 0], [22, 9], [30, 3], [31, -5]],
                    [1, 2, 0.5, 1, 3, 1, 0.7, 1])


def chords(e, pos):
    path = np.vstack([np.asarray(e.start)[None, :], pos])
    return np.linalg.norm(np.diff(path, axis=0), axis=1)


def test_quarter_circle_adaptive_chords_and_points_on_circle():
    d = 0.05
    s, pos, u, ev, carry = run(QUARTER, d, chord_tol_pct=0.001)
    np.testing.assert_allclose(np.linalg.norm(pos[:, :2], axis=1), 10.0, atol=1e-12)
    c = chords(QUARTER, pos)
    assert np.abs(c[:-1] / d - 1).max() <= 1e-5
    # the number of steps follows from the exact arc length and chord: 2 R asin(d / 2R) per step
    per_step = 2 * 10 * np.arcsin(d / 20)
    assert len(u) == int(np.floor(np.pi * 5 / per_step)) + 1
    np.testing.assert_array_equal(pos[-1], [0, 10, 0])
    assert carry == pytest.approx(d - c[-1], abs=1e-15)
    assert np.all(np.diff(u) > 0)


def test_startup_and_steady_state_follow_eq_8_to_14_exactly():
    """Re-derive u_1 and u_2 from 000 eq. 8-14 with the numpy kernel and the stepper's own chords."""
    e, d = WAVY, 0.3
    curve = curve_of(e)
    pt = lambda u: nurbs.curve_points(*curve, np.array([u]))[0]  # noqa: E731
    polygon = np.linalg.norm(np.diff(e.points, axis=0), axis=1).sum()  # eq. 10
    du = 1.0 * d / polygon  # eq. 11-12, u_s = 1
    for _ in range(2):  # m1 = 3: two refinements, eq. 13-14
        du = d * du / np.linalg.norm(pt(du) - e.points[0])
    s = make_stepper(e, n1=2, m1=3)
    r = s.advance(np.full(2, d))
    assert r.u[0] == pytest.approx(du, rel=1e-12)
    assert s.startup_evals == 3 and r.evals[0] == 3
    s1 = np.linalg.norm(pt(du) - e.points[0])
    g = d * du / s1  # eq. 8
    g = d * g / np.linalg.norm(pt(du + g) - pt(du))  # eq. 9, n1 = 2
    assert r.u[1] == pytest.approx(du + g, rel=1e-12)
    assert r.evals[1] == 2


@pytest.mark.parametrize("n1", [1, 2, 3])
def test_fixed_n1_counts_evaluations_and_improves(n1):
    _, pos, u, ev, _ = run(WAVY, 0.2, n1=n1, m1=4)
    assert ev[0] == 4
    assert np.all(ev[1:-1] >= n1) and np.mean(ev[1:-1]) < n1 + 0.05
    dev = np.abs(chords(WAVY, pos)[:-1] / 0.2 - 1).max()
    assert dev < {1: 0.3, 2: 0.03, 3: 0.005}[n1]


def test_startup_search_reaches_tolerance():
    for e_pct in (1.0, 0.01):
        s, pos, *_ = run(WAVY, 0.2, n1=2, start_tol_pct=e_pct)
        first = np.linalg.norm(pos[0] - WAVY.points[0])
        assert abs(first / 0.2 - 1) * 100 < e_pct
        assert 1 <= s.startup_evals <= 10


def parabola():
    """P(u) = (u, u^2): a quadratic Bezier; s(u) = u sqrt(1+4u^2)/2 + asinh(2u)/4."""
    return nurbs_entity([[0, 0], [0.5, 0], [1, 1]], knots=[0, 0, 0, 1, 1, 1], degree=2)


def parabola_length(u):
    return u * np.sqrt(1 + 4 * u * u) / 2 + np.arcsinh(2 * u) / 4


def exact_du(u0, ds):
    lo, hi = 0.0, 1.0
    target = parabola_length(u0) + ds
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if parabola_length(u0 + mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def test_taylor_second_order_term_against_exact_arc_length():
    u0 = 0.3
    d = nurbs.curve_derivs(*curve_of(parabola()), np.array([u0]), 2)[:, 0]
    p1, p2 = d[1], d[2]
    # the derived coefficient: d2u/ds2 / 2 = -(P'.P'') / (2 |P'|^4)
    coef = -(p1 @ p2) / (2 * np.linalg.norm(p1) ** 4)
    errs = {1: [], 2: []}
    for ds in (0.02, 0.01, 0.005):
        exact = exact_du(u0, ds)
        assert (exact - ds / np.linalg.norm(p1)) / ds**2 == pytest.approx(coef, rel=0.05)
        for order in (1, 2):
            errs[order].append(abs(taylor_delta_u(ds, *p1, *p2, order) - exact))
    e1, e2 = np.array(errs[1]), np.array(errs[2])
    np.testing.assert_allclose(e1[:-1] / e1[1:], 4.0, rtol=0.1)  # first order: O(ds^2)
    np.testing.assert_allclose(e2[:-1] / e2[1:], 8.0, rtol=0.15)  # second order: O(ds^3)
    assert np.all(e2 < e1 / 10)


def test_taylor2_beats_taylor1_and_constant_du_is_naive():
    dev = {}
    for m in ("taylor1", "taylor2", "constant-du"):
        _, pos, u, ev, _ = run(WAVY, 0.1, method=m, du=0.01)
        dev[m] = np.abs(chords(WAVY, pos)[:-1] / 0.1 - 1).max()
        assert np.all(ev[1:] == 1)
        if m == "constant-du":
            np.testing.assert_allclose(np.diff(u)[:-1], 0.01, rtol=1e-9)
    assert dev["taylor2"] < dev["taylor1"] / 2
    assert dev["constant-du"] > 0.5


@pytest.mark.parametrize("method", METHODS)
def test_varying_steps_zeros_tiny_lead_and_chunking(method):
    rng = np.random.default_rng(5)
    steps = rng.uniform(0.0, 0.3, 400)
    steps[rng.random(400) < 0.2] = 0.0
    steps[rng.random(400) < 0.1] = 1e-9
    lead = 0.05
    steps[0] = 0.12
    opts = dict(method=method, chord_tol_pct=0.01 if method == "recursive" else None, du=0.003)
    s = make_stepper(WAVY, lead_mm=lead, **opts)
    whole = s.advance(steps)
    s2 = make_stepper(WAVY, lead_mm=lead, **opts)
    pieces = [s2.advance(steps[i:i + 37]) for i in range(0, 400, 37) if not s2.done]
    joined = np.vstack([p.pos_mm for p in pieces])[:len(whole.u)]
    np.testing.assert_array_equal(joined, whole.pos_mm)
    k = len(whole.u)
    c = chords(WAVY, whole.pos_mm)
    target = steps[:k].copy()
    target[0] -= lead
    assert np.all(c[target == 0] == 0) and np.all(whole.evals[target == 0] == 0)
    assert np.all(np.diff(whole.u) >= 0) and np.all(np.diff(whole.u)[target[1:] > 0] > 0)
    if method == "recursive":
        moving = (target > 0)
        if whole.done:
            moving[-1] = False
        np.testing.assert_allclose(c[moving], target[moving], rtol=1.01e-4, atol=1e-12)


@pytest.mark.parametrize("kw", [dict(n1=2), dict(chord_tol_pct=0.01), dict(method="taylor2")])
def test_braking_to_a_stop_and_restarting(kw):
    """A feed ramp down to a standstill through steps far below a micrometre, then back up:
    the tiny steps must not spoil the du/ds the stepper has learnt."""
    ramp = 0.1 * np.logspace(0, -14, 40)
    steps = np.r_[np.full(20, 0.1), ramp, np.zeros(10), ramp[::-1], np.full(20, 0.1)]
    s = make_stepper(WAVY, **kw)
    r = s.advance(steps)
    assert not r.done and np.all(np.diff(r.u) >= 0) and np.isfinite(r.pos_mm).all()
    c = chords(WAVY, r.pos_mm)
    np.testing.assert_array_equal(c[60:70], 0.0)
    assert np.all(r.evals[60:70] == 0)
    # a spoilt du/ds would show as a first chord after the restart far off (here about 0.02 %)
    assert np.abs(c[-20:] / 0.1 - 1).max() <= 2e-3
    big = steps > 1e-6
    np.testing.assert_allclose(c[big], steps[big], rtol=0.05)


@pytest.mark.parametrize("method", METHODS)
def test_first_step_below_float_resolution_then_normal_steps(method):
    s = make_stepper(WAVY, method=method, lead_mm=0.1)
    r = s.advance(np.r_[0.1 + 1e-13, 1e-14, np.full(30, 0.1)])
    assert np.all(np.diff(r.u) >= 0) and r.u[-1] > r.u[2]
    c = chords(WAVY, r.pos_mm)
    if method == "recursive":
        np.testing.assert_allclose(c[2:], 0.1, rtol=2e-3)
        assert s.startup_evals >= 3


def test_end_clamp_and_carry():
    e = WAVY
    s, pos, u, ev, carry = run(e, 0.25, chord_tol_pct=0.01)
    last = np.linalg.norm(pos[-1] - pos[-2])
    np.testing.assert_array_equal(pos[-1], e.points[-1])
    assert u[-1] == 1.0 and s.done
    assert 0 <= carry < 0.25 and carry == pytest.approx(0.25 - last, abs=1e-15)
    with pytest.raises(RuntimeError):
        s.advance(np.ones(3))


def test_step_longer_than_curve_ends_at_once():
    s = make_stepper(QUARTER)
    r = s.advance(np.array([100.0, 1.0]))
    assert r.done and len(r.u) == 1
    assert r.carry_mm == pytest.approx(100 - np.sqrt(200), abs=1e-12)


DEGENERATE = {
    # p + 1 equal control points: the curve stands still over a whole knot span
    "repeated points": nurbs_entity([[0, 0], [1, 1], [2, 0], [2, 0], [2, 0], [2, 0], [3, 1], [4, 0]]),
    "zero length": nurbs_entity([[1, 2, 3]] * 5),
    "uneven weights": nurbs_entity([[0, 0], [1, 2], [2, -1], [3, 3], [4, 0], [5, 1]], [1, 1e4, 1e-4, 1e4, 1e-3, 1]),
    # B_1 = B_0: P'(u_min) = 0, and a cusp where the polygon doubles back
    "vanishing derivative": nurbs_entity([[0, 0], [0, 0], [2, 1], [4, 0], [2, 1], [5, 2]]),
    "degree 1": nurbs_entity([[0, 0], [1, 0], [1, 0], [1, 1]], degree=1),
}


@pytest.mark.parametrize("name", DEGENERATE)
@pytest.mark.parametrize("method", METHODS + ["adaptive"])
@pytest.mark.parametrize("d", [0.05, 1e-4])
def test_degenerate_curves_finish_forward(name, method, d):
    e = DEGENERATE[name]
    kw = dict(method="recursive", chord_tol_pct=0.01) if method == "adaptive" else dict(method=method)
    length = nurbs.arc_length(*curve_of(e)) if name != "zero length" else 0.0
    limit = 40 * (length / d + 1) + 2000
    s, pos, u, ev, carry = run(e, d, limit=limit, du=0.01, **kw)
    assert np.isfinite(pos).all() and np.isfinite(u).all() and np.isfinite(carry)
    assert np.all(np.diff(u) > 0)
    np.testing.assert_array_equal(pos[-1], e.points[-1])
    assert 0 <= carry <= d
    if method == "adaptive":  # the tolerance mode never overshoots, even where it hits the cap
        assert np.all(chords(e, pos) <= d * (1 + 1e-4))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), degree=st.integers(1, 5), d=st.sampled_from([0.01, 0.1, 0.5]))
def test_random_curves_adaptive_property(seed, degree, d):
    rng = np.random.default_rng(seed)
    n = rng.integers(degree + 1, min(14, 10 * degree + 2))
    inner = np.sort(rng.choice(np.repeat(np.linspace(0.1, 0.9, 9), degree), n - degree - 1, replace=False))
    knots = np.r_[[0.0] * (degree + 1), inner, [1.0] * (degree + 1)]
    e = nurbs_entity(rng.normal(size=(n, 3)) * 5, rng.uniform(0.2, 5, n), knots, degree)
    s, pos, u, ev, carry = run(e, d, chord_tol_pct=0.01, max_evals=12)
    c = chords(e, pos)
    assert np.all(np.diff(u) > 0) and s.done
    assert np.all(c <= d * (1 + 1e-4))  # never longer than the tolerance allows
    # where the curve doubles back within a step the chord is not monotonic in du and the
    # cap may stop a period short of d: rare on curves whose features are larger than d
    assert np.mean(np.abs(c[:-1] / d - 1) <= 1e-4) >= 0.95
    assert c.sum() <= nurbs.arc_length(*curve_of(e)) + 1e-9


def test_make_stepper_dispatch_and_bad_input():
    line = Line(1, (0, 0, 0), (1, 0, 0), 10.0)
    assert isinstance(make_stepper(line), LineStepper)
    assert isinstance(make_stepper(Rapid(1, (0, 0, 0), (0, 0, 1))), LineStepper)
    arc = Arc(1, (1, 0, 0), (0, 1, 0), (0, 0, 0), "XY", True, 10.0)
    assert isinstance(make_stepper(arc), ArcStepper)
    with pytest.raises(ValueError, match="method"):
        make_stepper(WAVY, method="spline")
    with pytest.raises(ValueError, match="n1"):
        make_stepper(WAVY, n1=0)
    with pytest.raises(ValueError, match="clamped"):
        make_stepper(nurbs_entity([[0, 0], [1, 1], [2, 0]], knots=[0, 0, 1, 1, 2, 2], degree=2))
    with pytest.raises(ValueError, match="repeats"):
        make_stepper(nurbs_entity([[0, 0], [1, 1], [2, 0], [3, 3]], knots=[0, 0, 0.5, 0.5, 1, 1], degree=1))
    with pytest.raises(ValueError, match="weights"):
        make_stepper(nurbs_entity([[0, 0], [1, 1], [2, 0]], [1, 0, 1], degree=2))
    s = make_stepper(WAVY, lead_mm=0.5)
    with pytest.raises(ValueError, match="lead"):
        s.advance(np.array([0.2]))
    with pytest.raises(ValueError, match=">= 0"):
        make_stepper(WAVY).advance(np.array([0.1, -0.1]))
    with pytest.raises(TypeError):
        make_stepper("G1")


CORPUS_NURBS = [p for p in corpus_files("g6_*.ngc") if p.id in ("no-corpus", "g6_farfalla.ngc", "g6_stella.ngc",
                                                                   "g6_unipa.ngc")]


@pytest.mark.parametrize("path", CORPUS_NURBS)
def test_corpus_curves_adaptive_meet_the_bar(path):
    ipr = pytest.importorskip("ipr")
    if not hasattr(ipr, "parse_file"):
        pytest.skip("ipr.parse_file not available yet")
    curves = [e for e in ipr.parse_file(path).entities if isinstance(e, Nurbs)]
    assert curves
    evals, worst = [], 0.0
    for e in curves:
        for kw in (dict(chord_tol_pct=0.01), dict(n1=2), dict(method="taylor2")):
            s, pos, u, ev, carry = run(e, 0.1, **kw)
            assert np.all(np.diff(u) > 0)  # no stall, no backward step
            np.testing.assert_array_equal(pos[-1], e.points[-1])
            if "chord_tol_pct" in kw:
                worst = max(worst, np.abs(chords(e, pos)[:-1] / 0.1 - 1).max())
                evals.append(ev)
    assert worst <= 1e-4
    assert np.concatenate(evals).mean() <= 2.5


PROGRAMS = Path(__file__).resolve().parents[3] / "programs"


def test_curve000_is_like_the_papers():
    from ipr import parse_file

    (e,) = [x for x in parse_file(PROGRAMS / "curve000.nc").entities if isinstance(x, Nurbs)]
    geom = curve_of(e)
    assert nurbs.arc_length(*geom) == pytest.approx(0.089, abs=0.001)
    assert np.linalg.norm(np.diff(e.points, axis=0), axis=1).sum() == pytest.approx(0.157, abs=0.001)
    u = np.linspace(0, 1, 100_001)
    assert 1 / nurbs.curvature(*geom, u).max() == pytest.approx(0.001, rel=0.05)


def test_cli_interp_json_out_and_pulse(tmp_path):
    from click.testing import CliRunner

    from machine.cli import main

    runner = CliRunner()
    out = tmp_path / "pts.npz"
    res = runner.invoke(main, ["interp", str(PROGRAMS / "curve000.nc"), "--step-um", "1", "--chord-tol-pct", "0.01",
                               "--json", "--out", str(out)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert set(data) == {"steps", "max_dev_pct", "rms_dev_pct", "evals_mean", "evals_max", "startup_evals",
                         "steps_per_s"}
    assert data["max_dev_pct"] <= 0.01 + 1e-9 and 1 <= data["evals_mean"] <= 4
    saved = np.load(out)
    assert saved["pos_mm"].shape == (data["steps"] + 1, 3) and saved["u"].shape == (data["steps"] + 1,)
    chords_um = np.linalg.norm(np.diff(saved["pos_mm"], axis=0), axis=1) * 1000
    assert np.all(np.abs(chords_um[1:-1] - 1) <= 1e-4)  # [0] is the zero-length G0 to the start
    res = runner.invoke(main, ["interp", str(PROGRAMS / "curve000.nc"), "--pulse", "--blu-um", "1"])
    assert res.exit_code == 0, res.output
    dev = float(res.output.split("pulse path deviation")[1].split()[0])
    assert 0.3 < dev < 0.75  # the 0.5 BLU rule per axis: at most 0.5*sqrt(2) in a plane
    res = runner.invoke(main, ["interp", str(PROGRAMS / "curve000.nc"), "--out", str(tmp_path / "x.txt")])
    assert res.exit_code != 0 and "npz or .csv" in res.output
