"""NURBS the feed stage cannot or can barely walk: refused before motion saying where and why,
or machined in a bounded time.

- A derivative that vanishes only at an end (LinuxCNC's G5.2 with the current position
  repeated as the first control point, g5_trident_3planes.ngc) is machined: the first
  periods leave along the limit tangent, and every period lies on the exact curve (scipy's
  BSpline on homogeneous coordinates) within the chord tolerance and a BLU.
- Extreme weights (the issue's 1, 1e-15, 1e15, 1 and others) are refused by the check with
  E-NURBS-PATH naming u and the position, or run to the end within a bounded number of
  periods (the issue's reproducer crawled at 1.2e-4 mm/s for 379,000 periods and more).
- A cusp inside a curve is refused saying where.
"""
from __future__ import annotations

import numpy as np
import pytest
from conftest import require_corpus
from scipy.interpolate import BSpline

from ipo.config import default_config
from ipr.entities import Nurbs
from machine.controller import Controller, ProgramRejected
from machine.trace import MemoryTrace


def _program(weights, points=((10, 0), (10, 10), (0, 10)), order=4, knots=None) -> str:
    knots = knots or [0.0] * order + [1.0] * order
    ws = [f"{w:.17f}".rstrip("0").rstrip(".") if w < 1 else f"{w:.0f}" for w in weights]
    lines = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z5", f"G6.2 P{order} K{knots[0]:g} X0 Y0 Z5 R{ws[0]} F600"]
    lines += [f"K{k:g} X{x:g} Y{y:g} R{w}" for k, (x, y), w in zip(knots[1:], points, ws[1:])]
    lines += [f"K{k:g}" for k in knots[len(points) + 1:]] + ["M2"]
    return "\n".join(lines) + "\n"


def _run(tmp_path, text, sinks=()):
    path = tmp_path / "p.nc"
    path.write_text(text)
    controller = Controller(default_config(), sinks=list(sinks))
    program = controller.check(path)
    return program, controller.run(program)


def _on_curve_mm(curve: Nurbs, pos: np.ndarray) -> np.ndarray:
    """Distance of each position to the exact curve (dense scipy samples, then the chord between)."""
    p, t = int(curve.degree), np.asarray(curve.knots, float)
    w = np.asarray(curve.weights, float)
    u = np.linspace(t[0], t[-1], 40_001)
    den = BSpline(t, w, p)(u)
    pts = np.stack([BSpline(t, curve.points[:, i] * w, p)(u) / den for i in range(3)], axis=1)
    seg_a, seg_b = pts[:-1], pts[1:]
    d = seg_b - seg_a
    out = np.empty(len(pos))
    for i, x in enumerate(pos):
        s = np.clip(np.einsum("ij,ij->i", x - seg_a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-30), 0, 1)
        out[i] = np.min(np.linalg.norm(seg_a + s[:, None] * d - x, axis=1))
    return out


@pytest.mark.slow
def test_a_derivative_vanishing_at_both_ends_is_machined_along_the_limit_tangent(tmp_path):
    # first and last control points doubled: C'(0) = C'(1) = 0
    text = ("G21 G90 G17 G61\nG0 X0 Y0 Z0\n"
            "G6.2 P4 K0 X0 Y0 Z0 R1 F600\nK0 X0 Y0 R1\nK0 X10 Y20 R1\nK0 X20 Y0 R1\nK0.3 X30 Y10 R1\n"
            "K0.7 X30 Y10 R1\nK1\nK1\nK1\nK1\nM2\n")
    sink = MemoryTrace({})
    program, result = _run(tmp_path, text, [sink])
    assert result.state == "completed", result.fault
    assert np.allclose(result.position_mm, [30, 10, 0], atol=1e-3)
    trace = sink.close()
    curve = next(e for e in program.entities if isinstance(e, Nurbs))
    pos = trace["pos_mm"]
    assert _on_curve_mm(curve, pos[::7]).max() < 1e-3 + 1e-3  # chord tolerance + a BLU
    first = pos[np.linalg.norm(pos, axis=1) > 0.05][0]
    limit_tangent = np.array([10, 20, 0]) / np.linalg.norm([10, 20, 0])
    assert np.dot(first / np.linalg.norm(first), limit_tangent) > 0.999


def test_the_trident_runs(tmp_path):
    path = require_corpus() / "g5_trident_3planes.ngc"
    controller = Controller(default_config())
    result = controller.run(controller.check(path))
    assert result.state == "completed" and result.limit_violations == 0


@pytest.mark.parametrize("weights", [
    (1, 1e-15, 1e15, 1),  # the issue's
    (1, 1e-12, 1e12, 1), (1, 1e-9, 1e9, 1), (1e-8, 1, 1, 1e8), (1, 1e8, 1, 1e8), (1, 1e-6, 1e6, 1),
])
def test_extreme_weights_are_refused_or_run_in_bounded_time(tmp_path, weights):
    try:
        program, result = _run(tmp_path, _program(weights))
    except ProgramRejected as rejected:
        (reason,) = rejected.reasons
        assert ":3:1: error[E-NURBS-PATH]: " in reason and "at u = " in reason and " Y" in reason, reason
        return
    assert result.state == "completed", result.fault
    assert np.allclose(result.position_mm, [0, 10, 5], atol=1e-3)
    # the control polygon (30 mm) bounds the length: at F600 (10 mm/s) and with the rapid, a few seconds
    assert result.cycle_time_s < 10.0


def test_the_issue_reproducer_is_refused_before_motion(tmp_path):
    with pytest.raises(ProgramRejected) as info:
        _run(tmp_path, _program((1, 1e-15, 1e15, 1)))
    assert "E-NURBS-PATH" in info.value.reasons[0] and "weights range from 1e-15 to 1e+15" in info.value.reasons[0]


def test_a_cusp_inside_a_curve_is_refused_saying_where(tmp_path):
    # three coincident interior points of a cubic: C'(0.5) = 0 at X10 Y10
    text = _program((1, 1, 1, 1, 1, 1), points=((5, 5), (10, 10), (10, 10), (10, 10), (20, 0)),
                    order=4, knots=[0, 0, 0, 0, 0.5, 0.5, 1, 1, 1, 1])
    with pytest.raises(ProgramRejected) as info:
        _run(tmp_path, text)
    (reason,) = info.value.reasons
    assert "error[E-NURBS-PATH]: NURBS has a vanishing derivative at u = 0.5 (X10.0000 Y10.0000 Z5.0000)" in reason


def test_even_speed_keeps_the_knots_of_extreme_weights_apart():
    """At a C0 knot whose one-sided speeds differ by 1e18 (weights 1e-9 and 1e9 beside it), the
    knots after it are not rescaled: by that ratio they would collapse onto each other in
    floating point (the fuzz suite found the divide by zero that followed), changing the curve."""
    import warnings

    from ipo.feed.split import even_speed
    knots = np.array([0, 0, 0, 0.5, 0.5, 0.75, 1, 1, 1.0])
    curve = Nurbs(1, 2, knots, np.array([1, 1e-9, 1, 1e9, 1, 1]),
                  np.array([[0, 0, 0], [5, 0, 0], [5, 5, 0], [10, 5, 0], [10, 10, 0], [0, 10, 0.0]]), 10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = even_speed(curve)
    assert np.array_equal(np.unique(out.knots), np.unique(knots))
