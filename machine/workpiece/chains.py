"""Runs of consecutive period positions that stay within a thin sleeve around one straight line (numba).

The Z-map cuts every period's segment exactly (machine/workpiece/removal.py), but it asks about a whole
run of segments at once: every point of a run lies within CHAIN_TOL_MM of the straight line through the
run's first and last positions, and the points' projections on that line advance (never step back). A
segment between two such points then lies, point for point, within the run's deviation of the line's
piece between the two projections (distance to a line is convex), which bounds the segment's envelope
from below by that of a slightly larger tool on the line. The bound only decides which segments need
their exact envelope: the tolerance trades the runs' length against the bounds' slack, never the result.

Along a G01 block the periods are collinear but for the BLU rounding (at most 0.87 BLU off the line in
3D), so a run is a block or more; along a curve a run is as long as its sagitta allows.
"""
from __future__ import annotations

import math

from numba import njit

CHAIN_TOL_MM = 0.001  # sleeve radius: the BLU rounding's reach at 1 um (0.87 um in 3D) and a little more
MAX_SEGMENTS = 4096  # a run's segments at most (an exceedingly long straight stays several runs)


@njit(cache=True)
def _fits(pos, a, b, tol2):
    """Points a+1 .. b-1 within sqrt(tol2) of the line P_a -> P_b, their projections advancing in [0, 1]."""
    bx, by, bz = pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2]
    ll = bx * bx + by * by + bz * bz
    s_prev = 0.0
    for k in range(a + 1, b):
        px, py, pz = pos[k, 0] - pos[a, 0], pos[k, 1] - pos[a, 1], pos[k, 2] - pos[a, 2]
        if ll == 0.0:
            if px != 0.0 or py != 0.0 or pz != 0.0:
                return False
            continue
        s = (px * bx + py * by + pz * bz) / ll
        if s < s_prev or s > 1.0:
            return False
        ex, ey, ez = px - s * bx, py - s * by, pz - s * bz
        if ex * ex + ey * ey + ez * ez > tol2:
            return False
        s_prev = s
    return True


@njit(cache=True)
def build_chains(pos, tol_mm, max_segments, starts):
    """Split the segments pos[k] -> pos[k+1] into runs; run c covers the points starts[c] .. starts[c+1]
    (consecutive runs share their joint). Returns the number of runs. Each run is grown by doubling its
    length while it fits, then by bisection between the last length that fit and the first that did not."""
    n = pos.shape[0] - 1
    tol2 = tol_mm * tol_mm
    count = 0
    a = 0
    while a < n:
        limit = min(a + max_segments, n)
        good = a + 1
        bad = limit + 1
        while good < limit:
            nxt = min(a + 2 * (good - a), limit)
            if _fits(pos, a, nxt, tol2):
                good = nxt
            else:
                bad = nxt
                break
        while bad - good > 1:
            mid = (good + bad) // 2
            if _fits(pos, a, mid, tol2):
                good = mid
            else:
                bad = mid
        starts[count] = a
        count += 1
        a = good
    starts[count] = n
    return count


@njit(cache=True)
def deviation(pos, a, b):
    """(3D, horizontal, vertical) largest distance of the points a .. b from their projections on the
    line P_a -> P_b (0 for a run standing still)."""
    bx, by, bz = pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2]
    ll = bx * bx + by * by + bz * bz
    e3 = exy = ez = 0.0
    if ll == 0.0:
        return e3, exy, ez
    for k in range(a + 1, b):
        px, py, pz = pos[k, 0] - pos[a, 0], pos[k, 1] - pos[a, 1], pos[k, 2] - pos[a, 2]
        s = (px * bx + py * by + pz * bz) / ll
        ex, ey, ez_k = px - s * bx, py - s * by, pz - s * bz
        e3 = max(e3, math.sqrt(ex * ex + ey * ey + ez_k * ez_k))
        exy = max(exy, math.hypot(ex, ey))
        ez = max(ez, abs(ez_k))
    return e3, exy, ez
