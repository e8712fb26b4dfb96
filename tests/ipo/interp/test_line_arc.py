"""LineStepper / ArcStepper against analytic geometry: every point on the exact line,
circle or helix, chords equal to the requested steps, exact end, carry and lead."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from ipr.entities import Arc, Line, Rapid
from ipo.interp.line_arc import ArcStepper, LineStepper

GEOM_TOL_MM = 1e-9


def run_all(stepper, steps):
    """Advance in uneven chunks until done; concatenated positions, u, carry, periods used."""
    pos, u = [], []
    i = 0
    chunk = 1
    while not stepper.done:
        assert i < len(steps), "stepper did not finish within the given steps"
        r = stepper.advance(steps[i:i + chunk])
        pos.append(r.pos_mm)
        u.append(r.u)
        assert r.evals.shape == (len(r.u),) and not r.evals.any()
        i += len(r.u)
        chunk = chunk * 3 + 1
    return np.vstack(pos), np.concatenate(u), r.carry_mm, i


def chords(start, pos):
    return np.linalg.norm(np.diff(np.vstack([start, pos]), axis=0), axis=1)


# ---------------------------------------------------------------- lines

def test_line_hand_computed_lead_and_carry():
    # Length 3 along (1,2,2)/3; lead 0.02 of a 0.05 step: points at 0.03 + 0.05 j.
    st_ = LineStepper(Line(1, (0, 0, 0), (1, 2, 2), 10.0), lead_mm=0.02)
    pos, u, carry, k = run_all(st_, np.full(100, 0.05))
    assert k == 61  # 0.03 + 0.05*60 = 3.03 >= 3 first
    np.testing.assert_allclose(u[:-1], 0.03 + 0.05 * np.arange(60), atol=1e-12)
    np.testing.assert_allclose(pos[0], np.array([1, 2, 2]) * 0.01, atol=1e-15)
    assert tuple(pos[-1]) == (1.0, 2.0, 2.0) and u[-1] == 3.0
    assert carry == pytest.approx(0.03, abs=1e-12)


def test_line_random_steps_with_zeros_on_line():
    rng = np.random.default_rng(1)
    steps = rng.uniform(0, 0.2, 400)
    steps[rng.random(400) < 0.2] = 0.0
    start, end = np.array([1.0, -2.0, 0.5]), np.array([-3.0, 7.0, 2.5])
    length = np.linalg.norm(end - start)
    pos, u, carry, k = run_all(LineStepper(Rapid(3, tuple(start), tuple(end))), steps)
    c = chords(start, pos)
    np.testing.assert_allclose(c[:-1], steps[:k - 1], atol=1e-12)
    unit = (end - start) / length
    rel = pos - start
    off_line = np.linalg.norm(rel - np.outer(rel @ unit, unit), axis=1)
    assert off_line.max() < GEOM_TOL_MM
    np.testing.assert_allclose(u, rel @ unit, atol=1e-12)
    assert np.array_equal(pos[-1], end)
    # carry: what of the last step lies beyond the end
    assert carry == pytest.approx(steps[:k].sum() - length, abs=1e-12)
    assert np.all(np.diff(u) >= 0)


def test_zero_length_line_finishes_at_first_period():
    s = LineStepper(Line(1, (1, 1, 1), (1, 1, 1), 5.0))
    r = s.advance(np.array([0.04, 0.04]))
    assert s.done and len(r.u) == 1 and r.carry_mm == pytest.approx(0.04)
    assert tuple(r.pos_mm[0]) == (1, 1, 1)


def test_empty_advance_keeps_lead_for_first_real_step():
    s = LineStepper(Line(1, (0, 0, 0), (10, 0, 0), 5.0), lead_mm=0.03)
    assert len(s.advance(np.array([])).u) == 0
    r = s.advance(np.array([0.05, 0.05]))
    np.testing.assert_allclose(r.pos_mm[:, 0], [0.02, 0.07], atol=1e-15)


@pytest.mark.parametrize("bad", [[-0.1], [np.nan], [np.inf], [[0.1, 0.1]]])
def test_bad_steps_rejected(bad):
    with pytest.raises(ValueError):
        LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 5.0)).advance(np.array(bad))
    with pytest.raises(ValueError):
        ArcStepper(Arc(1, (1, 0, 0), (0, 1, 0), (0, 0, 0), "XY", True, 5.0)).advance(np.array(bad))


def test_bad_construction_and_misuse():
    with pytest.raises(ValueError, match="lead_mm"):
        LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 5.0), lead_mm=-1.0)
    with pytest.raises(ValueError, match="shorter than lead_mm"):
        LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 5.0), lead_mm=0.05).advance(np.array([0.01]))
    with pytest.raises(ValueError, match="radius is zero"):
        ArcStepper(Arc(1, (0, 0, 0), (0, 0, 1), (0, 0, 0), "XY", True, 5.0))
    with pytest.raises(TypeError):
        LineStepper(Arc(1, (1, 0, 0), (0, 1, 0), (0, 0, 0), "XY", True, 5.0))
    with pytest.raises(TypeError):
        ArcStepper(Line(1, (0, 0, 0), (1, 0, 0), 5.0))
    s = LineStepper(Line(1, (0, 0, 0), (1, 0, 0), 5.0))
    s.advance(np.array([2.0]))
    with pytest.raises(RuntimeError):
        s.advance(np.array([0.1]))


# ---------------------------------------------------------------- arcs

def arc_check(arc: Arc, steps, lead=0.0, radius_end=None):
    """Run an arc and check it against the analytic curve; returns (pos, u, carry, k)."""
    a, b, n = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}[arc.plane]
    s = np.array(arc.start)
    c = np.array(arc.center)
    e = np.array(arc.end)
    pos, u, carry, k = run_all(ArcStepper(arc, lead_mm=lead), steps)
    assert np.array_equal(pos[-1], e)
    # unwrapped in-plane angle of every point, from the start, in the arc's own sense
    ang = np.unwrap(np.arctan2(np.r_[s[b], pos[:, b]] - c[b], np.r_[s[a], pos[:, a]] - c[a]))
    th = (ang - ang[0]) * (1 if arc.ccw else -1)
    assert np.all(np.diff(th) >= -1e-12), "moved against the arc's sense"
    r0 = np.hypot(s[a] - c[a], s[b] - c[b])
    r1 = r0 if radius_end is None else radius_end
    total = abs(arc.sweep_rad)
    assert th[-1] == pytest.approx(total, abs=1e-9)
    r = np.hypot(pos[:, a] - c[a], pos[:, b] - c[b])
    np.testing.assert_allclose(r, r0 + (r1 - r0) * th[1:] / total, atol=GEOM_TOL_MM, rtol=0)
    np.testing.assert_allclose(pos[:, n], s[n] + (e[n] - s[n]) * th[1:] / total, atol=GEOM_TOL_MM, rtol=0)
    ch = chords(s, pos)
    want = np.array(steps[:k], dtype=float)
    want[0] -= lead
    np.testing.assert_allclose(ch[:-1], want[:-1], atol=1e-12, rtol=1e-12)
    assert carry == pytest.approx(want[-1] - ch[-1], abs=1e-12)
    assert 0.0 <= carry <= want[-1]
    if radius_end is None:  # helix: u is sqrt(R^2 + k^2) * angle
        pitch = (e[n] - s[n]) / total
        # th comes from atan2 of the points: its rounding grows with the pitch / radius
        np.testing.assert_allclose(u, np.hypot(r0, pitch) * th[1:], rtol=1e-12,
                                   atol=1e-12 * (1 + abs(pitch) / r0))
    return pos, u, carry, k


@pytest.mark.parametrize("plane", ["XY", "ZX", "YZ"])
@pytest.mark.parametrize("ccw", [True, False])
def test_quarter_arc_each_plane_and_sense(plane, ccw):
    a, b, n = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}[plane]
    s, e, c = np.zeros(3), np.zeros(3), np.zeros(3)
    c[:] = (1.0, 2.0, 3.0)
    s[:] = c
    e[:] = c
    s[a] += 5.0
    e[b] += 5.0 if ccw else -5.0
    arc = Arc(1, tuple(s), tuple(e), tuple(c), plane, ccw, 50.0)
    pos, *_ = arc_check(arc, np.full(400, 0.05))
    # RS274NGC sense: a CCW arc turns from +first axis towards +second axis
    first = pos[0] - c
    assert np.sign(first[b]) == (1 if ccw else -1)


def test_g18_ccw_turns_from_plus_z_to_plus_x():
    arc = Arc(1, (0, 0, 10), (10, 0, 0), (0, 0, 0), "ZX", True, 50.0)
    assert arc.sweep_rad == pytest.approx(np.pi / 2)
    pos, *_ = arc_check(arc, np.full(400, 0.1))
    assert np.all(pos[:, 0] >= 0) and np.all(pos[:, 2] >= -1e-12)


def test_helix_with_full_turns_and_lead():
    # 2 turns + half, R = 4, climbing 7 mm along Z, CW
    arc = Arc(1, (4, 0, 0), (-4, 0, 7), (0, 0, 0), "XY", False, 50.0, turns=2)
    assert arc.sweep_rad == pytest.approx(-5 * np.pi)
    pos, u, carry, k = arc_check(arc, np.full(2000, 0.07), lead=0.03)
    assert u[-1] == pytest.approx(np.hypot(4 * 5 * np.pi, 7), rel=1e-12)


def test_full_circle_random_steps_with_zeros():
    rng = np.random.default_rng(7)
    steps = rng.uniform(0.0, 0.3, 600)
    steps[rng.random(600) < 0.15] = 0.0
    arc = Arc(1, (3, 1, -1), (3, 1, -1), (1, 1, -1), "XY", True, 50.0)
    assert arc.sweep_rad == pytest.approx(2 * np.pi)
    arc_check(arc, steps)


def test_chord_hand_computed_on_circle():
    # Chord 1 on R = 1: 60 degrees per step, a half circle in exactly 3 periods.
    arc = Arc(1, (1, 0, 0), (-1, 0, 0), (0, 0, 0), "XY", True, 50.0)
    r = ArcStepper(arc).advance(np.ones(5))
    np.testing.assert_allclose(r.pos_mm[:2], [[0.5, np.sqrt(3) / 2, 0], [-0.5, np.sqrt(3) / 2, 0]],
                               atol=1e-15)
    assert len(r.u) == 3 and r.done and r.carry_mm == pytest.approx(0.0, abs=1e-12)


def test_radius_mismatch_follows_spiral_to_exact_end():
    # End 0.002 mm off the start circle (the interpreter's tolerance): linear-radius spiral
    arc = Arc(1, (5, 0, 0), (0, 5.002, 0), (0, 0, 0), "XY", True, 50.0)
    arc_check(arc, np.full(400, 0.05), radius_end=5.002)


def test_step_wider_than_arc_reaches_end():
    # Full circle of diameter 0.02 with a 0.05 step: no point is 0.05 away, so the end
    # (= start) is reached in one period and the whole step is carried.
    arc = Arc(1, (0.01, 0, 0), (0.01, 0, 0), (0, 0, 0), "XY", True, 50.0)
    s = ArcStepper(arc)
    r = s.advance(np.array([0.05, 0.05]))
    assert s.done and len(r.u) == 1 and r.carry_mm == pytest.approx(0.05)
    assert r.u[0] == pytest.approx(2 * np.pi * 0.01)


def test_steep_helix_step_beyond_half_turn():
    # R = 0.01, 0.5 mm rise per half turn: a 0.7 mm chord needs about 4.4 rad of sweep.
    # The angle is read from Z (monotone here), so jumps beyond pi are checked too.
    arc = Arc(1, (0.01, 0, 0), (0.01, 0, 3), (0, 0, 0), "XY", True, 50.0, turns=2)
    k = 3 / (6 * np.pi)
    pos, u, carry, n = run_all(ArcStepper(arc), np.full(40, 0.7))
    th = pos[:, 2] / k
    assert np.diff(np.r_[0, th])[:-1].min() > np.pi  # every full step sweeps over half a turn
    np.testing.assert_allclose(pos[:, :2], 0.01 * np.c_[np.cos(th), np.sin(th)], atol=GEOM_TOL_MM)
    ch = chords(np.array(arc.start), pos)
    np.testing.assert_allclose(ch[:-1], 0.7, rtol=1e-12)
    assert carry == pytest.approx(0.7 - ch[-1], abs=1e-12)
    np.testing.assert_allclose(u, np.hypot(0.01, k) * th, rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    plane=st.sampled_from(["XY", "ZX", "YZ"]),
    ccw=st.booleans(),
    r=st.floats(0.05, 50.0),
    a0=st.floats(-np.pi, np.pi),
    sweep=st.floats(0.01, 2 * np.pi - 0.01),
    turns=st.integers(0, 2),
    rise=st.floats(-20.0, 20.0),
    step=st.floats(0.001, 0.5),
    lead_frac=st.floats(0.0, 1.0),
)
def test_random_arcs(plane, ccw, r, a0, sweep, turns, rise, step, lead_frac):
    a, b, n = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}[plane]
    c = np.array([0.3, -1.2, 2.0])
    s, e = c.copy(), c.copy()
    a1 = a0 + (sweep if ccw else -sweep)
    s[a] += r * np.cos(a0)
    s[b] += r * np.sin(a0)
    e[a] += r * np.cos(a1)
    e[b] += r * np.sin(a1)
    e[n] += rise
    arc = Arc(1, tuple(s), tuple(e), tuple(c), plane, ccw, 50.0, turns=turns)
    length = np.hypot(r * abs(arc.sweep_rad), rise)
    # steps wider than half a turn's chord have their own tests above
    assume(step < 0.9 * np.hypot(2 * r, rise / abs(arc.sweep_rad) * np.pi))
    n_steps = int(length / step) + 5
    if n_steps > 20000:
        step = length / 19990
        n_steps = 20000
    arc_check(arc, np.full(n_steps, step), lead=lead_frac * step)
