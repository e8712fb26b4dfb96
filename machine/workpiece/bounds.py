"""Lower bounds of a run's envelope (numba): what lets the Z-map skip the segments that cannot cut.

A run (machine/workpiece/chains.py) is segments whose ends lie within its deviation of one straight line
A -> B: a segment between two of its points lies, point for point, within that deviation of the line's
piece between the points' projections (distance to a line is convex). So a segment's envelope is at
least that of a dilated tool on the line: a ball of radius r + e3, e3 lower (e3 the 3D deviation: the
dilation of a ball by a ball); a flat or bull with its core wider by the horizontal deviation, lowered
by the vertical one (exactly 0 on a level cut, so that level passes tie exactly). Along the line the
bound G(s) = z(s) - drop + h(|q - xy(s)|) is convex in the line's parameter s, and its minimum G* over
the line bounds every segment of the run.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from machine.workpiece.chains import deviation
from machine.workpiece.envelope import TINY_MM2, ball_slanted, envelope, profile_mm, profile_slope

# columns of the run table
AX, AY, AZ, BX, BY, BZ, INV_LL, CORE, CORNER, DROP = range(10)
COLUMNS = 10
# A bound is trusted to be below what it bounds only to this: far above its rounding (heights below 1000 mm:
# 1e-13 mm), far below any height that matters. A bound above a node's best by less may still tie it.
ROUNDING_MM = 1e-9


@njit(cache=True, inline="always")
def run_row(runs, c):
    """Run c's row of the run table as a tuple, for the bounds' hot loops: numba counts the references
    to an array view with two atomic operations a call, which took 30 % of finish_g01's removal."""
    return (runs[c, 0], runs[c, 1], runs[c, 2], runs[c, 3], runs[c, 4], runs[c, 5], runs[c, 6], runs[c, 7],
            runs[c, 8], runs[c, 9])


@njit(cache=True)
def run_table(pos, starts, core, corner):
    """Per run: its line's ends, 1 / |B - A|^2 (0 for a run standing still) and its bound tool."""
    table = np.zeros((starts.shape[0] - 1, COLUMNS))
    for c in range(starts.shape[0] - 1):
        a, b = starts[c], starts[c + 1]
        run = table[c]
        run[AX], run[AY], run[AZ] = pos[a, 0], pos[a, 1], pos[a, 2]
        run[BX], run[BY], run[BZ] = pos[b, 0], pos[b, 1], pos[b, 2]
        ll = (pos[b, 0] - pos[a, 0]) ** 2 + (pos[b, 1] - pos[a, 1]) ** 2 + (pos[b, 2] - pos[a, 2]) ** 2
        run[INV_LL] = 1.0 / ll if ll > 0.0 else 0.0
        e3, exy, ez = deviation(pos, a, b)
        if core == 0.0:
            run[CORE], run[CORNER], run[DROP] = 0.0, corner + e3, e3
        else:
            run[CORE], run[CORNER], run[DROP] = core + exy, corner, ez
    return table


@njit(cache=True, inline="always")
def proj(pos, k, run):
    """The line parameter s of point k's projection."""
    return ((pos[k, 0] - run[AX]) * (run[BX] - run[AX]) + (pos[k, 1] - run[AY]) * (run[BY] - run[AY])
            + (pos[k, 2] - run[AZ]) * (run[BZ] - run[AZ])) * run[INV_LL]


@njit(cache=True, inline="always")
def bound_line(qx, qy, s, run, floor_mm):
    """G(s) at node q."""
    x, y = run[AX] + s * (run[BX] - run[AX]), run[AY] + s * (run[BY] - run[AY])
    z = run[AZ] + s * (run[BZ] - run[AZ])
    return max(z - run[DROP] + profile_mm(math.sqrt((qx - x) ** 2 + (qy - y) ** 2), run[CORE], run[CORNER]), floor_mm)


@njit(cache=True)
def bound_node(qx, qy, run, floor_mm):
    """(G*, s*) at node q: G's minimum over the line and where it is reached."""
    g, s = envelope(qx, qy, run[AX], run[AY], run[AZ], run[BX], run[BY], run[BZ], run[CORE], run[CORNER])
    return max(g - run[DROP], floor_mm), s


@njit(cache=True)
def bound_plane(qx, qy, run):
    """(G*(q), dG*/dx, dG*/dy, ok): G* is convex in q (the envelope of a convex tool along a line: the
    minimum over s of a function convex in (s, q) jointly), so its tangent plane at q lies below it
    everywhere. The slope is h'(rho*) towards q from the line point where G* is reached (Danskin's
    theorem; at an end of the line the same plane still supports G*, since G does not fall into the
    line there). ok is False where there is no plane: q beyond the tool's reach, or at its rim, or a flat end
    on a line that is not level: its profile jumps at the rim, so the line's part under the disc depends on q
    and G* falls towards where the disc reaches lower (no slope of the profile at the lowest point says so)."""
    core, corner = run[CORE], run[CORNER]
    if corner == 0.0 and run[AZ] != run[BZ]:
        return np.inf, 0.0, 0.0, False
    g, s = envelope(qx, qy, run[AX], run[AY], run[AZ], run[BX], run[BY], run[BZ], core, corner)
    px, py = qx - run[AX] - s * (run[BX] - run[AX]), qy - run[AY] - s * (run[BY] - run[AY])
    rho = math.sqrt(px * px + py * py)
    slope = profile_slope(rho, core, corner)
    if not (g < np.inf and slope < np.inf):
        return g, 0.0, 0.0, False
    if rho <= core or rho == 0.0:
        return g - run[DROP], 0.0, 0.0, True
    return g - run[DROP], slope * px / rho, slope * py / rho, True


