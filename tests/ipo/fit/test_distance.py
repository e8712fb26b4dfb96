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


def _numpy_samples(fit):
    """curve_samples' rule in numpy (SpanPolynomials' evaluation): each span at SPAN_PROBES equal steps
    in u, then at equal chord length (np.interp), and each chord's gap at its middle parameter."""
    from ipo.fit.distance import MAX_SAMPLES_PER_SPAN, SAMPLE_SPACING_MM, SPAN_PROBES
    from ipo.fit.rational import SpanPolynomials

    spans = SpanPolynomials(fit.knots, fit.degree)
    at = spans.curve_of(spans.homogeneous(fit.points * fit.weights[:, None], fit.weights))
    ends = np.append(spans.starts, fit.knots[-1])
    out, gaps = [], []
    for a, b in zip(ends[:-1], ends[1:]):
        u = np.linspace(a, b, SPAN_PROBES)
        p = at(u)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        n = int(min(MAX_SAMPLES_PER_SPAN, max(2, np.ceil(s[-1] / SAMPLE_SPACING_MM) + 1)))
        u = np.interp(np.linspace(0.0, s[-1], n), s, u)
        p = at(u)
        x, c0, c1 = at(0.5 * (u[:-1] + u[1:])), p[:-1], p[1:]
        ab = c1 - c0
        len2 = np.einsum("ij,ij->i", ab, ab)
        t = np.clip(np.einsum("ij,ij->i", x - c0, ab) / np.where(len2 > 0, len2, 1.0), 0.0, 1.0)
        gaps.append(np.linalg.norm(x - (c0 + t[:, None] * ab), axis=1))
        out.append(p if not out else p[1:])
    return np.vstack(out), np.concatenate(gaps)


def test_compiled_curve_samples_are_numpys_to_the_bit_and_lie_on_the_curve():
    """A rational quadratic fitted to an ellipse quadrant (uneven weights, spans of different lengths,
    one longer than SPAN_PROBES samples): the compiled samples are the numpy rule's to the bit, lie on
    the curve (within the step of ipo.nurbs.kernel's points at 200,001 parameters) and are about SAMPLE_SPACING_MM apart."""
    from ipo.fit.distance import SAMPLE_SPACING_MM, curve_samples
    from ipo.fit.rational import RationalFit
    from ipo.nurbs.kernel import curve_points

    knots = np.array([0.0, 0.0, 0.0, 0.3, 0.35, 1.0, 1.0, 1.0])
    weights = np.array([1.0, 0.8, 2.5, 0.05, 1.0])
    points = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.1], [5.0, 1.0, 0.2], [6.0, 3.0, 0.0], [6.0, 6.0, -0.1]])
    fit = RationalFit(2, knots, weights, points, np.empty(0), np.empty(0), True)
    samples, gaps = curve_samples(fit)
    ref_samples, ref_gaps = _numpy_samples(fit)
    assert len(samples) > 1000 and np.array_equal(samples, ref_samples) and np.array_equal(gaps, ref_gaps)
    dense = curve_points(2, knots, weights, points, np.linspace(0.0, 1.0, 200001))
    nearest = np.array([np.min(np.linalg.norm(dense - q, axis=1)) for q in samples[::50]])
    assert nearest.max() <= 0.5 * np.linalg.norm(np.diff(dense, axis=0), axis=1).max()  # within the dense step
    assert np.linalg.norm(np.diff(samples, axis=0), axis=1).max() <= 1.05 * SAMPLE_SPACING_MM  # u by linear interp
    assert np.all(gaps >= 0) and gaps.max() < 1e-3  # a chord of 10 um sags far below 1 um
