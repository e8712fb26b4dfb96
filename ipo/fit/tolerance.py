"""Fitting a polyline within a tolerance with the fewest NC blocks.

A G01 polyline is replaced by 001 rational fits only where every point of the
curve lies within `tol_mm` of the polyline and every point of the polyline within
`tol_mm` of the curve. Both are measured at points no more than SAMPLE_SPACING_MM
apart (at least MIN_SAMPLES per segment), conservatively: each is the distance to
one particular point of the other path (a segment's nearest point, or the curve
point found by golden section), so it can only overstate the true distance. The
control-point count is searched (the largest useful count first, then doubling and
bisection).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.fit.compiled import foot_params
from ipo.fit.rational import RationalFit, SpanPolynomials, evaluate, fit_rational

SAMPLE_SPACING_MM = 0.02  # densest spacing of check points along a segment
MIN_SAMPLES, MAX_SAMPLES = 4, 64  # per data interval
WINDOW = 3  # segments either side of a curve sample's own interval that it is checked against
MAX_CTRL = 48  # a piece needing more control points is split instead
GOOD_ENOUGH = 0.5  # a fit stops improving once every data point is this fraction of the tolerance close


def _point_segment_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    len2 = np.einsum("ij,ij->i", ab, ab)
    t = np.where(len2 > 0, np.einsum("ij,ij->i", p - a, ab) / np.where(len2 > 0, len2, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


def _samples_per_interval(q: np.ndarray) -> np.ndarray:
    seg = np.linalg.norm(np.diff(q, axis=0), axis=1)
    return np.clip(np.ceil(seg / SAMPLE_SPACING_MM).astype(int) + 1, MIN_SAMPLES, MAX_SAMPLES)


def _interval_samples(lo: np.ndarray, hi: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`counts[j]` evenly spaced values on [lo[j], hi[j]] for every j, and their owner j."""
    owner = np.repeat(np.arange(len(counts)), counts)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    t = (np.arange(counts.sum()) - start[owner]) / (counts[owner] - 1)
    return lo[owner] + t * (hi[owner] - lo[owner]), owner


def max_deviation(fit: RationalFit, q: np.ndarray) -> float:
    """Upper bound of the two-way distance between the curve and the polyline q."""
    u = fit.params
    spans = SpanPolynomials(fit.knots, fit.degree)
    poly = spans.homogeneous(fit.points * fit.weights[:, None], fit.weights)
    evaluate = spans.curve_of(poly)

    counts = _samples_per_interval(q)
    n_seg = len(q) - 1
    # curve -> polyline: curve samples on each data interval against nearby segments
    uu, owner = _interval_samples(u[:-1], u[1:], counts)
    pts = evaluate(uu)
    to_poly = np.full(len(uu), np.inf)
    for off in range(-WINDOW, WINDOW + 1):
        seg = np.clip(owner + off, 0, n_seg - 1)
        to_poly = np.minimum(to_poly, _point_segment_dist(pts, q[seg], q[seg + 1]))
    # polyline -> curve: segment samples projected onto the curve near their interval
    tt, owner = _interval_samples(np.zeros(n_seg), np.ones(n_seg), counts)
    seg_pts = q[owner] + tt[:, None] * (q[owner + 1] - q[owner])
    lo = u[np.clip(owner - 1, 0, n_seg)]
    hi = u[np.clip(owner + 2, 0, n_seg)]
    # a knot of multiplicity >= degree is a corner: the distance is not unimodal across it, so the
    # foot search stays on the interval's own side of the nearest corner knots
    inner = fit.knots[fit.degree + 1:-fit.degree - 1]
    values, mult = np.unique(inner, return_counts=True)
    corners = np.concatenate([[u[0]], values[mult >= fit.degree], [u[-1]]])
    eps = 1e-9 * (u[-1] - u[0])  # a data parameter on a corner knot may be off it by rounding
    lo = np.maximum(lo, corners[np.searchsorted(corners, u[owner] + eps, side="right") - 1])
    hi = np.minimum(hi, corners[np.searchsorted(corners, u[owner + 1] - eps, side="left")])

    def dist2(x):
        return np.sum((seg_pts - evaluate(x)) ** 2, axis=1)

    foot = foot_params(poly, spans.starts, seg_pts, lo, hi, 28)
    to_curve = np.sqrt(np.minimum(dist2(foot), np.minimum(dist2(lo), dist2(hi))))
    return float(max(to_poly.max(), to_curve.max()))


@dataclass(frozen=True, slots=True)
class FitSettings:
    tol_mm: float
    degree: int = 3
    max_iter: int = 15
    rel_delta: float = 1e-3
    rational: bool = True


def _try(q: np.ndarray, m: int, s: FitSettings, warm: RationalFit | None) -> tuple[RationalFit, float | None]:
    """Fit with m control points, starting from a previous fit's parameters (rescaled) if given,
    and its checked deviation (None where it is not within tolerance)."""
    params = None
    if warm is not None:
        params = warm.params * (m - s.degree) / (len(warm.points) - s.degree)
    fit = fit_rational(q, m, s.degree, max_iter=s.max_iter, rel_delta=s.rel_delta, rational=s.rational,
                       params=params, give_up_above=s.tol_mm, good_below=GOOD_ENOUGH * s.tol_mm)
    if not np.all(np.isfinite(fit.points)):
        return fit, None
    # the data points' distances to their own curve points first: far cheaper than the two-way
    # check; after the parameter correction they are the distances to the curve (within its bracket)
    if np.max(np.linalg.norm(q - evaluate(fit, fit.params), axis=1)) > s.tol_mm:
        return fit, None
    dev = max_deviation(fit, q)
    return fit, (dev if dev <= s.tol_mm else None)


def fewest_ctrl(q: np.ndarray, s: FitSettings, m_max: int) -> tuple[RationalFit, float] | None:
    """Smallest control-point count <= m_max whose fit is within tolerance, and its deviation.

    m_max is tried first (a piece that fails there is not worth fitting, and most
    failures end after a few iterations); then doubling from degree + 1 up to the
    first success, and bisection below it, each fit starting from the parameters
    of the best fit so far."""
    lo = s.degree + 1
    m_max = min(m_max, len(q))
    if m_max < lo:
        return None
    best = _try(q, m_max, s, None)
    if best[1] is None:
        return None
    bad, hi, m = lo - 1, m_max, lo
    while m < hi:
        fit = _try(q, m, s, best[0])
        if fit[1] is not None:
            hi, best = m, fit
            break
        bad, m = m, 2 * m
    while hi - bad > 1:
        mid = (hi + bad) // 2
        fit = _try(q, mid, s, best[0])
        if fit[1] is not None:
            hi, best = mid, fit
        else:
            bad = mid
    return best


def densify(q: np.ndarray) -> np.ndarray:
    """The same polyline with points added on its longer segments.

    001 uses uniform knots and chord-length parameters: where a long segment holds
    no data point, knot spans go empty and the least squares are ill-posed. Points
    on the segments are data of the same path (a fit must follow the segments too).
    The spacing is the median segment, but no finer than needed for MAX_CTRL spans."""
    seg = np.linalg.norm(np.diff(q, axis=0), axis=1)
    spacing = max(float(np.median(seg)), float(seg.sum()) / (3 * MAX_CTRL), 1e-12)
    parts = np.maximum(np.ceil(seg / spacing).astype(int), 1)
    t = np.concatenate([np.arange(k) / k for k in parts])
    owner = np.repeat(np.arange(len(seg)), parts)
    return np.vstack([q[owner] + t[:, None] * (q[owner + 1] - q[owner]), q[-1:]])
