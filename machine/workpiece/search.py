"""STEP 4's exact envelopes (machine/workpiece/tiles.py): a run's segments at the nodes of a tile, per node
(search) or at every node at once (sweep_ball), numba.

Both give each node the lowest exact envelope over every segment of the run and its height before
(a segment takes a node that is lower, or as low by an earlier segment: ties between level passes are
exact), evaluating only the segments near where the run's bound G (bounds.py) is least: G is convex along
the run's line and below every segment's envelope, so a segment whose projection lies beyond a point
where G does not reach the node's best cannot lower it.

search     At one node: the segment whose projection holds G's minimum s*, then its neighbours outwards
           while G at their near end is below the node's best.
sweep_ball At every node of a tile the run may lower (the rows from the first such node to the last),
           for a ball: the segments from the one before the lowest s* of those nodes to the one after the
           highest, each at all those nodes in one loop without branches (envelope.ball_slanted: the CPU's
           vector units take four nodes at a time), then a search at each node where G beyond those
           segments still reaches the node's best, passing over the segments swept. On finish_g01.nc (one batch, one thread, cycle counters)
           a search took about 700 cycles (its branches and square roots in a chain), a node of a swept
           segment about 25 (5 ns in a loop of its own): the group's 3.3 M searches became 0.53 M segments
           swept at 64 nodes and 0.14 M searches; sweeping every kept run, only at the rows it may lower,
           leaves 0.18 M searches of the 1.35 M, the envelopes evaluated 60 M instead of 61 M.
"""
from __future__ import annotations

import numpy as np
from numba import carray, njit, types
from numba.extending import intrinsic, overload

from machine.workpiece.bounds import INV_LL, ROUNDING_MM, bound_line, proj
from machine.workpiece.envelope import TINY_MM2, ball_slanted, envelope

# The most segments a sweep evaluates at every node of a tile; a run slower than that across the tile
# (short periods: a plunge, a slow approach) is searched per node instead.
SWEEP_SEGMENTS = 16
# Segments swept beyond those holding the lowest and the highest s*: a node whose s* lies in the first or last
# of them often needs the next (G rises by only (83 um)^2 / 2r = 1.1 um over a period of 83 um at 5 m/min);
# on finish_g01.nc 2 instead of 1 took the searches from 1.35 M to 1.28 M but the envelopes from 61 M to 68 M.
SWEEP_MARGIN = 1
# A sweep takes its nodes in whole groups of this many (the doubles in one of the CPU's 512-bit vectors), so that
# the loops over them leave no remainder to a scalar loop after the vector one: on finish_g01.nc a scalar node
# cost about as much as a vector of 8, and sweeps from the first node the run may lower to the last left 3.5
# nodes to it on average (a tile's row is 8 nodes: the groups are whole rows)
VECTOR_NODES = 8


