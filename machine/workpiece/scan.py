"""STEP 3's scan (machine/workpiece/tiles.py) in float32: per tile, every run listed for its block gets a
distance bound (a pruning bound: at most the float64 one, min(z_A, z_B) - drop + h(d - e), so it prunes no
run that float64 keeps) and a key (the order of the kept runs and the first group: speed only, never the
heights, the later stages pruning only by certified bounds and the sweeps taking a node lower, or as low by
an earlier segment, in any order). The vector units take 16 float32 lanes where they take 8 float64, and the
square roots at the same cost a lane.

The table (near_table), per block: each run's line truncated to the part that can reach one of the block's
tiles (a point of the line farther along it than L = core + corner + e + E from the block centre's foot is
farther than core + corner + e from every tile centre, E the farthest tile centre's distance from the block
centre: beyond the float64 bound's reach, so the bound is the same), relative to the block centre, and the
heights relative to z_ref (the block's highest node), as its start (x0, y0), its horizontal unit direction
and its length. Every magnitude is then at most S = |x0| + |y0| + length + 2 half + core + corner + e (half: a
tile centre's largest offset from the block centre along an axis), a few mm, whatever the run's length or its
distance from the origin.

The bound's error (u = 2^-24, float32's unit roundoff; each operation's rounding at most u times its result):
- The inputs, rounded to float32, move the tile centre by at most u S and the segment's ends by 2 u S; the
  distance to the segment moves by at most 3 u S (it is 1-Lipschitz in each).
- Computed from them: p = m - A within u |p|; the parameter s along the line is any value in [0, length]
  (a point of the segment: |p - s U| is never below the distance, whatever s's error), within 4 u |p| of the
  nearest (its dot product with U, |U| within u of 1, clamped); e = p - s U within 2 u (|p| + s), its norm
  within 2.5 u: d is within 14 u S of the exact distance on each side, and d - (core + e) within 15 u S.
  The float64 distance's own error (1e-13 mm at 1000 mm) is far below. So d's margin is 32 u S = 2^-19 S, in
  the cut-off (NCUT, rounded to float32 within u S: u = d - NCUT is below the float64 u) and the reach
  (NREACH: finite wherever the float64 bound is).
- h(u) = c - sqrt((c - u)(c + u)) without cancellation in c^2 - u^2 near the rim (c - u exact or within u of
  itself); c rounded up (c_up: h decreasing in c at a given u) and u clamped to c rounded down: the square root
  within 2.6 u c_up of the exact. The float64 h is within 2^-26 c of its exact value (its c^2 - u^2 cancels
  near the rim). Both are covered by 2^-21 c_up taken off NLOWC = low - z_ref + c_up, with 2^-48 (|low| +
  |z_ref| + c_up) for the float64 sums and NLOWC rounded down.
- b = NLOWC - sqrt(...) rounds within u |b|: b - 2^-22 |b| (exact product, rounded difference) is below
  the exact difference, on either sign. The floor, rounded down, raises it to at most the float64 floor.
The thresholds the bound is tested against (top, the heights after the group) are rounded up, one step more.
The key: G* at the tile centre for a ball, G at the line's closest point else, each within a few u S of
its float64 value: the group and the other runs of finish_g01.nc and g1_lhchips4.ngc within 0.01 % of the
float64 scan's, the searches and envelopes too (docs/workpiece-speed.md).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from machine.workpiece.bounds import AX, AY, AZ, BX, BY, BZ, CORE, CORNER, DROP
from machine.workpiece.envelope import TINY_MM2

# rows of a block's table of its runs (near_table, float32), laid out for the scan of each tile
NX0, NY0, NUX, NUY, NLEN, NKAPPA, NZ0, NSLOPE, NCORE, NCORNER, NCUT, NREACH, NCUP, NCDOWN, NLOWC = range(15)
ROWS = 15
DISTANCE_MARGIN = 2.0 ** -19  # of S: d's error, 32 u S (see the docstring)
CORNER_MARGIN = 2.0 ** -21  # of c_up: the square roots' errors, float32's and float64's
SUM_MARGIN = 2.0 ** -48  # of the magnitudes: the float64 sums of NLOWC and of the float64 bound
_UP, _DOWN = 1.0 + 2.0 ** -23, 1.0 - 2.0 ** -23  # (f32_below) x * _UP rounds to a float32 at or above x > 0
_ROUND = np.float32(2.0 ** -22)  # of |b|: b's rounding, 2 u
_ZERO, _INF = np.float32(0.0), np.float32(np.inf)
_I31, _MAGNITUDE = np.int32(31), np.int32(0x7FFFFFFF)


@intrinsic
def _bits(typingctx, x):
    """A float32's bits as an int32."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int32))
    return types.int32(types.float32), codegen


