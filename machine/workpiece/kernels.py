"""Compiled kernels of the Z-map: the exact lower envelope of a tool swept along one segment, and the
per-period update of the height field with it.

A tool is a solid of revolution about a vertical axis, described from its tip upwards by the profile
h(rho), the height of its surface above the tip at radial distance rho (the shank above it is a
cylinder of the full radius, so the lower surface alone decides what is removed):
    h(rho) = 0                                   rho <= core
    h(rho) = corner - sqrt(corner^2 - (rho - core)^2)   core < rho <= core + corner
A flat end mill is (core = R, corner = 0), a ball (0, r), a bull nose (R - rc, rc).

Sweeping the tip from c0 to c1 (t in [0, 1]) removes, above each node q of the grid, everything above
    env(q) = min_t  z(t) + h(|q - xy(t)|),
which is convex in t (h is convex and non-decreasing, |q - xy(t)| is convex in t). Closed forms:
- flat: the t where the disc covers q form one interval; z(t) is linear, so its minimum is an end;
- ball: the swept ball is a capsule around the segment of sphere centres; the lowest capsule point
  on the vertical through q is on its cylinder (the lower root of a quadratic, when the foot of the
  root lies inside the segment) or on one of the end spheres;
- bull: bisection of g'(t) = 0 on the covering interval (convex g; 60 halvings reach machine precision).

The update visits the grid in tiles of TILE x TILE nodes and skips a tile when a lower bound of the
envelope over it is not below the tile's highest node (kept per tile): the bound is the larger of
  B1 = min(z0, z1) + h(d - e)             d: distance of the tile centre to the segment, e: half-diagonal
  B2 = env(centre) - e * h'(rho_max)      every g(t; q) is Lipschitz in q with h'(rho_max), rho_max the
                                          largest distance of a tile point to the segment's ends
so the result is the same as visiting every node.

Tooth-pass marks (teeth > 0): the cutting edges instead of the solid of revolution. Each of the tool's
z flutes is an edge along the profile h(rho) in the half-plane at angle theta(t) + 2 pi k / z about the axis (theta the spindle angle). Within a period the axis moves on its
segment and theta turns by dth, both linearly in t; a node q at azimuth phi(t) about the moving axis is
cut when theta(t) + 2 pi k / z = phi(t) (mod 2 pi), down to z(t) + h(|q - xy(t)|). The crossings are
found on sub-intervals of the period (at least SUBSTEPS, and enough that the node's azimuth turns by at
most MAX_TURN_RAD in each, at most MAX_SUBSTEPS), on the continuous (unwrapped) angle
G(t) = theta(t) - phi(t), by linear interpolation between the sub-interval's ends.
Needs |dth| < pi per period (the rows give the angle at each period's end): below 30,000 rpm at 1 ms.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

TILE = 4
BISECTIONS = 60
SUBSTEPS = 8
MAX_SUBSTEPS = 512
MAX_TURN_RAD = 0.1
TINY_MM2 = 1e-18  # squared horizontal step below which a segment is vertical (below 1 nm)


@njit(cache=True, inline="always")
def profile_mm(rho, core, corner):
    """h(rho); inf outside the tool."""
    if rho <= core:
        return 0.0
    d = rho - core
    if d > corner:
        return np.inf
    return corner - math.sqrt(max(corner * corner - d * d, 0.0))


@njit(cache=True, inline="always")
def profile_slope(rho, core, corner):
    """h'(rho); inf at and beyond the rim."""
    if rho <= core:
        return 0.0
    d = rho - core
    w2 = corner * corner - d * d
    if w2 <= 0.0:
        return np.inf
    return d / math.sqrt(w2)


@njit(cache=True, inline="always")
def cover_interval(qx, qy, x0, y0, bx, by, radius):
    """The interval of t in [0, 1] where |q - (c0 + t b)| <= radius; (1, 0) when empty."""
    px, py = qx - x0, qy - y0
    bb = bx * bx + by * by
    pp = px * px + py * py
    r2 = radius * radius
    if bb <= TINY_MM2:
        if pp <= r2:
            return 0.0, 1.0
        return 1.0, 0.0
    pb = px * bx + py * by
    disc = pb * pb - bb * (pp - r2)
    if disc < 0.0:
        return 1.0, 0.0
    sq = math.sqrt(disc)
    return max((pb - sq) / bb, 0.0), min((pb + sq) / bb, 1.0)


