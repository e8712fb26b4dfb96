"""The recursive paper mode's steady state (steppers._paper_run) against 000 eq. 8-9 driven from
Python, steppers writing into the caller's arrays, and the chord study's preallocated path."""
from __future__ import annotations

import numpy as np
import pytest

from ipo.interp import chord_study
from ipo.interp.chord_study import study
from ipo.interp.line_arc import LineStepper
from ipo.interp.steppers import make_stepper
from ipo.nurbs.compiled import compile_curve, dist3, poly_point, poly_span
from ipr.entities import Arc, Line, Nurbs

WAVY = Nurbs(1, 3, np.r_[[0.0] * 4, np.linspace(0, 1, 6)[1:-1], [1.0] * 4],
             np.array([1, 2, 0.5, 1, 3, 1, 0.7, 1], dtype=float),
             np.array([[0, 0, 0], [3, 8, 1], [9, -4, 0], [12, 6, 2], [20, 0, 0], [22, 9, 1], [30, 3, 0], [31, -5, 0]],
                      dtype=float), 10.0)
QUARTER = Nurbs(1, 2, np.array([0, 0, 0, 1, 1, 1], dtype=float), np.array([1, np.sqrt(0.5), 1]),
                np.array([[10, 0, 0], [10, 10, 0], [0, 10, 0]], dtype=float), 10.0)


def eq8_eq9_periods(e, steps, u, p, du_prev, s_prev, n1):
    """000 eq. 8 (first guess from the previous period's du/s) and n1 - 1 refinements by eq. 9,
    evaluated one point at a time through the span polynomials; stops before a trial that would
    reach the curve's end (there the stepper clamps)."""
    c = compile_curve(e.degree, e.knots, e.weights, e.points)
    span, out = 0, []
    for d in steps:
        g = d * du_prev / s_prev  # eq. 8
        for k in range(n1):
            if k:
                g = d * g / s  # eq. 9
            if u + g >= c.u_max:
                return out
            span = poly_span(c.breaks, u + g, span)
            x = poly_point(c.breaks, c.inv_h, c.coef, span, u + g)
            s = dist3(*p, *x)
        u, p, du_prev, s_prev = u + g, x, g, s
        out.append((u, *x))
    return out


@pytest.mark.parametrize("n1", [1, 2, 3, 5])
@pytest.mark.parametrize("curve, d", [(WAVY, 0.05), (QUARTER, 0.01)])
def test_steady_state_is_eq8_eq9_bit_for_bit(curve, d, n1):
    rng = np.random.default_rng(n1)
    steps = d * rng.uniform(0.5, 1.5, 20_000)
    s = make_stepper(curve, n1=n1, m1=3)
    first = s.advance(steps[:1])  # the start-up (eq. 10-14), the general path
    chunks = [s.advance(steps[i:i + 999]) for i in range(1, len(steps), 999) if not s.done]
    got = np.column_stack([np.concatenate([r.u for r in chunks]), np.vstack([r.pos_mm for r in chunks])])
    evals = np.concatenate([r.evals for r in chunks])
    p1 = tuple(first.pos_mm[0])
    want = np.array(eq8_eq9_periods(curve, steps[1:], first.u[0], p1, first.u[0] - curve.knots[0],
                                    dist3(*curve.points[0], *p1), n1))
    assert len(want) > 100 and len(got) >= len(want)
    np.testing.assert_array_equal(got[:len(want)], want)
    assert np.all(evals[:len(want)] == n1)
    if s.done:
        np.testing.assert_array_equal(chunks[-1].pos_mm[-1], curve.points[-1])


def test_steady_state_hands_zero_and_tiny_steps_back_and_resumes():
    """A stop in the middle of the steady state: zero steps stand still (no evaluation), steps
    below float resolution follow the general path, and the paper mode resumes after them."""
    steps = np.r_[np.full(50, 0.1), np.zeros(5), np.full(3, 1e-12), np.full(50, 0.1)]
    whole = make_stepper(WAVY, n1=2).advance(steps)
    s = make_stepper(WAVY, n1=2)
    parts = [s.advance(steps[i:i + 7]) for i in range(0, len(steps), 7)]
    np.testing.assert_array_equal(np.vstack([p.pos_mm for p in parts]), whole.pos_mm)
    np.testing.assert_array_equal(np.concatenate([p.u for p in parts]), whole.u)
    np.testing.assert_array_equal(whole.pos_mm[50:55], np.repeat(whole.pos_mm[49:50], 5, axis=0))
    assert np.all(whole.evals[50:55] == 0) and np.all(whole.evals[58:] == 2)
    chords = np.linalg.norm(np.diff(whole.pos_mm[57:], axis=0), axis=1)
    np.testing.assert_allclose(chords, 0.1, rtol=1e-2)


