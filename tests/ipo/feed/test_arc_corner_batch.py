"""The batched corner blends next to arcs (ipo.feed.arc_corners) against curve_corner.corner_blend,
corner by corner, to the bit: the same found/not found, the same d and the same control points,
on random arc chains (arc-arc, arc-line and line-arc corners) whose blends are shrunk
(the arcs bend within d)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ipo.feed import pieces
from ipo.feed.analytic import point_tangent, points_along_piece
from ipo.feed.arc_corners import arc_corner_blends
from ipo.feed.blends.curve_corner import Side, corner_blend
from tests.ipo.feed.test_jerk_profile import random_arc_chain


def _side(g, is_arc, start, unit, length, i, from_end):
    """The move next to a corner as corner_blend takes it (ipo.feed.pieces._side, by hand)."""
    sign, base = (-1.0, length[i]) if from_end else (1.0, 0.0)
    if is_arc[i]:
        return Side(lambda x: point_tangent(g, i, base + sign * x),
                    lambda x, n: points_along_piece(g, i, base, sign, x, n), None)
    return Side(lambda x: (start[i] + unit[i] * (base + sign * x), unit[i]),
                lambda x, n: start[i] + unit[i] * (base + sign * np.array([0.0, x]))[:, None], None)


def _one_by_one(g, is_arc, start, unit, length, end, js, theta, tol_mm, d_max):
    found, d, ctrl = np.zeros(len(js), bool), np.zeros(len(js)), np.zeros((len(js), 4, 3))
    for k, j in enumerate(js):
        r = corner_blend(_side(g, is_arc, start, unit, length, j, True),
                         _side(g, is_arc, start, unit, length, j + 1, False),
                         end[j], float(theta[k]), float(tol_mm[k]), float(d_max[k]))
        if r is not None:
            found[k], d[k], ctrl[k] = True, *r
    return found, d, ctrl


class _Compared(Exception):
    """Raised once the corners of a build are compared: the rest of the build is not under test."""


@pytest.mark.parametrize("tol", [0.05, 0.2])
def test_batch_equals_corner_blend_bit_for_bit(monkeypatch, tol):
    seen = {"corners": 0, "shrunk": 0}

    def both(*args):
        found, d, ctrl = arc_corner_blends(*args)
        ref_found, ref_d, ref_ctrl = _one_by_one(*args)
        np.testing.assert_array_equal(found, ref_found)
        assert d[found].tobytes() == ref_d[found].tobytes()
        assert ctrl[found].tobytes() == ref_ctrl[found].tobytes()
        half = 0.5 * args[7]
        first = np.minimum(args[8] / (1.0 / np.cos(half) - 1.0) * np.tan(half), args[9])
        seen["corners"] += len(found)
        seen["shrunk"] += int((found & (d < first)).sum())
        raise _Compared

    monkeypatch.setattr(pieces, "arc_corner_blends", both)
    ents = random_arc_chain(np.random.default_rng(7), n=3000, tol=tol)
    with pytest.raises(_Compared):
        pieces.build([pieces.Motion(e, 0.0, -1) for e in ents], final=True, lead_trim_mm=0.0, blend_default_mm=tol,
                     rapid_mm_s=100.0, drivers={}, next_index=0, make_drivers=None)
    assert seen["corners"] > 3000 and seen["shrunk"] > 300


def test_side_by_hand_is_the_planners():
    """_side above is ipo.feed.pieces._side for lines and arcs (what corner_blend is given in the planner)."""
    rng = np.random.default_rng(1)
    g = SimpleNamespace(geometry=None)
    start, unit, length = rng.normal(size=(2, 3)), rng.normal(size=(2, 3)), np.array([3.0, 4.0])
    mine = _side(None, np.array([False, False]), start, unit, length, 0, True)
    planners = pieces._side(None, -1, None, g, start, unit, length, 0, from_end=True)
    assert mine.at(0.7)[0].tobytes() == planners.at(0.7)[0].tobytes()
    assert mine.polyline(0.7, 65).tobytes() == planners.polyline(0.7, 65).tobytes()
