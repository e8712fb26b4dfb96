"""A stretch of G1 moves outside the groups as the fewest G1/G2/G3 blocks, its junctions anywhere on
its segments.

The plan (ipo.fit.conic_plan) joins runs written as one move (ipo.fit.arcs) at the source's vertices.
Between two blocks the fit writes, though, the junction may lie anywhere on the path: a fillet's arc
may end inside the chord that leads into the next curve. So each stretch of G1 moves that
the plan leaves outside groups is planned again over junctions at every vertex and at every 1/STEPS
of each segment: a shortest path, one block per piece, each piece (a junction, the vertices inside,
the next junction) tested by ipo.fit.arcs.one_move, and taken where it is fewer blocks than the plan's.
Inner junctions are tried only on the NEAR segments each side of an end of the plan's one-move pieces (a
kept zig-zag leaves nothing to join: 32 junctions on every segment cost g1_stellabee1's first 30000 lines
11.7 s of fit at 5 um, these 3.3 s, 1.1 s without move_runs; g1_lhchips4 the same blocks), and a
junction reached with no fewer blocks than one up to a segment ahead of it starts no piece (that one
reaches as far), and a piece to a junction already reached with no more blocks is not tested.
The pieces partition the path, so the two-way distance of the whole is that of its worst piece; each
is checked again as written (ipo.fit.convert). A junction inside a segment is written to the fit's
decimals (ipo.fit.written.coordinate_digits: the rounding its tolerance leaves room for).
On g1_lhchips4 at 10 um, 3435 -> 3305 written blocks (junctions at 1/8 of a segment: 3343; 1/16: 3310).
"""
from __future__ import annotations

from bisect import bisect_left, bisect_right

import numpy as np
from numba import njit

from ipo.fit.arcs import ARC, NONE, fit_move, one_move
from ipo.fit.groups import Span
from ipr.entities import PLANE_AXES, Line

STEPS = 32  # junctions per segment (its start and STEPS - 1 points inside it)
MAX_INSIDE = 400  # source vertices inside one piece at most
FAILS = 3  # longer pieces tried after this many vertices in a row end no piece
INF = 1 << 40
NEAR = 3  # segments on each side of an end of the plan's one-move pieces whose inner junctions are tried
# of the tolerance: a junction inside a segment is rounded as written, and the next piece starts there
ROUNDING_MARGIN = 0.005