@njit(cache=True, error_model="numpy")
def ball_planes(qx, qy, runs, listed, chosen, n, columns, out):
    """bound_plane at q for the ball runs listed[chosen[0 .. n-1]], into out's columns (G*, dG*/dx, dG*/dy,
    state: 1 a plane, 0 none, 2 a vertical line, for bound_plane itself): its arithmetic with selects in
    place of branches (envelope.ball_slanted for env_ball), so that the loop runs on the CPU's vector units
    and gives the same bits (numpy's error model: a division by zero only reaches a discarded select).
    The runs' rows are first gathered into columns (scratch, 8 x n): a loop that gathers does not vectorize."""
    ax, ay, az, bx, by, bz, rs, drop = columns[0], columns[1], columns[2], columns[3], columns[4], columns[5], \
        columns[6], columns[7]
    for p in range(n):
        c = listed[chosen[p]]
        ax[p], ay[p], az[p], bx[p], by[p], bz[p] = runs[c, AX], runs[c, AY], runs[c, AZ], runs[c, BX], runs[c, BY], \
            runs[c, BZ]
        rs[p], drop[p] = runs[c, CORNER], runs[c, DROP]
    g_out, gx_out, gy_out, state = out[0], out[1], out[2], out[3]
    for p in range(n):
        r = rs[p]
        dx, dy = bx[p] - ax[p], by[p] - ay[p]
        g, s = ball_slanted(qx, qy, ax[p], ay[p], az[p], bx[p], by[p], bz[p], r)
        px, py = qx - ax[p] - s * dx, qy - ay[p] - s * dy
        rho = math.sqrt(px * px + py * py)
        w2 = r * r - rho * rho
        slope = rho / math.sqrt(w2 if w2 > 0.0 else 1.0)  # profile_slope(rho, 0, r) where it is finite
        flat = rho == 0.0
        g_out[p] = g - drop[p]
        gx_out[p] = 0.0 if flat else slope * px / rho
        gy_out[p] = 0.0 if flat else slope * py / rho
        state[p] = 2.0 if dx * dx + dy * dy <= TINY_MM2 else 1.0 if g < np.inf and (flat or w2 > 0.0) else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def ball_bounds(qx, qy, m0, m1, run, floor_mm, g_out, s_out, row):
    """(G*, s*) of a ball run at the nodes m0 .. m1-1 of (qx, qy) into row `row` of g_out and s_out:
    envelope.env_ball's closed form (the cylinder's root, clamped to the line's ends) without branches, so that
    the loop runs on the CPU's vector units (numpy's error model: no check of each division for a zero, which
    would keep the loop scalar; no divisor here is zero). Inlined into removal.cut_blocks, which takes the same
    error model: a call cost about 90 ns (on finish_g01.nc 0.35 M calls), most of it the atomic counts of its
    four arrays' references. The nodes are indices into whole arrays, not views of them: each view counted a
    reference to its array with two atomic operations (tiles._keep took eight a kept run); the indices are
    unsigned (numba tests a signed index for a negative one, which keeps a loop scalar)."""
    r = run[CORNER]
    r2 = r * r
    ax, ay, az, bx, by, bz = run[AX], run[AY], run[AZ], run[BX], run[BY], run[BZ]
    dx, dy, dz = bx - ax, by - ay, bz - az
    a = max(dx * dx + dy * dy, 1e-300)  # a vertical line: t is then 0 or 1 by the sign of zl's numerator
    l2 = a + dz * dz
    inv_l2 = 1.0 / l2  # s* steers which segments are evaluated, not their heights: a rounding off is harmless
    top = az + r - run[DROP]
    for m in range(m0, m1):  # one loop: a row of 8 nodes is too short for the vector loop (2.5x slower)
        px, py = qx[m] - ax, qy[m] - ay
        pp = px * px + py * py
        k = px * dx + py * dy
        b = -k * dz
        c = (pp - r2) * l2 - k * k
        disc = b * b - a * c
        sq = math.sqrt(max(disc, 0.0))
        rising = sq - b > 0.0  # one division of the three cases' (selects compute every case's operands)
        zl = (-(b + sq) if b > 0.0 else c if rising else -b) / (a if b > 0.0 else max(sq - b, 1e-300) if rising else a)
        t = min(max((k + zl * dz) * inv_l2, 0.0), 1.0)
        ex, ey = px - t * dx, py - t * dy
        w = r2 - (ex * ex + ey * ey)
        v = top + t * dz - math.sqrt(max(w, 0.0))
        g_out[row, m] = max(v, floor_mm) if disc >= 0.0 and w >= 0.0 else np.inf
        s_out[row, m] = t
