"""STEP 3 and 4 of the Z-map's update (machine/workpiece/removal.py), per tile of TILE x TILE nodes (numba).

STEP 3  The runs listed for the tile's block that its distance bound min(z_A, z_B) - drop + h(d - e)
        does not rule out (d: the tile centre's distance to the run's line, e the tile's half-diagonal),
        each with a key: G* at the centre for a ball, else G where the line passes closest to the centre
        (scan.py: in float32, the bound certified below the float64 one).
STEP 4  First the group of runs whose key is within GROUP_MM of the lowest (the passes through the tile
        and next to it: they leave the nodes near their final heights), then the others in the order of their
        keys, in chunks (CHUNK_GROWTH), each run unless its distance bound is above the tile's highest node or
        its tangent plane of G* at the tile centre is nowhere below a node's height after the chunks before
        (bounds.bound_plane: G* is convex in q; first at the tile's corners against a plane on or above
        every node, _tile_cover). For a ball, the kept runs one after
        the other, the group's first in the order of their keys, at all the rows of nodes each may lower
        at once (search.sweep_ball); for a flat or a bull, per node: each node searches the runs whose G*
        there may still reach its height, in the order of G* (search.search). Whatever the order, a run is
        skipped at a node only where its bound is above the node's height by bounds.ROUNDING_MM
        (search.may_win), so a tie with an earlier segment is never lost to a bound one rounding high.
A node's line is that of the first segment, in program order, that reached its new height: a segment
takes a node that is lower, or as low by an earlier segment (ties between level passes are exact).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from machine.workpiece.bounds import (COLUMNS, ROUNDING_MM, ball_bounds, ball_planes, bound_node, bound_plane,
                                      run_row)
from machine.workpiece.scan import ROWS, candidates, select, threshold
from machine.workpiece.search import lent, may_win, search, sweep_ball

TILE = 8  # nodes along a tile's side
NODES = TILE * TILE
# counts the update keeps: (block, run) pairs, searches, envelopes evaluated, nodes lowered
COUNTS = 4
# STEP 4's first group: the runs whose key is within this of the lowest. On finish_g01.nc (3 mm ball, 0.2 mm
# pick, 50 um grid) it holds the passes through the tile and next to it (a 3 mm ball is 6.7 um above its
# lowest point 0.2 mm aside): searches 4.59 M -> 3.96 M, kept runs 422 k -> 348 k against the closest run
# alone; 10 um: 4.17 M, 371 k; 40 um: 3.69 M, 354 k (the group's own bounds grow).
GROUP_MM = 0.020
# STEP 4's other runs are kept and swept in chunks, in the order of their keys: 1, then 4, 16, ... (each chunk
# CHUNK_GROWTH times the last), each pruned against the heights the chunks before it left. On g1_lhchips4.ngc (a
# 3-D finish, 1/4" ball, 1.6 mm picks: the runs of a pass on a steep flank reach far along it) the planes kept
# 725 k other runs in one chunk, of which 575 k then had no node left to take; in chunks 305 k, envelopes 66.9 M
# -> 36.8 M (one batch, one thread: 0.35 -> 0.28 s). Where a tile has FEW_OTHERS or fewer (finish_g01.nc: 234 k
# after the cover over 38 k tiles, the neighbouring passes), one chunk: the calls of more cost what they save.
CHUNK_GROWTH = 4
FEW_OTHERS = 8
_SUM_U2 = sum((u - 0.5 * (TILE - 1)) ** 2 for u in range(TILE))  # sum of (u - 3.5)^2 over a tile's row


class ZMap(NamedTuple):
    """The heights a batch lowers (the Workpiece's arrays, updated in place) and where their nodes are:
    node (i, j) at (origin_x + i grid_mm, origin_y + j grid_mm)."""

    z: np.ndarray  # (ny, nx) float32
    line: np.ndarray  # (ny, nx) int32: the source line of the segment that cut each node (0: never cut)
    tile_max: np.ndarray  # each TILE x TILE tile's highest node
    origin_x: float
    origin_y: float
    grid_mm: float
    floor_mm: float  # the stock's bottom: nothing is cut below it


class Batch(NamedTuple):
    """A batch of periods: the tool's tip swept along pos[k] -> pos[k + 1] (work mm)."""

    pos: np.ndarray  # (n + 1, 3)
    lines: np.ndarray  # (n,) int32: each segment's source line
    core: float  # the tool (envelope.py's profile)
    corner: float
    stamp_first: bool  # the first segment counts even when of zero length (the tool standing at the start)


class Workspace(NamedTuple):
    """A block's scratch arrays (one set per thread): its frame (the centre's x, y and z_ref, scan.near_table),
    its listed runs' table (float32, near_table), the candidates' bounds and keys (float32, scan.candidates),
    the tile's nodes (best height, its segment) and the kept runs' G*, s* per node."""

    frame: np.ndarray
    near: np.ndarray
    scratch: np.ndarray
    best: np.ndarray
    idx: np.ndarray
    cand: np.ndarray
    planes: np.ndarray  # the planes of G* of the candidates that are not pruned by their bounds (_plane_prunes)
    columns: np.ndarray  # their runs' rows, gathered (bounds.ball_planes; the block's in scan.near_table)
    g_star: np.ndarray
    s_star: np.ndarray
    order: np.ndarray
    ranked: np.ndarray  # the other candidates' places in cand, in the order of their keys
    kept: np.ndarray
    qx: np.ndarray  # the tile's nodes
    qy: np.ndarray
    need: np.ndarray  # search.sweep_ball's scratch


@njit(cache=True, error_model="numpy")
def _tile_cover(best, grid_mm):
    """(c, sx, sy): the plane c + sx (x - mx) + sy (y - my) about the tile centre (mx, my), the nodes' least
    squares plane raised to lie on or above every node's best; nan where the tile has nodes off the grid.
    _plane_prunes compares a run's plane with it at the tile's corners instead of at its 64 nodes."""
    c, sx, sy = 0.0, 0.0, 0.0
    for m in range(NODES):
        u, v = m % TILE - 0.5 * (TILE - 1), m // TILE - 0.5 * (TILE - 1)
        c += best[m]
        sx += best[m] * u
        sy += best[m] * v
    c /= NODES
    sx /= TILE * _SUM_U2 * grid_mm
    sy /= TILE * _SUM_U2 * grid_mm
    above = -np.inf
    for m in range(NODES):
        u, v = m % TILE - 0.5 * (TILE - 1), m // TILE - 0.5 * (TILE - 1)
        above = max(above, best[m] - (c + grid_mm * (sx * u + sy * v)))
    if not np.isfinite(c):  # a node off the grid (-inf)
        return np.nan, 0.0, 0.0
    return c + above, sx, sy


@njit(cache=True, inline="always")
def _over_cover(gc, gx, gy, cover, grid_mm):
    """The plane gc + gx (x - mx) + gy (y - my) is above the tile's cover plane (_tile_cover) at the tile's
    corners, so above every node, by more than ROUNDING_MM (which the rounding of both planes cannot reach)."""
    return gc - cover[0] - 0.5 * (TILE - 1) * grid_mm * (abs(gx - cover[1]) + abs(gy - cover[2])) > ROUNDING_MM


@njit(cache=True)
def _under_cover(n, planes, cover, grid_mm, cand):
    """Of the n candidates with a ball's planes (bounds.ball_planes), those whose plane is not above the
    cover (_over_cover) moved to the front of cand and planes, in order; their number. Without branches."""
    k = 0
    for q in range(n):
        gc, gx, gy, state = planes[0, q], planes[1, q], planes[2, q], planes[3, q]
        cand[k], planes[0, k], planes[1, k], planes[2, k], planes[3, k] = cand[q], gc, gx, gy, state
        k += not (state == 1.0 and _over_cover(gc, gx, gy, cover, grid_mm))
    return k


@njit(cache=True, inline="always")
def _plane_prunes(plane, grid_mm, floor_mm, a, best, idx, cover):
    """(prunes, j_lo, j_hi). Prunes: no node of the tile can take the run, its tangent plane of G* at the tile
    centre (bounds.bound_plane: plane = (G*, dG*/dx, dG*/dy, ok)) being nowhere below a node's best (an exact
    tie can still move a node's line to an earlier segment). First against the tile's cover plane
    (_tile_cover) at the tile's corners: a plane above it there by more than ROUNDING_MM, which the
    rounding of both planes cannot reach, is above every node. Else node by node: the counts are integer
    sums, which the vector units take without reordering floating-point sums. Rows j_lo .. j_hi of the tile
    hold every node where the plane is not above best by ROUNDING_MM: elsewhere G* (at or above its
    plane) cannot win, so _keep need not evaluate it."""
    gc, gx, gy, ok = plane
    if not ok:
        return False, 0, TILE - 1
    if _over_cover(gc, gx, gy, cover, grid_mm):
        return True, 0, TILE - 1
    below = 0
    level = 0
    j_lo, j_hi = TILE, -1
    for m in range(NODES):
        plane = max(gc + grid_mm * (gx * (m % TILE - 0.5 * (TILE - 1)) + gy * (m // TILE - 0.5 * (TILE - 1))),
                    floor_mm)
        below += plane < best[m]
        level += plane == best[m]
        near = plane - ROUNDING_MM < best[m]
        j_lo, j_hi = min(j_lo, m // TILE if near else TILE), max(j_hi, m // TILE if near else -1)
    if below > 0:
        return False, j_lo, j_hi
    if level == 0:
        return True, j_lo, j_hi
    for m in range(NODES):
        plane = max(gc + grid_mm * (gx * (m % TILE - 0.5 * (TILE - 1)) + gy * (m // TILE - 0.5 * (TILE - 1))),
                    floor_mm)
        if plane == best[m] and idx[m] > a:
            return False, j_lo, j_hi
    return True, j_lo, j_hi


@njit(cache=True)
def _search_nodes(r0, r1, zm, bt, starts, runs, ws, counts):
    """Search the kept runs r0 .. r1-1 (ws.kept) at each node of the tile, in the order of their G* there;
    returns the tile's highest node."""
    kept, best, idx, g_star, s_star, order = ws.kept, ws.best, ws.idx, ws.g_star, ws.s_star, ws.order
    pos, tool = bt.pos, (bt.core, bt.corner, zm.floor_mm)
    top = -np.inf
    for m in range(NODES):
        if best[m] == -np.inf:
            continue
        n = 0
        for r in range(r0, r1):  # the runs that may lower the node, sorted by G* (insertion: a few)
            if may_win(g_star[r, m], best[m]):
                k = n
                while k > 0 and g_star[order[k - 1], m] > g_star[r, m]:
                    order[k] = order[k - 1]
                    k -= 1
                order[k] = r
                n += 1
        for k in range(n):
            r = order[k]
            c = kept[r]
            a = starts[c]
            if not may_win(g_star[r, m], best[m]):
                continue
            best[m], idx[m], evaluated = search((ws.qx[m], ws.qy[m]), s_star[r, m], best[m], idx[m], a, starts[c + 1],
                                                run_row(runs, c), pos, tool, bt.stamp_first and a == 0, (1, 0))
            counts[1] += 1
            counts[2] += evaluated
        top = max(top, best[m])
    return top


@njit(cache=True, error_model="numpy", inline="always")
def _sweep_runs(r0, r1, zm, bt, starts, runs, ws, counts):
    """The kept runs r0 .. r1-1 at each node of the tile: for a ball one run after the other at every node at
    once (search.sweep_ball, inlined here, as this is into cut_blocks: numpy's error model; its arrays borrowed by
    cut_tile), else per node (_search_nodes); returns the tile's highest node."""
    if bt.core != 0.0:
        return _search_nodes(r0, r1, zm, bt, starts, runs, ws, counts)
    tool, g_star, best = (bt.core, bt.corner, zm.floor_mm), ws.g_star, ws.best
    for r in range(r0, r1):
        # a run that the runs swept before it have left no node to lower (a third of the kept runs of
        # finish_g01.nc) is passed over after one loop without branches, before sweep_ball's views and searches
        may = False
        for m in range(NODES):
            may |= may_win(g_star[r, m], best[m])
        if not may:
            continue
        c = ws.kept[r]
        a = starts[c]
        sweep_ball(g_star[r], ws.s_star[r], a, starts[c + 1], run_row(runs, c), bt.pos, tool, bt.stamp_first and a == 0,
                   ws.qx, ws.qy, best, ws.idx, ws.need, counts)
    return np.max(ws.best)


@njit(cache=True)
def workspace(n):
    """Scratch arrays for blocks of up to n listed runs, one set per call of removal.cut_blocks (near_table
    fills frame and near for each block in turn)."""
    return Workspace(np.empty(3), np.empty((ROWS, n), np.float32), np.empty((2, n), np.float32), np.empty(NODES),
                     np.empty(NODES, np.int64), np.empty(n, np.int64), np.empty((4, n)), np.empty((COLUMNS, n)),
                     np.empty((n, NODES)), np.empty((n, NODES)), np.empty(n, np.int64), np.empty(n, np.int64),
                     np.empty(n, np.int64), np.empty(NODES), np.empty(NODES), np.empty(NODES, np.bool_))


@njit(cache=True, inline="always")
def _keep(c, kept, i0, j0, zm, core, runs, ws, rows, counts):
    """Run c becomes kept run number `kept`: its (G*, s*) at the tile's nodes into ws (by index, not views:
    bounds.ball_bounds); for a ball only at the rows (j_lo, j_hi) where it may win (_plane_prunes), else inf."""
    run = run_row(runs, c)
    origin_x, origin_y, grid_mm, floor_mm = zm.origin_x, zm.origin_y, zm.grid_mm, zm.floor_mm
    if core == 0.0:
        row, m0, m1 = np.uint64(kept), np.uint64(rows[0] * TILE), np.uint64((rows[1] + 1) * TILE)
        for m in range(np.uint64(NODES)):  # the rows not evaluated; ball_bounds overwrites the others
            ws.g_star[row, m], ws.s_star[row, m] = np.inf, 0.0
        ball_bounds(ws.qx, ws.qy, m0, m1, run, floor_mm, ws.g_star, ws.s_star, row)
        counts[2] += (rows[1] + 1 - rows[0]) * TILE
    else:
        counts[2] += NODES
        for m in range(NODES):
            ws.g_star[kept, m], ws.s_star[kept, m] = bound_node(origin_x + (i0 + m % TILE) * grid_mm,
                                                                origin_y + (j0 + m // TILE) * grid_mm, run, floor_mm)
    ws.kept[kept] = c


@njit(cache=True, inline="always")
def cut_tile(ty, tx, zm, bt, starts, runs, listed, ws, counts):
    """STEP 3 and 4 for one tile of zm (ZMap) by the batch bt (Batch), whose runs (removal.plan) start at
    starts, with their table runs; listed: the runs of the tile's block in program order; ws: its block's
    Workspace. Inlined into removal.cut_blocks, which owns them all, and borrows them (search.lent): a call or
    a view counts a reference to each array it is handed or views (the Workspace holds 16) with two atomic
    operations; a borrowed one has none (finish_g01.nc 0.279 -> 0.245 s, g1_lhchips4.ngc 0.239 -> 0.189 s)."""
    zm, bt, starts, runs, ws, counts = lent((zm, bt, starts, runs, ws, counts))
    z, line, tile_max, lines = zm.z, zm.line, zm.tile_max, bt.lines
    origin_x, origin_y, grid_mm, floor_mm = zm.origin_x, zm.origin_y, zm.grid_mm, zm.floor_mm
    best, idx, cand = ws.best, ws.idx, ws.cand
    ny, nx = z.shape
    i0, j0 = tx * TILE, ty * TILE  # node (i0 + m % TILE, j0 + m // TILE) is at origin + (i, j) g, as everywhere
    mx, my = origin_x + (i0 + 0.5 * (TILE - 1)) * grid_mm, origin_y + (j0 + 0.5 * (TILE - 1)) * grid_mm
    top = tile_max[ty, tx]
    key_min, top32 = candidates(mx, my, top, floor_mm, listed, ws.frame, ws.near, ws.scratch)
    if key_min == np.inf:
        return
    for m in range(NODES):
        j, i = j0 + m // TILE, i0 + m % TILE
        best[m] = z[j, i] if j < ny and i < nx else -np.inf
        idx[m] = -1
        ws.qx[m], ws.qy[m] = origin_x + i * grid_mm, origin_y + j * grid_mm
    # the first group: the runs whose key is within GROUP_MM of the lowest, so that each node's best is nearly
    # final before the other runs are pruned against it
    key0, count = key_min + np.float32(GROUP_MM), listed.shape[0]
    group = select(count, ws.scratch, top32, top32, key0, True, cand)
    for q in range(1, group):  # in the order of their keys (insertion: a few), the lowest first
        p, k = cand[q], q
        while k > 0 and ws.scratch[1, cand[k - 1]] > ws.scratch[1, p]:
            cand[k] = cand[k - 1]
            k -= 1
        cand[k] = p
    for q in range(group):
        _keep(listed[cand[q]], q, i0, j0, zm, bt.core, runs, ws, (0, TILE - 1), counts)
    top_now = _sweep_runs(0, group, zm, bt, starts, runs, ws, counts)
    cover = _tile_cover(best, grid_mm)
    kept = group
    others = select(count, ws.scratch, top32, threshold(top_now, ws.frame), key0, False, cand)
    if bt.core == 0.0:
        ball_planes(mx, my, runs, listed, cand, others, ws.columns, ws.planes)
        others = _under_cover(others, ws.planes, cover, grid_mm, cand)
    ranked = ws.ranked
    for q in range(others):  # in the order of their keys (insertion), the lowest first
        k = q
        while k > 0 and ws.scratch[1, cand[ranked[k - 1]]] > ws.scratch[1, cand[q]]:
            ranked[k] = ranked[k - 1]
            k -= 1
        ranked[k] = q
    q0, size = 0, 1 if others > FEW_OTHERS else others
    while q0 < others:
        first = kept
        for u in range(q0, min(q0 + size, others)):
            q = ranked[u]
            c = listed[cand[q]]
            state = ws.planes[3, q] if bt.core == 0.0 else 2.0
            plane = bound_plane(mx, my, run_row(runs, c)) if state == 2.0 else (ws.planes[0, q], ws.planes[1, q],
                                                                                 ws.planes[2, q], state == 1.0)
            prunes, j_lo, j_hi = _plane_prunes(plane, grid_mm, floor_mm, starts[c], best, idx, cover)
            if not prunes:
                _keep(c, kept, i0, j0, zm, bt.core, runs, ws, (j_lo, j_hi), counts)
                kept += 1
        if kept > first:
            _sweep_runs(first, kept, zm, bt, starts, runs, ws, counts)
        q0, size = q0 + size, size * CHUNK_GROWTH
    new_top = -np.inf
    for m in range(NODES):
        j, i = j0 + m // TILE, i0 + m % TILE
        if j >= ny or i >= nx:
            continue
        if idx[m] >= 0:
            z[j, i] = best[m]
            line[j, i] = lines[idx[m]]
            counts[3] += 1
        new_top = max(new_top, np.float64(z[j, i]))
    tile_max[ty, tx] = new_top