@intrinsic
def _from_bits(typingctx, bits):
    """The float32 of an int32's bits."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float32))
    return types.float32(types.int32), codegen


@njit(cache=True, inline="always")
def _ordered(x):
    """An int32 in the order of the float32s x (not nan), its own inverse: the bits of x >= 0 rise with x,
    those of x < 0 fall as x rises (sign and magnitude), so the magnitude's are flipped. The least of such
    ints is a vector loop's (the CPU's integer minimum); the least of floats is not, the compiler keeping
    the order of the comparisons for a nan."""
    k = _bits(x)
    return k ^ ((k >> _I31) & _MAGNITUDE)


@njit(cache=True, inline="always")
def f32_below(x):
    """A float32 at or below x (x scaled away from 0 by 2^-23, then rounded: the float32 spacing is 2^-23 of
    it at most, so the rounding, half of that, cannot reach back to x)."""
    return np.float32(x * (_UP if x < 0.0 else _DOWN))


@njit(cache=True, inline="always")
def f32_above(x):
    """A float32 strictly above x: the float32 next above x's nearest."""
    return np.nextafter(np.float32(x), _INF)


@njit(cache=True, inline="always")
def _truncated(p, columns, cx, cy, reach_mm):
    """Run p's line (its row gathered into columns) as near_table stores it: (x0, y0) its start relative to
    the block centre (cx, cy), float32; its horizontal direction (0 for a run standing still or vertical: a
    point, as bounds.seg_distance takes it), the height's slope along it, where it starts and its length (mm)
    after truncation to within reach_mm of the block centre's foot."""
    ax, ay = columns[AX, p], columns[AY, p]
    dx, dy, dz = columns[BX, p] - ax, columns[BY, p] - ay, columns[BZ, p] - columns[AZ, p]
    bb = dx * dx + dy * dy
    line = bb > TINY_MM2
    length = math.sqrt(bb)
    inv = 1.0 / length
    ux, uy, slope = dx * inv if line else 0.0, dy * inv if line else 0.0, dz * inv if line else 0.0
    length = length if line else 0.0
    s_c = (cx - ax) * ux + (cy - ay) * uy
    s_lo = min(max(s_c - reach_mm, 0.0), length)
    s_hi = max(min(s_c + reach_mm, length), s_lo)
    return np.float32(ax + s_lo * ux - cx), np.float32(ay + s_lo * uy - cy), ux, uy, slope, s_lo, s_hi - s_lo


@njit(cache=True, error_model="numpy")
def near_table(listed, runs, frame, half_mm, e_tile, columns, near):
    """The listed runs' lines (truncated, relative to the block's frame = (centre x, y, z_ref)) and bound
    tools into near's first columns, float32 (STEP 3's scan reads them in order); half_mm: a tile centre's
    largest offset from the block centre along an axis; e_tile: a tile's half-diagonal. The runs' rows are
    first gathered into columns (scratch, COLUMNS x n): a loop that gathers does not vectorize; then two
    loops that do (numpy's error model: a division by zero only reaches a discarded select; one loop
    storing all ROWS rows does not: the compiler would check too many pairs of them for overlaps)."""
    count = listed.shape[0]
    for p in range(count):
        c = listed[p]
        columns[AX, p], columns[AY, p], columns[AZ, p] = runs[c, AX], runs[c, AY], runs[c, AZ]
        columns[BX, p], columns[BY, p], columns[BZ, p] = runs[c, BX], runs[c, BY], runs[c, BZ]
        columns[CORE, p], columns[CORNER, p], columns[DROP, p] = runs[c, CORE], runs[c, CORNER], runs[c, DROP]
    cx, cy, z_ref = frame[0], frame[1], frame[2]
    for p in range(count):
        core, corner = columns[CORE, p], columns[CORNER, p]
        # the part within L of the block centre's foot, a little more (the docstring)
        x0, y0, ux, uy, slope, s_lo, length = _truncated(
            p, columns, cx, cy, 1.01 * (core + corner + e_tile + half_mm * math.sqrt(2.0)))
        near[NX0, p], near[NY0, p], near[NUX, p], near[NUY, p], near[NLEN, p] = x0, y0, ux, uy, length
        near[NZ0, p], near[NSLOPE, p] = columns[AZ, p] + s_lo * slope - columns[DROP, p] - z_ref, slope
        # a ball's lowest point over q lies kappa R along the line from q's foot, R the ball's half-chord
        # there: the capsule's cylinder, what envelope.ball_slanted solves
        near[NKAPPA, p] = -slope / math.sqrt(1.0 + slope * slope) if core == 0.0 else 0.0
    for p in range(count):
        core, corner = columns[CORE, p], columns[CORNER, p]
        s = abs(near[NX0, p]) + abs(near[NY0, p]) + near[NLEN, p] + 2.0 * half_mm + core + corner + e_tile
        near[NCORE, p], near[NCORNER, p] = core, corner
        near[NCUT, p] = core + e_tile + DISTANCE_MARGIN * s
        near[NREACH, p] = core + corner + e_tile + DISTANCE_MARGIN * s
        c_up = np.float32(corner * _UP)
        near[NCUP, p], near[NCDOWN, p] = c_up, corner * _DOWN
        low = min(columns[AZ, p], columns[BZ, p]) - columns[DROP, p]
        v = low - z_ref + c_up - CORNER_MARGIN * c_up - SUM_MARGIN * (abs(low) + abs(z_ref) + c_up)
        near[NLOWC, p] = f32_below(v)
    return near


