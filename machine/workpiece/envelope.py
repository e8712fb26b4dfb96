"""The exact lower envelope of a tool swept along one straight segment (numba).

A tool is a solid of revolution about a vertical axis, described from its tip upwards by the profile
h(rho), the height of its surface above the tip at radial distance rho (the shank above it is a
cylinder of the full radius, so the lower surface alone decides what is removed):
    h(rho) = 0                                          rho <= core
    h(rho) = corner - sqrt(corner^2 - (rho - core)^2)   core < rho <= core + corner
A flat end mill is (core = R, corner = 0), a ball (0, r), a bull nose (R - rc, rc).

Sweeping the tip from c0 to c1 (t in [0, 1]) removes, above a node q, everything above
    env(q) = min_t  g(t),   g(t) = z(t) + h(|q - xy(t)|),
which is convex in t (h is convex and non-decreasing, |q - xy(t)| is convex in t). `envelope` returns
the minimum and a t where it is reached, in closed form for a flat end (the t where the disc covers q
form one interval; z is linear, so an end) and a ball (the swept ball is a capsule around the segment of
sphere centres: its lowest point on the vertical through q is on the capsule's cylinder, the lower root
of a quadratic, or on an end sphere), and by bisection of g'(t) = 0 for a bull nose.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

BISECTIONS = 32  # halvings of the covering interval: t to 2e-10 of it, where g is flat to far below 1 nm
TINY_MM2 = 1e-18  # squared horizontal step below which a segment is vertical (below 1 nm)


@njit(cache=True, inline="always")
def profile_mm(rho, core, corner):
    """h(rho); inf outside the tool. Selects, not branches: a loop of it over nodes runs on the CPU's
    vector units (search._unfinished)."""
    d = rho - core
    h = corner - math.sqrt(max(corner * corner - d * d, 0.0))
    return 0.0 if rho <= core else np.inf if d > corner else h


@njit(cache=True)
def profile_slope(rho, core, corner):
    """h'(rho); inf at and beyond the rim."""
    if rho <= core:
        return 0.0
    d = rho - core
    w2 = corner * corner - d * d
    if w2 <= 0.0:
        return np.inf
    return d / math.sqrt(w2)


@njit(cache=True)
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
        return np.inf, 0.0
    dz = z1 - z0
    t = lo if dz >= 0.0 else hi
    return z0 + dz * t, t


@njit(cache=True)
def _sphere(qx, qy, x, y, z, r):
    rho2 = (qx - x) ** 2 + (qy - y) ** 2
    return z + r - math.sqrt(r * r - rho2) if rho2 <= r * r else np.inf


@njit(cache=True, inline="always")
def ball_slanted(qx, qy, x0, y0, z0, x1, y1, z1, r):
    """env_ball for a segment that is not vertical, with selects in place of branches, so that a loop of it
    over nodes runs on the CPU's vector units (tiles.sweep_ball); the same arithmetic as branches would do.
    The lowest point of the infinite cylinder of radius r about the line of sphere centres, on the
    vertical through q: |w|^2 - (w.D)^2/|D|^2 = r^2 with w = (q - c0, Z), Z the height above the first
    centre, a Z^2 + 2 b Z + c = 0, the lower root taken without cancellation. Its foot t on the line
    minimises g over all t (no ball on the line goes lower there), so g, convex, is least on [0, 1] at t
    clamped into it: the cylinder inside, else the nearer end sphere."""
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    a = dx * dx + dy * dy
    ax, ay = qx - x0, qy - y0
    l2 = a + dz * dz
    k = ax * dx + ay * dy
    b = -k * dz
    c = (ax * ax + ay * ay - r * r) * l2 - k * k
    disc = b * b - a * c
    sq = math.sqrt(max(disc, 0.0))
    rising = sq - b > 0.0
    # b > 0: -(b + sq) / a; else c / (sq - b); b = sq = 0 (q on the cylinder's rim line): the double root -b / a
    zl = (-(b + sq) if b > 0.0 else c if rising else -b) / (a if b > 0.0 else sq - b if rising else a)
    # the foot t = foot / l2 is off the segment where foot < 0 or foot > l2: the same tests as t < 0, t > 1 (the
    # division rounds correctly, l2 > 0), so a caller that needs only the height divides once, not twice
    foot = k + zl * dz
    ex, ey, ez = (x0, y0, z0) if foot < 0.0 else (x1, y1, z1)
    rho2 = (qx - ex) ** 2 + (qy - ey) ** 2
    end = ez + r - math.sqrt(max(r * r - rho2, 0.0)) if rho2 <= r * r else np.inf
    v = end if foot < 0.0 or foot > l2 else z0 + r + zl
    return (v, min(max(foot / l2, 0.0), 1.0)) if disc >= 0.0 else (np.inf, 0.0)


