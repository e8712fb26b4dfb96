"""Tooth-pass marks (`vcnc run --teeth`, numba): the cutting edges instead of the solid of revolution.

Each of the tool's z flutes is an edge along the profile h(rho) in the half-plane at angle
theta(t) + 2 pi k / z about the axis (theta the spindle angle). Within a period the axis moves on its
segment and theta turns by dth, both linearly in t; a node q at azimuth phi(t) about the moving axis is
cut when theta(t) + 2 pi k / z = phi(t) (mod 2 pi), down to z(t) + h(|q - xy(t)|). The crossings are
found on sub-intervals of the period (at least SUBSTEPS, and enough that the node's azimuth turns by at
most MAX_TURN_RAD in each, at most MAX_SUBSTEPS), on the continuous (unwrapped) angle
G(t) = theta(t) - phi(t), by linear interpolation between the sub-interval's ends.
Needs |dth| < pi per period (the rows give the angle at each period's end): below 30,000 rpm at 1 ms.

The marks depend on the spindle angle of every period, so the update goes period by period (unlike the
solid's, machine/workpiece/removal.py), over the same tiles: a tile is skipped when a lower bound of the
solid's envelope over it (which is below the edges') is not below the tile's highest node: the larger of
min(z0, z1) + h(d - e) (d: the tile centre's distance to the segment, e the tile's half-diagonal) and
env(centre) - e h'(rho_max) (the envelope is Lipschitz in q with h' at the largest distance of a tile
point to the segment's ends).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from machine.workpiece.envelope import cover_interval, envelope, profile_mm, profile_slope, seg_distance
from machine.workpiece.tiles import TILE

SUBSTEPS = 8
MAX_SUBSTEPS = 512
MAX_TURN_RAD = 0.1


@njit(cache=True)
def wrap_pi(a):
    """a wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def tooth_envelope(qx, qy, x0, y0, z0, x1, y1, z1, core, corner, theta0, dtheta, teeth):
    """The lowest height the edges leave at q during the period; inf if no edge passes over it."""
    bx, by, dz = x1 - x0, y1 - y0, z1 - z0
    radius = core + corner
    lo, hi = cover_interval(qx, qy, x0, y0, bx, by, radius)
    if lo > hi:
        return np.inf
    pitch = 2.0 * math.pi / teeth
    # near the axis the node's azimuth turns fast: sub-intervals over which it turns by at most
    # MAX_TURN_RAD, so that G stays monotone between their ends (at most MAX_SUBSTEPS)
    rho_min = max(seg_distance(qx, qy, x0, y0, x1, y1)[0], 1e-9)
    steps = min(max(SUBSTEPS, int(math.ceil(math.hypot(bx, by) * (hi - lo) / (rho_min * MAX_TURN_RAD)))),
                MAX_SUBSTEPS)
    best = np.inf
    t_prev = lo
    g_prev = theta0 + dtheta * lo - math.atan2(qy - y0 - lo * by, qx - x0 - lo * bx)
    for s in range(1, steps + 1):
        t = lo + (hi - lo) * s / steps
        g_raw = theta0 + dtheta * t - math.atan2(qy - y0 - t * by, qx - x0 - t * bx)
        g = g_prev + dtheta * (t - t_prev) + wrap_pi(g_raw - g_prev - dtheta * (t - t_prev))
        a, b = min(g_prev, g), max(g_prev, g)
        m = math.floor(a / pitch) + 1
        while m * pitch <= b:
            tc = t_prev + (m * pitch - g_prev) / (g - g_prev) * (t - t_prev)
            rho = math.hypot(qx - x0 - tc * bx, qy - y0 - tc * by)
            best = min(best, z0 + dz * tc + profile_mm(min(rho, radius), core, corner))
            m += 1
        t_prev, g_prev = t, g
    return best


@njit(cache=True)
def sweep_teeth(zmap, batch, counts, spindle_rad, teeth):
    """Lower zmap.z (ny, nx) by the edges along batch's segments pos[k] -> pos[k+1] (work mm) at the
    spindle angles spindle_rad[k]; zmap.line[j, i] takes lines[k] of the segment that last lowered node
    (i, j). Segments of zero length are skipped, but for the first one when stamp_first. counts
    (updated): tiles looked at, tiles searched, envelopes evaluated, nodes lowered."""
    z, line, tile_max, origin_x, origin_y, grid_mm, floor_mm = zmap
    pos, lines, core, corner, stamp_first = batch
    ny, nx = z.shape
    radius = core + corner
    half_diag = (TILE - 1) * grid_mm / math.sqrt(2.0)
    for k in range(pos.shape[0] - 1):
        x0, y0, z0 = pos[k, 0], pos[k, 1], pos[k, 2]
        x1, y1, z1 = pos[k + 1, 0], pos[k + 1, 1], pos[k + 1, 2]
        if x0 == x1 and y0 == y1 and z0 == z1 and not (stamp_first and k == 0):
            continue
        i0 = max(int(math.floor((min(x0, x1) - radius - origin_x) / grid_mm)), 0)
        i1 = min(int(math.ceil((max(x0, x1) + radius - origin_x) / grid_mm)), nx - 1)
        j0 = max(int(math.floor((min(y0, y1) - radius - origin_y) / grid_mm)), 0)
        j1 = min(int(math.ceil((max(y0, y1) + radius - origin_y) / grid_mm)), ny - 1)
        if i0 > i1 or j0 > j1:
            continue
        z_low = min(z0, z1)
        reach = radius + half_diag
        dtheta = wrap_pi(spindle_rad[k + 1] - spindle_rad[k])
        for ty in range(j0 // TILE, j1 // TILE + 1):
            my = origin_y + (ty * TILE + 0.5 * (TILE - 1)) * grid_mm
            for tx in range(i0 // TILE, i1 // TILE + 1):
                counts[0] += 1
                mx = origin_x + (tx * TILE + 0.5 * (TILE - 1)) * grid_mm
                d = seg_distance(mx, my, x0, y0, x1, y1)[0]
                if d > reach:
                    continue
                top = tile_max[ty, tx]
                if z_low + profile_mm(max(d - half_diag, 0.0), core, corner) >= top:
                    continue
                if corner > 0.0:
                    rho_max = math.sqrt(max((mx - x0) ** 2 + (my - y0) ** 2, (mx - x1) ** 2 + (my - y1) ** 2)) \
                        + half_diag
                    if rho_max < radius:
                        bound = envelope(mx, my, x0, y0, z0, x1, y1, z1, core, corner)[0] \
                            - half_diag * profile_slope(rho_max, core, corner)
                        if bound >= top:
                            continue
                counts[1] += 1
                new_top = -np.inf
                for j in range(ty * TILE, min(ty * TILE + TILE, ny)):
                    qy = origin_y + j * grid_mm
                    for i in range(tx * TILE, min(tx * TILE + TILE, nx)):
                        v = max(tooth_envelope(origin_x + i * grid_mm, qy, x0, y0, z0, x1, y1, z1, core, corner,
                                               spindle_rad[k], dtheta, teeth), floor_mm)
                        counts[2] += 1
                        if v < z[j, i]:
                            z[j, i] = v
                            line[j, i] = lines[k]
                            counts[3] += 1
                        new_top = max(new_top, z[j, i])
                tile_max[ty, tx] = new_top