@njit(cache=True, inline="always")
def candidates(mx, my, top, floor_mm, listed, frame, near, scratch):
    """STEP 3 for the tile centred at (mx, my) (float64, work mm): every listed run's distance bound and key
    into scratch (float32, heights relative to frame's z_ref); returns (the lowest key of the runs whose bound
    is below top, inf where there is none, top as the float32 threshold). Loops without branches, for the
    vector units. A ball's key is G* at the centre, not G where the line passes closest (a flat's or a
    bull's key, and a ball's beyond its line's cylinder): on a sloped line the lowest point is off the
    closest, and the group by G* holds more of the final runs (finish_g01.nc: envelopes -8 %)."""
    mx32, my32 = np.float32(mx - frame[0]), np.float32(my - frame[1])
    top32, floor32 = threshold(top, frame), f32_below(floor_mm - frame[2])
    key_min = _ordered(_INF)
    for p in range(listed.shape[0]):
        px, py = mx32 - near[NX0, p], my32 - near[NY0, p]
        ux, uy, length = near[NUX, p], near[NUY, p], near[NLEN, p]
        s_line = px * ux + py * uy
        s = min(max(s_line, _ZERO), length)
        ex, ey = px - s * ux, py - s * uy
        d = math.sqrt(ex * ex + ey * ey)
        c_up = near[NCUP, p]
        u = min(max(d - near[NCUT, p], _ZERO), near[NCDOWN, p])  # the tile's nearest point, clamped into the tool
        b = near[NLOWC, p] - math.sqrt((c_up - u) * (c_up + u))
        b -= abs(b) * _ROUND
        bound = max(b, floor32) if d <= near[NREACH, p] else _INF
        scratch[0, p] = bound
        core, corner = near[NCORE, p], near[NCORNER, p]
        fx, fy = px - s_line * ux, py - s_line * uy
        s = min(max(s_line + math.sqrt(max(corner * corner - (fx * fx + fy * fy), _ZERO)) * near[NKAPPA, p], _ZERO),
                length)
        gx, gy = px - s * ux, py - s * uy
        w = min(max(d - core, _ZERO), corner)  # a flat's or a bull's: at the closest point, s the same
        w2 = min(gx * gx + gy * gy, corner * corner) if core == _ZERO else w * w
        key = near[NZ0, p] + s * near[NSLOPE, p] + corner - math.sqrt(corner * corner - w2)
        scratch[1, p] = key
        key_min = min(key_min, _ordered(key) if bound < top32 else _ordered(_INF))
    return _from_bits(_ordered(_from_bits(key_min))), top32  # _ordered is its own inverse


@njit(cache=True, inline="always")
def threshold(height, frame):
    """A height (float64, work mm) as the float32 the scan's bounds are tested against: above it, relative to
    frame's z_ref (a bound below the height stays below it)."""
    return f32_above(height - frame[2])


@intrinsic
def _lowest_bit(typingctx, word):
    """The place of a nonzero int64's lowest set bit (the CPU's count of trailing zeros)."""
    def codegen(context, builder, signature, args):
        return builder.cttz(args[0], context.get_constant(types.boolean, False))
    return types.int64(types.int64), codegen


@njit(cache=True, inline="always")
def select(count, scratch, top32, top_now32, key0, group, chosen):
    """The candidates (bound below top32) of the group (key at most key0) or else the others whose bound is
    not above top_now32 (thresholds); their places in the block's list into chosen, in order; their number.
    64 places at a time: their tests into the bits of a word (a loop without branches, for the vector
    units), then the word's set bits, lowest first: a few of the 64 are taken."""
    n = 0
    for w0 in range(0, count, 64):
        word = 0
        for i in range(min(64, count - w0)):
            bound, key = scratch[0, w0 + i], scratch[1, w0 + i]
            take = (bound < top32) & ((key <= key0) if group else ((key > key0) & (bound <= top_now32)))
            word |= np.int64(take) << i
        while word != 0:
            chosen[n] = w0 + _lowest_bit(word)
            n += 1
            word &= word - 1
    return n