@njit(cache=True)
def env_flat(qx, qy, x0, y0, z0, x1, y1, z1, radius):
    lo, hi = cover_interval(qx, qy, x0, y0, x1 - x0, y1 - y0, radius)
    if lo > hi:
        return np.inf
    dz = z1 - z0
    return z0 + dz * (lo if dz >= 0.0 else hi)


@njit(cache=True)
def env_ball(qx, qy, x0, y0, z0, x1, y1, z1, r):
    best = np.inf
    r2 = r * r
    rho2 = (qx - x0) ** 2 + (qy - y0) ** 2
    if rho2 <= r2:
        best = z0 + r - math.sqrt(r2 - rho2)
    rho2 = (qx - x1) ** 2 + (qy - y1) ** 2
    if rho2 <= r2:
        best = min(best, z1 + r - math.sqrt(r2 - rho2))
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    a = dx * dx + dy * dy
    if a <= TINY_MM2:
        return best
    # |w|^2 - (w.D)^2/|D|^2 = r^2 with w = (q - c0, Z), Z the height above the first sphere centre:
    # a Z^2 + 2 B Z + c = 0, lower root taken without cancellation
    ax, ay = qx - x0, qy - y0
    l2 = a + dz * dz
    k = ax * dx + ay * dy
    b = -k * dz
    c = (ax * ax + ay * ay - r2) * l2 - k * k
    disc = b * b - a * c
    if disc < 0.0:
        return best
    sq = math.sqrt(disc)
    if b > 0.0:
        zl = -(b + sq) / a
    elif sq - b > 0.0:
        zl = c / (sq - b)
    else:
        return best
    t = (k + zl * dz) / l2
    if 0.0 <= t <= 1.0:
        best = min(best, z0 + r + zl)
    return best


@njit(cache=True)
def _g(t, qx, qy, x0, y0, z0, bx, by, dz, core, corner):
    rho = math.hypot(qx - x0 - t * bx, qy - y0 - t * by)
    return z0 + t * dz + profile_mm(min(rho, core + corner), core, corner)


@njit(cache=True)
def _dg(t, qx, qy, x0, y0, bx, by, dz, core, corner):
    px, py = qx - x0 - t * bx, qy - y0 - t * by
    rho = math.hypot(px, py)
    if rho <= core or rho == 0.0:
        return dz
    return dz + profile_slope(min(rho, core + corner), core, corner) * (-(px * bx + py * by) / rho)


@njit(cache=True)
def env_bull(qx, qy, x0, y0, z0, x1, y1, z1, core, corner):
    bx, by, dz = x1 - x0, y1 - y0, z1 - z0
    lo, hi = cover_interval(qx, qy, x0, y0, bx, by, core + corner)
    if lo > hi:
        return np.inf
    if _dg(lo, qx, qy, x0, y0, bx, by, dz, core, corner) >= 0.0:
        return _g(lo, qx, qy, x0, y0, z0, bx, by, dz, core, corner)
    if _dg(hi, qx, qy, x0, y0, bx, by, dz, core, corner) <= 0.0:
        return _g(hi, qx, qy, x0, y0, z0, bx, by, dz, core, corner)
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _dg(mid, qx, qy, x0, y0, bx, by, dz, core, corner) < 0.0:
            lo = mid
        else:
            hi = mid
    return _g(0.5 * (lo + hi), qx, qy, x0, y0, z0, bx, by, dz, core, corner)


@njit(cache=True)
def envelope(qx, qy, x0, y0, z0, x1, y1, z1, core, corner):
    """env(q) of the tool (core, corner) swept from (x0, y0, z0) to (x1, y1, z1); inf off its path."""
    if corner == 0.0:
        return env_flat(qx, qy, x0, y0, z0, x1, y1, z1, core)
    if core == 0.0:
        return env_ball(qx, qy, x0, y0, z0, x1, y1, z1, corner)
    return env_bull(qx, qy, x0, y0, z0, x1, y1, z1, core, corner)


