"""The two-way distance between a written curve and the path it replaces, bounded from above.

The curve is sampled evenly along its length (each knot span first at SPAN_PROBES
parameters, then again at equal arc length, so a rational span that runs fast near
its ends and slowly at a tight apex is sampled as densely everywhere). Then, walking
both in path order:

- every sample's distance to the path: the distance to one segment near the one
  the previous sample was nearest to (any segment's distance is at least the true one);
- every point of the path (its vertices and points along its segments at most
  DENSE_SPACING_MM apart) to one chord of the samples, plus that chord's gap to the
  curve (measured at the chord's middle parameter).

Both can only overstate the distance, so a curve accepted here is within the bound;
the walks assume the curve follows the path's order, which a fitted piece does (a
walk that loses its place overstates, it never understates). A path that comes back
along itself (a V-carving's out-and-back strokes, a Z-only dip and lift at one XY)
can lose a walk its place: a later pass lies as near as the right one, the walk takes
it and cannot come back. So a point whose walked bound is above `exact_above_mm` (the
tolerance the caller tests) is measured against every segment (every chord, plus its
gap), which is the exact distance (the same bound) and never more than the walk's,
and the walk goes on from the segment found. On LinuxCNC's Pasta.ngc (a VCarve
program) a group within 8.6 um both ways (brute force) was bounded at 20,302 um by
the walks alone.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ipo.fit.rational import RationalFit, SpanPolynomials
from ipo.numpy_kernels import interp_at, linspace_into

SPAN_PROBES = 257
SAMPLE_SPACING_MM = 0.01
MAX_SAMPLES_PER_SPAN = 20000
DENSE_SPACING_MM = 0.01
LOOKAHEAD = 3  # segments past a rise in distance that a walk still looks at


@njit(cache=True)
def seg_dist2(p0, p1, p2, pts, i):
    """Squared distance from (p0, p1, p2) to the segment pts[i] pts[i + 1]."""
    a0, a1, a2 = pts[i, 0], pts[i, 1], pts[i, 2]
    ab0, ab1, ab2 = pts[i + 1, 0] - a0, pts[i + 1, 1] - a1, pts[i + 1, 2] - a2
    ap0, ap1, ap2 = p0 - a0, p1 - a1, p2 - a2
    len2 = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    t = 0.0
    if len2 > 0.0:
        t = min(1.0, max(0.0, (ap0 * ab0 + ap1 * ab1 + ap2 * ab2) / len2))
    d0, d1, d2 = ap0 - t * ab0, ap1 - t * ab1, ap2 - t * ab2
    return d0 * d0 + d1 * d1 + d2 * d2


@njit(cache=True)
def walk(p0, p1, p2, pts, n, j):
    """Smallest squared distance from (p0, p1, p2) to the chords pts[i] pts[i+1] (i >= j - 1, i + 1 < n),
    found walking forward from j while it falls (looking LOOKAHEAD chords past a rise); and where."""
    j = min(max(j - 1, 0), n - 2)
    best = seg_dist2(p0, p1, p2, pts, j)
    at = j
    i = j + 1
    rises = 0
    while i < n - 1 and rises <= LOOKAHEAD:
        d = seg_dist2(p0, p1, p2, pts, i)
        if d < best:
            best, at, rises = d, i, 0
        else:
            rises += 1
        i += 1
    return best, at


@njit(cache=True)
def nearest(p0, p1, p2, pts, n, gap):
    """Smallest distance from (p0, p1, p2) to a chord pts[i] pts[i+1] plus gap[i], over every chord; and where."""
    best = np.inf
    at = 0
    for i in range(n - 1):
        d = np.sqrt(seg_dist2(p0, p1, p2, pts, i)) + gap[i]
        if d < best:
            best, at = d, i
    return best, at


@njit(cache=True)
def two_way_mm(samples, gap_mm, path, exact_above_mm):
    """The bound of the module doc: samples (m, 3) of the curve in order, gap_mm (m - 1,) each
    chord's gap to the curve, path (n, 3) the polyline; a walked bound above exact_above_mm (and
    above the worst so far) is measured against every segment instead."""
    worst = 0.0
    j = 0
    n_s, n_p = samples.shape[0], path.shape[0]
    flat = np.zeros(max(n_p - 1, 1))
    for i in range(n_s):
        d2, j = walk(samples[i, 0], samples[i, 1], samples[i, 2], path, n_p, j)
        d = np.sqrt(d2)
        if d > exact_above_mm and d > worst:
            d, j = nearest(samples[i, 0], samples[i, 1], samples[i, 2], path, n_p, flat)
        worst = max(worst, d)
    j = 0
    for k in range(n_p):
        s0, s1, s2 = 0.0, 0.0, 0.0
        parts = 1
        if k + 1 < n_p:
            s0, s1, s2 = path[k + 1, 0] - path[k, 0], path[k + 1, 1] - path[k, 1], path[k + 1, 2] - path[k, 2]
            parts = max(1, int(np.ceil(np.sqrt(s0 * s0 + s1 * s1 + s2 * s2) / DENSE_SPACING_MM)))
        for m in range(parts):
            f = m / parts
            x0, x1, x2 = path[k, 0] + f * s0, path[k, 1] + f * s1, path[k, 2] + f * s2
            d2, j = walk(x0, x1, x2, samples, n_s, j)
            d = np.sqrt(d2) + gap_mm[j]
            if d > exact_above_mm and d > worst:
                d, j = nearest(x0, x1, x2, samples, n_s, gap_mm)
            worst = max(worst, d)
    return worst


@njit(cache=True)
def _point_at(poly, starts, u, out):
    """C(u) into out (3,) from the span polynomials (SpanPolynomials.curve_of, the same arithmetic)."""
    p = poly.shape[1] - 1
    k = min(max(np.searchsorted(starts, u, side="right") - 1, 0), starts.shape[0] - 1)
    x = u - starts[k]
    for d in range(4):
        acc = poly[k, p, d]
        for power in range(p - 1, -1, -1):
            acc = acc * x + poly[k, power, d]
        out[d] = acc
    for d in range(3):
        out[d] /= out[3]


@njit(cache=True)
def _samples(poly, starts, u_end):
    """curve_samples' points and gaps from the span polynomials (poly, starts) ending at u_end."""
    n_spans = starts.shape[0]
    counts = np.empty(n_spans, np.int64)
    probes = np.empty((n_spans, SPAN_PROBES))  # each span's samples at equal arc length (the first counts[i])
    u = np.empty(SPAN_PROBES)
    s = np.empty(SPAN_PROBES)
    at, prev = np.empty(4), np.empty(4)
    for i in range(n_spans):
        b = starts[i + 1] if i + 1 < n_spans else u_end
        linspace_into(starts[i], b, SPAN_PROBES, u, 0)
        s[0] = 0.0
        _point_at(poly, starts, u[0], prev)
        for j in range(1, SPAN_PROBES):
            _point_at(poly, starts, u[j], at)
            d0, d1, d2 = at[0] - prev[0], at[1] - prev[1], at[2] - prev[2]
            s[j] = s[j - 1] + np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
            prev[:] = at
        counts[i] = int(min(MAX_SAMPLES_PER_SPAN, max(2.0, np.ceil(s[-1] / SAMPLE_SPACING_MM) + 1)))
        if counts[i] > SPAN_PROBES:
            probes = _wider(probes, counts[i])
        row = probes[i]
        if s[-1] > 0:
            linspace_into(0.0, s[-1], counts[i], row, 0)
            for j in range(counts[i]):
                row[j] = interp_at(row[j], s, u)
        else:
            linspace_into(starts[i], b, counts[i], row, 0)
    total = 1 + np.sum(counts - 1)
    points = np.empty((total, 3))
    gaps = np.empty(total - 1)
    mid, a, c = np.empty(4), np.empty(4), np.empty(4)
    m = 0
    for i in range(n_spans):
        row = probes[i]
        _point_at(poly, starts, row[0], a)
        if i == 0:
            points[0] = a[:3]
            m = 1
        for j in range(1, counts[i]):
            _point_at(poly, starts, row[j], c)
            _point_at(poly, starts, 0.5 * (row[j - 1] + row[j]), mid)
            gaps[m - 1] = _chord_gap(mid, a, c)
            points[m] = c[:3]
            m += 1
            a[:] = c
    return points, gaps


