"""G2/G3 arcs and helices as analytic path pieces (ipo.feed.analytic), compiled for all arcs of a build at once.

An arc of radius r0 from start about centre in its plane (axes a, b; normal n) becomes
c + r(phi) (cos(phi) e1 + sin(phi) e2) + w sigma: e1 points from the centre to the start,
e2 is e1 turned a quarter in the sweep's direction, w carries the helix's rise along n, and
r(phi) = r0 + dr phi spirals to the end's own radius r1 (the end may lie slightly off the
circle), so that the piece ends exactly on the programmed end point. The arithmetic is that
of the array forms these kernels replace, operation by operation (np.cross's, np.sign's),
so the pieces are the same to the bit.
"""
from __future__ import annotations

from math import cos, hypot, sin
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.feed.analytic import frame_into


@njit(cache=True)
def _sign(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x  # a signed zero or nan, as np.sign gives


class ArcSpecs(NamedTuple):
    """A arcs as programmed, one row each."""

    start: np.ndarray  # (A, 3), mm
    end: np.ndarray  # (A, 3), mm
    centre: np.ndarray  # (A, 3), mm
    r0: np.ndarray  # (A,) radius at the start, mm
    sweep: np.ndarray  # (A,) signed sweep, rad
    axes: np.ndarray  # (A, 3) the plane's axes a, b and its normal n


@njit(cache=True)
def arc_pieces(g, length, t_in, t_out, rows, arcs):
    """Rows `rows` of the geometry g (ipo.feed.analytic.Geometry), of length and of the
    tangents at both ends t_in, t_out, from the arcs (ArcSpecs). Returns the first arc whose
    start lies on its centre (r0 = 0, not laid out), or -1."""
    start, end, centre, r0, sweep, axes = arcs
    eye = np.eye(3)
    tt, kk = np.empty((2, 3)), np.empty((2, 3))
    for k in range(rows.shape[0]):
        i = rows[k]
        a, b, n = axes[k, 0], axes[k, 1], axes[k, 2]
        if not r0[k] > 0:
            return k
        r1 = hypot(end[k, a] - centre[k, a], end[k, b] - centre[k, b])
        theta = abs(sweep[k])
        da, db = start[k, a] - centre[k, a], start[k, b] - centre[k, b]
        for q in range(3):
            g.e1[i, q] = (da * eye[a, q] + db * eye[b, q]) / r0[k]
        sg = _sign(sweep[k])
        un, e1 = eye[n], g.e1[i]
        g.e2[i, 0] = (un[1] * e1[2] - un[2] * e1[1]) * sg  # np.cross(un, e1) * np.sign(sweep)
        g.e2[i, 1] = (un[2] * e1[0] - un[0] * e1[2]) * sg
        g.e2[i, 2] = (un[0] * e1[1] - un[1] * e1[0]) * sg
        rise = end[k, n] - start[k, n]
        ln = hypot(0.5 * (r0[k] + r1) * theta, rise)
        for q in range(3):
            g.c[i, q] = centre[k, q] + (start[k, n] - centre[k, n]) * un[q]
            g.w[i, q] = un[q] * rise / ln
        g.radius[i] = r0[k]
        g.dr[i] = (r1 - r0[k]) / theta
        g.omega[i] = theta / ln
        length[i] = ln
        frame_into(g, i, 0.0, tt, kk, 0)
        frame_into(g, i, ln, tt, kk, 1)
        for q in range(3):
            t_in[i, q], t_out[i, q] = tt[0, q], tt[1, q]
    return -1


@njit(cache=True)
def trimmed_arcs(src, src_length, dst, dst_length, src_rows, dst_rows, trim_in, trim_out):
    """The arcs src_rows of geometry src without their first trim_in and last trim_out
    millimetres, as rows dst_rows of geometry dst (and of dst_length)."""
    for k in range(src_rows.shape[0]):
        i, j = src_rows[k], dst_rows[k]
        phi = src.omega[i] * trim_in[k]
        cs, sn = cos(phi), sin(phi)
        for q in range(3):
            dst.e1[j, q] = cs * src.e1[i, q] + sn * src.e2[i, q]
            dst.e2[j, q] = -sn * src.e1[i, q] + cs * src.e2[i, q]
            dst.c[j, q] = src.c[i, q] + src.w[i, q] * trim_in[k]
            dst.w[j, q] = src.w[i, q]
        dst.radius[j] = src.radius[i] + src.dr[i] * phi
        dst.dr[j] = src.dr[i]
        dst.omega[j] = src.omega[i]
        dst_length[j] = max(src_length[i] - trim_in[k] - trim_out[k], 0.0)
