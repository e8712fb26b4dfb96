"""G64 Q collinear merging (ipo.feed.merge) against hand-built cases and brute-force distances,
and through the planner: the merged run takes fewer periods and stays within P + Q + delta."""
from __future__ import annotations

import numpy as np
import pytest

import ipr
from ipo.config import default_config
from ipo.contracts import PeriodBatch
from ipo.feed.merge import MAX_CHAIN, merge_collinear
from ipo.feed.planner import plan_periods
from ipr.entities import Arc, Line, PathControl, Rapid
from tests.ipo.feed.test_nurbs_blend import distance_to_polyline

Q = PathControl(blend_tol_mm=0.1, merge_tol_mm=0.01)


def polyline(points, path=Q, feed=50.0):
    return [Line(i + 1, tuple(map(float, a)), tuple(map(float, b)), feed, path)
            for i, (a, b) in enumerate(zip(points[:-1], points[1:]))]


def seg_distance(p, a, b):
    m = b - a
    t = np.clip((p - a) @ m / (m @ m), 0, 1)
    return np.linalg.norm(p - (a + t[:, None] * m), axis=1)


def test_a_wobble_within_q_is_one_line_and_keeps_its_first_line_number():
    x = np.linspace(0, 10, 21)
    pts = np.c_[x, 0.0045 * (-1) ** np.arange(21), np.zeros(21)]  # within 2 x 0.0045 of start -> newest
    out = list(merge_collinear(polyline(pts)))
    assert len(out) == 1
    assert out[0].start == tuple(pts[0]) and out[0].end == tuple(pts[-1]) and out[0].line == 1


def test_a_wobble_beyond_q_is_not_merged():
    x = np.linspace(0, 10, 21)
    pts = np.c_[x, 0.011 * (-1) ** np.arange(21), np.zeros(21)]
    out = list(merge_collinear(polyline(pts)))
    assert len(out) == 20


def test_a_corner_ends_the_chain_and_the_next_starts_on_it():
    pts = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [3, 1, 0], [3, 2, 0]], float)
    out = list(merge_collinear(polyline(pts)))
    assert [(o.start, o.end) for o in out] == [((0.0, 0, 0), (3.0, 0, 0)), ((3.0, 0, 0), (3.0, 2, 0))]


def test_the_chain_holds_at_most_max_chain_points_as_linuxcnc():
    n = 250
    pts = np.c_[np.arange(n + 1, dtype=float), np.zeros(n + 1), np.zeros(n + 1)]
    out = list(merge_collinear(polyline(pts)))
    assert [round(o.end[0] - o.start[0]) for o in out] == [MAX_CHAIN, MAX_CHAIN, n - 2 * MAX_CHAIN]


@pytest.mark.parametrize("breaker", ["feed", "g61", "no_q", "rapid", "arc"])
def test_anything_but_a_like_g1_ends_the_chain(breaker):
    pts = np.c_[np.arange(5, dtype=float), np.zeros(5), np.zeros(5)]
    ents = polyline(pts)
    e = ents[2]
    if breaker == "feed":
        ents[2] = Line(e.line, e.start, e.end, 60.0, Q)
    elif breaker == "g61":
        ents[2] = Line(e.line, e.start, e.end, 50.0, PathControl(exact_stop=True))
    elif breaker == "no_q":
        ents[2] = Line(e.line, e.start, e.end, 50.0, PathControl(blend_tol_mm=0.1))
    elif breaker == "rapid":
        ents[2] = Rapid(e.line, e.start, e.end, Q)
    else:
        ents[2] = Arc(e.line, e.start, e.end, (2.5, 0.0, 0.0), "XY", True, 50.0, path=Q)
    out = list(merge_collinear(ents))
    assert [(o.start[0], o.end[0]) for o in out] == [(0.0, 2.0), (2.0, 3.0), (3.0, 4.0)]
    assert out[1] is ents[2]


def test_random_polylines_merge_within_q_of_every_programmed_point():
    rng = np.random.default_rng(7)
    for _ in range(20):
        steps = rng.normal(size=(300, 3)) * [1.0, 0.004, 0.004] + [0, 0, 0]
        steps[rng.random(300) < 0.05] *= [1, 200, 200]  # some real corners
        pts = np.vstack([np.zeros(3), np.cumsum(np.abs(steps) * [1, 1, 1], axis=0)])
        ents = polyline(pts)
        out = list(merge_collinear(ents))
        assert len(out) < len(ents)
        # the merged path is continuous and ends where the program ends
        for a, b in zip(out[:-1], out[1:]):
            assert a.end == b.start
        assert out[0].start == ents[0].start and out[-1].end == ents[-1].end
        # every programmed vertex is within Q of the merged line that replaced it
        k = 0
        for o in out:
            a, b = np.array(o.start), np.array(o.end)
            covered = [np.array(ents[k].start)]
            while ents[k].end != o.end:
                covered.append(np.array(ents[k].end))
                k += 1
            k += 1
            assert seg_distance(np.array(covered), a, b).max() <= 0.01 + 1e-12


def periods(text, cfg):
    prog = ipr.parse_text(text, "q.ngc")
    start = next(e for e in prog.entities if isinstance(e, (Line, Rapid))).start
    pos = [b.pos_mm for b in plan_periods(prog.entities, cfg, start_mm=start) if isinstance(b, PeriodBatch)]
    return np.vstack(pos)


def test_planner_merges_under_q_faster_and_within_p_plus_q():
    x = np.linspace(0, 20, 201)
    y = 0.002 * (-1) ** np.arange(201)
    body = "".join(f"X{a:.4f} Y{b:.4f}\n" for a, b in zip(x[1:], y[1:]))
    head = "G21 G90 G17 G0 X0 Y0\nG1 F3000\n"
    cfg = default_config()
    with_q = periods(head + "G64 P0.001 Q0.005\n" + body + "M2\n", cfg)
    without = periods(head + "G64 P0.001\n" + body + "M2\n", cfg)
    assert len(with_q) < len(without)
    dense = np.concatenate([np.linspace(a, b, 50) for a, b in zip(x[:-1], x[1:])])
    programmed = np.c_[dense, np.interp(dense, x, y), np.zeros_like(dense)]
    assert distance_to_polyline(programmed, with_q).max() <= 0.001 + 0.005 + cfg.chord_tol_mm