@njit(cache=True)
def _wider(rows, width):
    if rows.shape[1] >= width:
        return rows
    out = np.empty((rows.shape[0], width))
    out[:, :rows.shape[1]] = rows
    return out


@njit(cache=True)
def _chord_gap(x, a, b):
    """Distance of x from the chord a-b (numpy's sums: the dot products first plus last, then the middle)."""
    ab0, ab1, ab2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    xa0, xa1, xa2 = x[0] - a[0], x[1] - a[1], x[2] - a[2]
    len2 = (ab0 * ab0 + ab2 * ab2) + ab1 * ab1
    t = min(max(((xa0 * ab0 + xa2 * ab2) + xa1 * ab1) / (len2 if len2 > 0 else 1.0), 0.0), 1.0)
    d0, d1, d2 = x[0] - (a[0] + t * ab0), x[1] - (a[1] + t * ab1), x[2] - (a[2] + t * ab2)
    return np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)


@lru_cache(maxsize=16)
def _span_polynomials(knots: bytes, degree: int) -> SpanPolynomials:
    """SpanPolynomials of knots (float64 bytes), built once per knot vector: every G1 line and G2/G3 arc the fit
    writes is checked as a conic on the knots 0, 0, 0, 1, 1, 1 (the whole g1_stellabee1 at 10 um: 46,140 of
    them, 2.9 s of building the same polynomials again)."""
    return SpanPolynomials(np.frombuffer(knots), degree)


def curve_samples(fit: RationalFit) -> tuple[np.ndarray, np.ndarray]:
    """Samples of the curve evenly spaced along it (at most SAMPLE_SPACING_MM apart) and each chord's
    gap to the curve: each span at SPAN_PROBES equal steps in u, then again at equal chord length."""
    spans = _span_polynomials(np.asarray(fit.knots, dtype=float).tobytes(), fit.degree)
    poly = spans.homogeneous(fit.points * fit.weights[:, None], fit.weights)
    return _samples(np.ascontiguousarray(poly), np.ascontiguousarray(spans.starts, dtype=float), float(fit.knots[-1]))


def written_deviation_mm(fit: RationalFit, path: np.ndarray, exact_above_mm: float = np.inf) -> float:
    """Upper bound of the two-way distance between the curve and the polyline `path` (points whose walked
    bound is above exact_above_mm, the caller's tolerance, are measured exactly: see the module doc)."""
    samples, gaps = curve_samples(fit)
    return float(two_way_mm(samples, gaps, np.ascontiguousarray(path, dtype=float), exact_above_mm))