@njit(cache=True)
def _piece(q, k, m, steps, buf):
    """The path from junction k to junction m into buf: its two ends and the vertices between; its length."""
    n = q.shape[0] - 1
    i, f = k // steps, (k % steps) / steps
    buf[0] = q[i] + f * (q[min(i + 1, n)] - q[i])
    count = 1
    for v in range(k // steps + 1, (m + steps - 1) // steps):
        buf[count] = q[v]
        count += 1
    i, f = m // steps, (m % steps) / steps
    buf[count] = q[i] + f * (q[min(i + 1, n)] - q[i])
    return count + 1


@njit(cache=True)
def _dominated(cost, k, steps):
    """A junction up to a segment ahead is reached with no more blocks: a piece from there reaches at
    least as far (a piece within tol is, but for its ends, within tol from any junction inside it)."""
    for j in range(k + 1, min(k + steps + 1, cost.shape[0])):
        if cost[j] <= cost[k]:
            return True
    return False


@njit(cache=True)
def plan_junctions(q, sharp, axes, tol_mm, steps, restore_cost, near):
    """Fewest pieces from q[0] to q[-1] (module doc): the cost and the junction each is reached from, per
    junction k (point q[k // steps] + (k % steps) / steps of its segment). sharp: vertices no piece may
    have inside; restore_cost: blocks after the stretch where it ends in an arc; near: the segments whose
    inner junctions are tried (the others: only their start vertex)."""
    n_j = steps * (q.shape[0] - 1) + 1
    cost = np.full(n_j, INF, dtype=np.int64)
    came = np.full(n_j, -1, dtype=np.int64)
    cost[0] = 0
    buf = np.empty((min(q.shape[0], MAX_INSIDE) + 2, 3))
    centre = np.empty(3)
    for k in range(n_j):
        if cost[k] >= INF or (k % steps and not near[k // steps]) or _dominated(cost, k, steps):
            continue
        fails = 0
        for m in range(k + 1, n_j):
            inside = (m + steps - 1) // steps - 1  # the last vertex before junction m
            if inside > k // steps and (sharp[inside] or inside - k // steps > MAX_INSIDE):
                break
            if (m % steps and not near[m // steps]) or cost[k] + 1 >= cost[m]:
                continue  # not a junction, or no piece from k makes m cheaper: not tested, not counted
            count = _piece(q, k, m, steps, buf)
            kind = one_move(buf[:count], 0, count - 1, axes[0], axes[1], axes[2], tol_mm, centre)
            if kind == NONE:
                fails += m % steps == 0
                if fails > FAILS:
                    break
                continue
            fails = 0
            c = cost[k] + 1 + (restore_cost if kind == ARC and m == n_j - 1 else 0)
            if c < cost[m]:
                cost[m] = c
                came[m] = k
    return cost, came


def free_junctions(chain, spans: list[Span], opt, sharp: np.ndarray) -> list[Span]:
    """The plan's spans with each stretch of G1 moves outside groups planned again (module
    doc) where that saves blocks. sharp: the chain's sharp vertices (bool per point); opt: FitOptions."""
    grouped = np.zeros(len(chain.moves), dtype=bool)
    for s in spans:
        if s.fit is not None:
            grouped[s.first:s.last] = True
    free = [isinstance(m, Line) and not g for m, g in zip(chain.moves, grouped)]
    stretches = []  # (first, last) move indices: runs of free G1 moves (whatever their feeds: quadratic._line_runs)
    for i, m in enumerate(chain.moves):
        if free[i] and i > 0 and free[i - 1]:
            stretches[-1] = (stretches[-1][0], i + 1)
        elif free[i]:
            stretches.append((i, i + 1))
    starts = [s.first for s in spans]  # the spans partition the moves, in path order
    new = []
    for first, last in stretches:
        if last - first >= 2:
            local = spans[bisect_right(starts, first) - 1:bisect_left(starts, last)]
            span = _replanned(chain, local, first, last, opt, sharp)
            if span is not None:
                new.append(span)
    return _spliced(spans, new) if new else spans


def _spliced(spans: list[Span], new: list[Span]) -> list[Span]:
    """The spans with new's (disjoint, in path order) in place of the moves they cover: a kept span is cut
    at them, any other that they cover dropped (one pass: a chain may hold thousands of stretches)."""
    out, k = [], 0
    for s in spans:
        while k < len(new) and new[k].last <= s.first:
            k += 1
        lo, j, covered = s.first, k, False
        while j < len(new) and new[j].first < s.last:
            if s.kept and new[j].first > lo:
                out.append(Span(lo, new[j].first))
            lo, j, covered = max(lo, new[j].last), j + 1, True
        if s.kept and lo < s.last:
            out.append(Span(lo, s.last))
        elif not s.kept and not covered:
            out.append(s)
    return sorted(out + new, key=lambda s: s.first)


def _blocks(spans: list[Span], first: int, last: int, restore: int) -> int:
    """Blocks the spans write for moves first..last-1 (one-move spans lie wholly inside or outside)."""
    count = 0
    for s in spans:
        if s.one_moves and first <= s.first and s.last <= last:
            count += len(s.one_moves) + (restore if s.last == last and s.one_moves[-1].centre_mm is not None else 0)
        elif s.kept:
            count += max(0, min(s.last, last) - max(s.first, first))
    return count


def _replanned(chain, spans: list[Span], first: int, last: int, opt, sharp: np.ndarray) -> Span | None:
    """Moves first..last-1 (a stretch; spans: those of the plan that meet it) as one span of one moves
    over free junctions, or None where that is no fewer blocks than the plan's."""
    a = 0 if first == 0 else int(chain.ends[first - 1])
    b = int(chain.ends[last - 1])
    q = np.ascontiguousarray(chain.points[a:b + 1])
    restore = opt.restore_blocks if last == len(chain.moves) else 0
    axes = np.array(PLANE_AXES[opt.plane], dtype=np.int64)
    tol = opt.tol_mm * (1.0 - ROUNDING_MARGIN)
    near = np.zeros(len(q), dtype=bool)  # the segments near an end of the plan's one-move pieces
    for s in spans:
        if first <= s.first and s.last <= last and s.one_moves:
            for end in (s.first, s.last):
                at = (0 if end == 0 else int(chain.ends[end - 1])) - a
                near[max(at - NEAR, 0):at + NEAR] = True
    cost, came = plan_junctions(q, sharp[a:b + 1], axes, tol, STEPS, restore, near)
    if cost[-1] >= _blocks(spans, first, last, restore):
        return None
    pieces, m = [], len(cost) - 1
    buf = np.empty((len(q) + 2, 3))
    while m > 0:
        k = int(came[m])
        count = _piece(q, k, m, STEPS, buf)
        pieces.append(fit_move(buf[:count].copy(), opt.plane, tol, vertex_end=m % STEPS == 0))
        m = k
    return Span(first, last, data=q, one_moves=tuple(pieces[::-1]))