@njit(cache=True)
def env_ball(qx, qy, x0, y0, z0, x1, y1, z1, r):
    dx, dy = x1 - x0, y1 - y0
    if dx * dx + dy * dy <= TINY_MM2:
        v0, v1 = _sphere(qx, qy, x0, y0, z0, r), _sphere(qx, qy, x1, y1, z1, r)
        return (v0, 0.0) if v0 <= v1 else (v1, 1.0)
    return ball_slanted(qx, qy, x0, y0, z0, x1, y1, z1, r)


@njit(cache=True)
def _g(t, qx, qy, x0, y0, z0, bx, by, dz, core, corner):
    rho = math.sqrt((qx - x0 - t * bx) ** 2 + (qy - y0 - t * by) ** 2)
    return z0 + t * dz + profile_mm(min(rho, core + corner), core, corner)


@njit(cache=True)
def _dg(t, qx, qy, x0, y0, bx, by, dz, core, corner):
    px, py = qx - x0 - t * bx, qy - y0 - t * by
    rho = math.sqrt(px * px + py * py)
    if rho <= core or rho == 0.0:
        return dz
    return dz + profile_slope(min(rho, core + corner), core, corner) * (-(px * bx + py * by) / rho)


@njit(cache=True)
def env_bull(qx, qy, x0, y0, z0, x1, y1, z1, core, corner):
    bx, by, dz = x1 - x0, y1 - y0, z1 - z0
    lo, hi = cover_interval(qx, qy, x0, y0, bx, by, core + corner)
    if lo > hi:
        return np.inf, 0.0
    if _dg(lo, qx, qy, x0, y0, bx, by, dz, core, corner) >= 0.0:
        return _g(lo, qx, qy, x0, y0, z0, bx, by, dz, core, corner), lo
    if _dg(hi, qx, qy, x0, y0, bx, by, dz, core, corner) <= 0.0:
        return _g(hi, qx, qy, x0, y0, z0, bx, by, dz, core, corner), hi
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _dg(mid, qx, qy, x0, y0, bx, by, dz, core, corner) < 0.0:
            lo = mid
        else:
            hi = mid
    t = 0.5 * (lo + hi)
    return _g(t, qx, qy, x0, y0, z0, bx, by, dz, core, corner), t


@njit(cache=True)
def envelope(qx, qy, x0, y0, z0, x1, y1, z1, core, corner):
    """(env(q), t) of the tool (core, corner) swept from (x0, y0, z0) to (x1, y1, z1); inf off its path."""
    if corner == 0.0:
        return env_flat(qx, qy, x0, y0, z0, x1, y1, z1, core)
    if core == 0.0:
        return env_ball(qx, qy, x0, y0, z0, x1, y1, z1, corner)
    return env_bull(qx, qy, x0, y0, z0, x1, y1, z1, core, corner)


@njit(cache=True)
def seg_distance(mx, my, x0, y0, x1, y1):
    """(Horizontal distance of (mx, my) to the segment's shadow, the segment's parameter t there)."""
    bx, by = x1 - x0, y1 - y0
    bb = bx * bx + by * by
    t = 0.0 if bb <= TINY_MM2 else min(max(((mx - x0) * bx + (my - y0) * by) / bb, 0.0), 1.0)
    ex, ey = mx - x0 - t * bx, my - y0 - t * by
    return math.sqrt(ex * ex + ey * ey), t