@pytest.mark.parametrize("entity", [WAVY, Line(1, (0, 0, 0), (3, 4, 0), 10.0)])
def test_advance_writes_into_the_callers_arrays(entity):
    steps = np.full(80, 0.1)
    fresh = make_stepper(entity, n1=2).advance(steps)
    out = (np.full((100, 3), np.nan), np.full(100, np.nan), np.full(100, -1, dtype=np.int64))
    r = make_stepper(entity, n1=2).advance(steps, out=out)
    k = len(fresh.u)
    assert np.shares_memory(r.pos_mm, out[0]) and np.shares_memory(r.u, out[1]) and np.shares_memory(r.evals, out[2])
    np.testing.assert_array_equal(out[0][:k], fresh.pos_mm)
    np.testing.assert_array_equal(out[1][:k], fresh.u)
    np.testing.assert_array_equal(out[2][:k], fresh.evals)
    assert np.isnan(out[1][k:]).all()  # nothing written past the periods taken
    assert r.done == fresh.done and r.carry_mm == fresh.carry_mm


@pytest.mark.parametrize("stepper", [lambda: make_stepper(WAVY), lambda: LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 1.0))])
def test_advance_refuses_out_arrays_it_cannot_fill(stepper):
    steps = np.full(10, 0.01)
    good = (np.empty((10, 3)), np.empty(10), np.empty(10, dtype=np.int64))
    for bad in ((good[0][:9], good[1], good[2]), (good[0], good[1].astype(np.float32), good[2]),
                (good[0], good[1], good[2].astype(np.int32)), (np.empty((10, 2)), good[1], good[2]),
                (np.empty((10, 6))[:, ::2], good[1], good[2])):
        with pytest.raises(ValueError, match="out"):
            stepper().advance(steps, out=bad)


def test_study_path_grows_past_its_length_bound(monkeypatch):
    """A length bound far too small costs copies, nothing else."""
    program = [Line(1, (0, 0, 0), (2, 0, 0), 10.0), WAVY, Line(3, (31, -5, 0), (31, -5, 2), 10.0)]
    normal = study(program, 0.01, n1=2)
    monkeypatch.setattr(chord_study, "_length_bound_mm", lambda e: 0.0)
    grown = study(program, 0.01, n1=2)
    for field in ("pos_mm", "u", "chord_dev", "nurbs_evals", "startup_evals"):
        np.testing.assert_array_equal(getattr(grown, field), getattr(normal, field))
    assert grown.steps == normal.steps == len(normal.u) - 1 and grown.stalls == normal.stalls == 0


def test_study_chords_start_at_each_entitys_own_start():
    """A line, an arc and a NURBS whose starts are not the previous ends: each entity's chords
    start from its own start point, and its final clamped chord is left out."""
    program = [Line(1, (0, 0, 0), (2, 0, 0.001), 10.0), Arc(2, (2, 0, 0), (0, 2, 0), (0, 0, 0), "XY", True, 10.0),
               WAVY]
    d = 0.01
    s = study(program, d, n1=2)
    expect, at = [], 1
    for e in program:
        n = len(make_stepper(e, n1=2).advance(np.full(20_000, d)).u)
        path = np.vstack([np.asarray(e.start, dtype=float), s.pos_mm[at:at + n]])
        expect.append(np.linalg.norm(np.diff(path, axis=0), axis=1)[:-1] / d - 1.0)
        at += n
    np.testing.assert_array_equal(s.chord_dev, np.concatenate(expect))
    assert at == len(s.u) and len(s.nurbs_evals) == n  # the NURBS's periods only
    np.testing.assert_array_equal(s.pos_mm[0], program[0].start)
    np.testing.assert_array_equal(s.pos_mm[-1], WAVY.points[-1])


def test_entity_chords_by_hand():
    """Chords from the start point (1, 2, 2) then point to point, D = 3; the parameter stalls
    once (0.5 -> 0.5) and steps back once (0.7 -> 0.6); the last period is not measured."""
    pos = np.array([[1, 2, 5], [1, 2, 5], [4, 6, 5], [4, 6, 5 + 6], [0, 0, 0]], dtype=float)
    u = np.array([0.5, 0.5, 0.7, 0.6, 0.1])
    dev = np.empty(4)
    stalls = chord_study._entity_chords(np.array([1.0, 2.0, 2.0]), 0.25, pos, u, 3.0, dev)
    np.testing.assert_array_equal(dev, [0.0, -1.0, 5 / 3 - 1, 1.0])
    assert stalls == 2