@intrinsic
def _data_at(typingctx, arr, offset):
    """The address of element `offset` (in elements, the array read in order) of a C-contiguous array's data."""
    if not (isinstance(arr, types.Array) and arr.layout == "C" and isinstance(offset, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        return builder.gep(data, [args[1]])
    return types.CPointer(arr.dtype)(arr, offset), codegen


@njit(cache=True, inline="always")
def borrowed(arr):
    """arr's data as an array with no reference to count: numba counts a reference to every array a call is
    handed or a view is made of with two atomic operations; an array made from a pointer (numba.carray) has
    none. Its caller keeps arr alive while it is used."""
    return carray(_data_at(arr, 0), arr.shape)


def lent(value):
    """value with every array in it borrowed (an array, or a tuple or named tuple such as tiles.Workspace of them;
    anything else as it is), for a call that is handed many: it then counts no reference to them. Not inlined
    (overload's inline="always" made cut_blocks crash on finish_g01.nc)."""


@overload(lent)
def _lent(value):
    if isinstance(value, types.Array):
        return lambda value: borrowed(value)
    if not isinstance(value, types.BaseTuple):
        return lambda value: value
    fields = "".join(f"lent(value[{i}]), " for i in range(len(value)))
    made = f"kind({fields})" if isinstance(value, types.BaseNamedTuple) else f"({fields})"
    scope = {"kind": getattr(value, "instance_class", None), "lent": lent}
    exec(f"def impl(value):\n    return {made}", scope)
    return scope["impl"]


@njit(cache=True, inline="always")
def wins(v, k, best, idx):
    """Segment k reaching v replaces (best, idx): lower, or as low and earlier (idx < 0: before the batch)."""
    return v < best or (v == best and idx >= 0 and k < idx)


@njit(cache=True, inline="always")
def may_win(g, best):
    """A segment whose envelope is at least g (a bound: G or G*) may still take a node of height best, lower
    or tied: g is not above best by ROUNDING_MM, whatever rounding put g one step above the envelope it
    bounds (a tie decides the node's line: the first segment in program order reaching the height)."""
    return g - ROUNDING_MM < best


@njit(cache=True, inline="always")
def try_segment(qx, qy, k, best, idx, pos, tool, stamp):
    """The exact envelope of segment k (a zero-length one only as the stream's very first); tool: (core,
    corner, floor_mm)."""
    x0, y0, z0, x1, y1, z1 = pos[k, 0], pos[k, 1], pos[k, 2], pos[k + 1, 0], pos[k + 1, 1], pos[k + 1, 2]
    if x0 == x1 and y0 == y1 and z0 == z1 and not (stamp and k == 0):
        return best, idx
    v = max(envelope(qx, qy, x0, y0, z0, x1, y1, z1, tool[0], tool[1])[0], tool[2])
    if wins(v, k, best, idx):
        return v, k
    return best, idx


@njit(cache=True, inline="always")
def segment_at(s, a, b, run, pos):
    """The last segment of a .. b-1 whose start projects at or before s (projections advance along a run)."""
    lo, hi = a, b - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if proj(pos, mid, run) <= s:
            lo = mid
        else:
            hi = mid - 1
    return lo


@njit(cache=True, inline="always")
def search(q, s_star, best, idx, a, b, run, pos, tool, stamp, done):
    """(best, idx, envelopes evaluated) at node q = (x, y) over the segments a .. b-1 of a run (STEP 4);
    tool: (core, corner, floor_mm); done: the segments (first, last) already evaluated at q (none where
    first > last), passed over (the result is the lowest envelope, ties to the earliest segment, in any order
    of evaluation; G's test at a segment's near end only ends a side early, G rising away from s*)."""
    qx, qy = q
    floor_mm = tool[2]
    d_lo, d_hi = done
    if run[INV_LL] == 0.0:  # standing still: only the stream's first stamp
        best, idx = try_segment(qx, qy, a, best, idx, pos, tool, stamp)
        return best, idx, 1
    lo = segment_at(s_star, a, b, run, pos)
    n = 0
    if not d_lo <= lo <= d_hi:
        best, idx = try_segment(qx, qy, lo, best, idx, pos, tool, stamp)
        n = 1
    k = lo + 1
    while k < b:
        if d_lo <= k <= d_hi:
            k = d_hi + 1
            continue
        n += 1
        if not may_win(bound_line(qx, qy, proj(pos, k, run), run, floor_mm), best):
            break
        best, idx = try_segment(qx, qy, k, best, idx, pos, tool, stamp)
        k += 1
    k = lo - 1
    while k >= a:
        if d_lo <= k <= d_hi:
            k = d_lo - 1
            continue
        n += 1
        if not may_win(bound_line(qx, qy, proj(pos, k + 1, run), run, floor_mm), best):
            break
        best, idx = try_segment(qx, qy, k, best, idx, pos, tool, stamp)
        k -= 1
    return best, idx, n


@njit(cache=True, inline="always")
def _sweep_segment(k, pos, r, floor_mm, qx, qy, best, idx):
    """Segment k (not vertical) of a ball of radius r at every node: a loop without branches (inlined, with
    sweep_ball, into tiles._sweep_runs, whose numpy error model it takes: python's would check each division
    for a zero, and the loop would not vectorize; none is zero here, the segment not being vertical).
    Inlined, not called: a call counts a reference to each array it is handed with two atomic operations."""
    x0, y0, z0, x1, y1, z1 = pos[k, 0], pos[k, 1], pos[k, 2], pos[k + 1, 0], pos[k + 1, 1], pos[k + 1, 2]
    for m in range(best.shape[0]):
        v = max(ball_slanted(qx[m], qy[m], x0, y0, z0, x1, y1, z1, r)[0], floor_mm)
        was, by = best[m], idx[m]
        win = (v < was) | ((v == was) & (by >= 0) & (k < by))
        best[m] = v if win else was
        idx[m] = k if win else by


@njit(cache=True, inline="always")
def _unfinished(g_star, s_star, a, b, k_lo, k_hi, run, pos, floor_mm, qx, qy, best, need):
    """need[m]: node m still needs a search after the sweep of the segments k_lo .. k_hi (none when k_hi <
    k_lo): the run may lower it (its G* wins) and s* lies beyond the swept segments' projections or G at
    their ends still wins (G convex: no lower beyond its ends than there, if s* lies between them). A
    loop without branches (wins' operators, bound_line's selects), for the vector units."""
    swept = k_hi >= k_lo
    s_left, s_right = proj(pos, k_lo, run), proj(pos, k_hi + 1, run)
    first, last = k_lo == a, k_hi == b - 1
    for m in range(best.shape[0]):
        was = best[m]
        g_left = bound_line(qx[m], qy[m], s_left, run, floor_mm)
        g_right = bound_line(qx[m], qy[m], s_right, run, floor_mm)
        left = first | ((s_star[m] >= s_left) & (not may_win(g_left, was)))
        right = last | ((s_star[m] <= s_right) & (not may_win(g_right, was)))
        need[m] = may_win(g_star[m], was) & (not (swept & left & right))


@njit(cache=True, error_model="numpy", inline="always")
def sweep_ball(g_star, s_star, a, b, run, pos, tool, stamp, qx, qy, best, idx, need, counts):
    """The run's segments a .. b-1 at the nodes (qx, qy) of a tile (best, idx updated), for a ball; g_star and
    s_star: its bound's minimum and where it is reached at each node (bounds.ball_bounds); tool: (core,
    corner, floor_mm); need: scratch (a flag per node). counts: searches, envelopes evaluated (tiles.COUNTS' 1
    and 2). Inlined into tiles._sweep_runs, which takes numpy's error model for _sweep_segment's divisions;
    its arrays are borrowed (tiles.cut_tile), so that its views of them count no references (finish_g01.nc,
    one batch, one thread: 0.325 -> 0.305 s)."""
    floor_mm = tool[2]
    s_lo, s_hi = np.inf, -np.inf
    m0, m1 = best.shape[0], 0
    for m in range(best.shape[0]):  # without branches: which nodes the run may lower is data, not a pattern
        win = may_win(g_star[m], best[m])
        s_lo, s_hi = min(s_lo, s_star[m] if win else np.inf), max(s_hi, s_star[m] if win else -np.inf)
        m0, m1 = min(m0, m if win else m0), max(m1, m + 1 if win else m1)
    if m0 >= m1:
        return
    # only the nodes m0 .. m1-1 (the rows the run may lower, the tile's nodes being row after row), as
    # arrays of their own: loops from 0 over them run on the vector units, loops from m0 do not
    m0, m1 = m0 // VECTOR_NODES * VECTOR_NODES, -(-m1 // VECTOR_NODES) * VECTOR_NODES
    g_star, s_star, qx, qy, best, idx, need = (g_star[m0:m1], s_star[m0:m1], qx[m0:m1], qy[m0:m1], best[m0:m1],
                                               idx[m0:m1], need[m0:m1])
    k_lo, k_hi = a, a - 1  # the segments swept: none where the run stands still or is slow across the tile
    if run[INV_LL] != 0.0:
        k_lo = max(segment_at(s_lo, a, b, run, pos) - SWEEP_MARGIN, a)
        k_hi = min(segment_at(s_hi, a, b, run, pos) + SWEEP_MARGIN, b - 1)
        if k_hi - k_lo >= SWEEP_SEGMENTS:
            k_lo, k_hi = a, a - 1
    for k in range(k_lo, k_hi + 1):
        dx, dy, dz = pos[k + 1, 0] - pos[k, 0], pos[k + 1, 1] - pos[k, 1], pos[k + 1, 2] - pos[k, 2]
        if dx * dx + dy * dy > TINY_MM2:
            _sweep_segment(k, pos, tool[1], floor_mm, qx, qy, best, idx)
        elif dx != 0.0 or dy != 0.0 or dz != 0.0 or (stamp and k == 0):  # vertical, or the stream's first stamp
            for m in range(best.shape[0]):
                best[m], idx[m] = try_segment(qx[m], qy[m], k, best[m], idx[m], pos, tool, stamp)
    counts[2] += (k_hi - k_lo + 1) * best.shape[0]
    _unfinished(g_star, s_star, a, b, k_lo, k_hi, run, pos, floor_mm, qx, qy, best, need)
    for m in range(best.shape[0]):
        if need[m]:
            best[m], idx[m], evaluated = search((qx[m], qy[m]), s_star[m], best[m], idx[m], a, b, run, pos, tool,
                                                stamp, (k_lo, k_hi))
            counts[1] += 1
            counts[2] += evaluated
