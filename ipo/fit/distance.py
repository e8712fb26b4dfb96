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

import numpy as np
from numba import njit

from ipo.fit.rational import RationalFit, SpanPolynomials

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


def curve_samples(fit: RationalFit) -> tuple[np.ndarray, np.ndarray]:
    """Samples of the curve evenly spaced along it (at most SAMPLE_SPACING_MM apart) and each chord's
    gap to the curve."""
    spans = SpanPolynomials(fit.knots, fit.degree)
    at = spans.curve_of(spans.homogeneous(fit.points * fit.weights[:, None], fit.weights))
    ends = np.append(spans.starts, fit.knots[-1])
    out, gaps = [], []
    for a, b in zip(ends[:-1], ends[1:]):
        u = np.linspace(a, b, SPAN_PROBES)
        p = at(u)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        n = int(min(MAX_SAMPLES_PER_SPAN, max(2, np.ceil(s[-1] / SAMPLE_SPACING_MM) + 1)))
        u = np.interp(np.linspace(0.0, s[-1], n), s, u) if s[-1] > 0 else np.linspace(a, b, n)
        p = at(u)
        gaps.append(_chord_gap(at(0.5 * (u[:-1] + u[1:])), p[:-1], p[1:]))
        out.append(p if not out else p[1:])
    return np.vstack(out), np.concatenate(gaps)


def _chord_gap(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    len2 = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", x - a, ab) / np.where(len2 > 0, len2, 1.0), 0.0, 1.0)
    return np.linalg.norm(x - (a + t[:, None] * ab), axis=1)


def written_deviation_mm(fit: RationalFit, path: np.ndarray, exact_above_mm: float = np.inf) -> float:
    """Upper bound of the two-way distance between the curve and the polyline `path` (points whose walked
    bound is above exact_above_mm, the caller's tolerance, are measured exactly: see the module doc)."""
    samples, gaps = curve_samples(fit)
    return float(two_way_mm(samples, gaps, np.ascontiguousarray(path, dtype=float), exact_above_mm))