@njit(cache=True)
def _seg_distance(mx, my, x0, y0, x1, y1):
    bx, by = x1 - x0, y1 - y0
    bb = bx * bx + by * by
    t = 0.0 if bb <= TINY_MM2 else min(max(((mx - x0) * bx + (my - y0) * by) / bb, 0.0), 1.0)
    ex, ey = mx - x0 - t * bx, my - y0 - t * by
    return math.sqrt(ex * ex + ey * ey)


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
    rho_min = max(_seg_distance(qx, qy, x0, y0, x1, y1), 1e-9)
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
def sweep(z, line, tile_max, origin_x, origin_y, grid_mm, floor_mm, pos, lines, core, corner, stamp_first, counts,
          spindle_rad, teeth):
    """Lower z (ny, nx) along the segments pos[k] -> pos[k+1] (work mm); line[j, i] takes the source
    line of the segment that last lowered node (i, j). teeth = 0: the solid of revolution; teeth = z:
    z cutting edges at the spindle angles spindle_rad[k] (machine/workpiece/teeth.py; the solid's
    envelope is below the edges', so the tile bounds hold for both). Segments of zero length are skipped, but for the
    first one when stamp_first (the tool standing at its start). counts (updated): tiles looked at,
    tiles whose nodes were evaluated, nodes evaluated."""
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
        y_lo, y_hi = min(y0, y1), max(y0, y1)
        for ty in range(j0 // TILE, j1 // TILE + 1):
            my = origin_y + (ty * TILE + 0.5 * (TILE - 1)) * grid_mm
            # tiles of this row within reach of the segment: x within the reach's half-width of its x span
            dy = max(y_lo - my, my - y_hi, 0.0)
            if dy > reach:
                continue
            half = math.sqrt(reach * reach - dy * dy)
            tx0 = max(int(math.floor((min(x0, x1) - half - origin_x) / grid_mm - 0.5 * (TILE - 1))) // TILE, i0 // TILE)
            tx1 = min(int(math.ceil((max(x0, x1) + half - origin_x) / grid_mm - 0.5 * (TILE - 1))) // TILE + 1,
                      i1 // TILE)
            for tx in range(tx0, tx1 + 1):
                counts[0] += 1
                mx = origin_x + (tx * TILE + 0.5 * (TILE - 1)) * grid_mm
                d = _seg_distance(mx, my, x0, y0, x1, y1)
                if d > reach:
                    continue
                top = tile_max[ty, tx]
                if z_low + profile_mm(max(d - half_diag, 0.0), core, corner) >= top:
                    continue
                if corner > 0.0:
                    rho_max = math.sqrt(max((mx - x0) ** 2 + (my - y0) ** 2, (mx - x1) ** 2 + (my - y1) ** 2)) \
                        + half_diag
                    if rho_max < radius:
                        bound = envelope(mx, my, x0, y0, z0, x1, y1, z1, core, corner) \
                            - half_diag * profile_slope(rho_max, core, corner)
                        if bound >= top:
                            continue
                counts[1] += 1
                new_top = -np.inf
                for j in range(ty * TILE, min(ty * TILE + TILE, ny)):
                    qy = origin_y + j * grid_mm
                    for i in range(tx * TILE, min(tx * TILE + TILE, nx)):
                        qx = origin_x + i * grid_mm
                        if teeth == 0:
                            v = envelope(qx, qy, x0, y0, z0, x1, y1, z1, core, corner)
                        else:
                            v = tooth_envelope(qx, qy, x0, y0, z0, x1, y1, z1, core, corner, spindle_rad[k],
                                               wrap_pi(spindle_rad[k + 1] - spindle_rad[k]), teeth)
                        v = max(v, floor_mm)
                        counts[2] += 1
                        if v < z[j, i]:
                            z[j, i] = v
                            line[j, i] = lines[k]
                        new_top = max(new_top, z[j, i])
                tile_max[ty, tx] = new_top
