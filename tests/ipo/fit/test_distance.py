"""ipo.fit.distance: the two-way distance bound between a written curve and the path it replaces."""
from __future__ import annotations

import numpy as np

from ipo.fit.distance import two_way_mm


def _dense(poly: np.ndarray, step_mm: float) -> np.ndarray:
    """The polyline's vertices and points along its segments at most step_mm apart, in order."""
    out = [poly[:1]]
    for a, b in zip(poly[:-1], poly[1:]):
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / step_mm)))
        out.append(a + np.arange(1, k + 1)[:, None] / k * (b - a))
    return np.vstack(out)


def test_points_the_walks_cannot_place_are_measured_against_every_segment():
    # a closed 1 mm square path, and a curve 3 um inside it that starts at another corner: its first
    # samples lie nearest the path's last side, the walks (which follow the path's order) cannot get
    # there. The exact two-way distance is 3 * sqrt(2) um (a path corner to the inner square's corner).
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0]], dtype=float)
    e = 0.003
    inner = np.array([[1 - e, 1 - e, 0], [e, 1 - e, 0], [e, e, 0], [1 - e, e, 0], [1 - e, 1 - e, 0]])
    samples = _dense(inner, 0.01)
    gaps = np.zeros(len(samples) - 1)
    walked = two_way_mm(samples, gaps, square, np.inf)
    assert walked > 0.5  # the walks alone: a bound, hundreds of times the distance
    bound = two_way_mm(samples, gaps, square, 0.01)
    assert e * np.sqrt(2.0) - 1e-12 <= bound <= 0.01  # still a bound, now within the tolerance tested
    assert abs(two_way_mm(samples, gaps, square, 0.0) - e * np.sqrt(2.0)) < 1e-12  # every point exact
    # where the walks place every point (a curve that follows the path), the threshold changes nothing
    along = _dense(square + [0.0, 0.0, e], 0.01)
    flat = np.zeros(len(along) - 1)
    assert two_way_mm(along, flat, square, 0.01) == two_way_mm(along, flat, square, np.inf)
    assert abs(two_way_mm(along, flat, square, np.inf) - e) < 1e-12
