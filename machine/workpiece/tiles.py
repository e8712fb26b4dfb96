"""STEP 3 and 4 of the Z-map's update (machine/workpiece/removal.py), per tile of TILE x TILE nodes (numba).

STEP 3  The runs listed for the tile's block that its distance bound min(z_A, z_B) - drop + h(d - e)
        does not rule out (d: the tile centre's distance to the run's line, e the tile's half-diagonal),
        each with a key: G where the line passes closest to the centre.
STEP 4  First the group of runs whose key is within GROUP_MM of the lowest (the passes through the tile
        and next to it: they leave the nodes near their final heights), then each other run unless its
        distance bound is above the tile's highest node or its tangent plane of G* at the tile centre is
        nowhere below a node (bounds.bound_plane: G* is convex in q). The group's runs, for a ball, one
        after the other at every node at once (search.sweep_ball), and so the other runs whose G* is below
        SWEEP_NODES nodes or more; the rest, and every run of a flat or a bull, per node: each node
        searches the runs whose G* there is below its height, in the order of G* (search.search).
A node's line is that of the first segment, in program order, that reached its new height: a segment
takes a node that is lower, or as low by an earlier segment (ties between level passes are exact).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from machine.workpiece.bounds import (AX, AY, AZ, BX, BY, BZ, CORE, CORNER, DROP, INV_LL, ball_bounds, bound_line,
                                      bound_node, bound_plane, proj, run_row)
from machine.workpiece.search import search, sweep_ball, wins

TILE = 8  # nodes along a tile's side
NODES = TILE * TILE
# counts the update keeps: (block, run) pairs, searches, envelopes evaluated, nodes lowered
COUNTS = 4
# STEP 4's first group: the runs whose key is within this of the lowest. On finish_g01.nc (3 mm ball, 0.2 mm
# pick, 50 um grid) it holds the passes through the tile and next to it (a 3 mm ball is 6.7 um above its
# lowest point 0.2 mm aside): searches 4.59 M -> 3.96 M, kept runs 422 k -> 348 k against the closest run
# alone; 10 um: 4.17 M, 371 k; 40 um: 3.69 M, 354 k (the group's own bounds grow).
GROUP_MM = 0.020
# A run kept after the group is swept (search.sweep_ball) when its G* is below this many nodes or more, else
# searched per node: on finish_g01.nc (one batch, one thread) the searches fell 1.35 M -> 0.34 M, the envelopes
# evaluated rose 61 M -> 73 M; 8 nodes: 0.22 M and 78 M, 4: 0.19 M and 80 M, and no faster.
SWEEP_NODES = 16


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
    """A block's scratch arrays (one set per thread): its listed runs' table (_near), the candidates'
    bounds and keys, the tile's nodes (best height, its segment) and the kept runs' G*, s* per node."""

    near: np.ndarray
    scratch: np.ndarray
    best: np.ndarray
    idx: np.ndarray
    cand: np.ndarray
    cand_bound: np.ndarray
    cand_key: np.ndarray
    g_star: np.ndarray
    s_star: np.ndarray
    order: np.ndarray
    kept: np.ndarray
    qx: np.ndarray  # the tile's nodes
    qy: np.ndarray
    need: np.ndarray  # search.sweep_ball's scratch


@njit(cache=True)
def _plane_prunes(run, mx, my, grid_mm, floor_mm, a, best, idx):
    """No node of the tile can take the run: its tangent plane of G* at the tile centre (bounds.bound_plane)
    is nowhere below a node's best (an exact tie can still move a node's line to an earlier segment).
    The counts are integer sums, which the vector units take without reordering floating-point sums."""
    gc, gx, gy, ok = bound_plane(mx, my, run)
    if not ok:
        return False
    below = 0
    level = 0
    for m in range(NODES):
        plane = max(gc + grid_mm * (gx * (m % TILE - 0.5 * (TILE - 1)) + gy * (m // TILE - 0.5 * (TILE - 1))),
                    floor_mm)
        below += plane < best[m]
        level += plane == best[m]
    if below > 0:
        return False
    if level == 0:
        return True
    for m in range(NODES):
        plane = max(gc + grid_mm * (gx * (m % TILE - 0.5 * (TILE - 1)) + gy * (m // TILE - 0.5 * (TILE - 1))),
                    floor_mm)
        if plane == best[m] and idx[m] > a:
            return False
    return True


# rows of a block's table of its runs (_near), laid out for the scan of each tile
NX0, NY0, NDX, NDY, NINV, NLOW, NZ0, NDZ, NCORE, NCORNER = range(10)


@njit(cache=True)
def _near(listed, runs):
    """The listed runs' lines and bound tools, one row per quantity (STEP 3's scan reads them in order)."""
    near = np.empty((10, listed.shape[0]))
    for p in range(listed.shape[0]):
        run = runs[listed[p]]
        dx, dy = run[BX] - run[AX], run[BY] - run[AY]
        bb = dx * dx + dy * dy
        near[NX0, p], near[NY0, p], near[NDX, p], near[NDY, p] = run[AX], run[AY], dx, dy
        near[NINV, p] = 1.0 / bb if bb > 1e-18 else 0.0
        near[NLOW, p] = min(run[AZ], run[BZ]) - run[DROP]
        near[NZ0, p], near[NDZ, p] = run[AZ] - run[DROP], run[BZ] - run[AZ]
        near[NCORE, p], near[NCORNER, p] = run[CORE], run[CORNER]
    return near


@njit(cache=True)
def _candidates(mx, my, e_tile, top, floor_mm, listed, ws):
    """STEP 3 for the tile centred at (mx, my): the listed runs whose distance bound is below top, with
    that bound and their key (G where the line passes closest to the centre) into ws; (count, the lowest
    key's place). The first loop has no branches, for the vector units."""
    near, scratch, cand, cand_bound, cand_key = ws.near, ws.scratch, ws.cand, ws.cand_bound, ws.cand_key
    count = listed.shape[0]
    for p in range(count):
        px, py = mx - near[NX0, p], my - near[NY0, p]
        dx, dy = near[NDX, p], near[NDY, p]
        t = min(max((px * dx + py * dy) * near[NINV, p], 0.0), 1.0)
        ex, ey = px - t * dx, py - t * dy
        d = math.sqrt(ex * ex + ey * ey)
        core, corner = near[NCORE, p], near[NCORNER, p]
        u = min(max(d - e_tile - core, 0.0), corner)  # the tile's nearest point, clamped into the tool
        bound = near[NLOW, p] + corner - math.sqrt(corner * corner - u * u)
        w = min(max(d - core, 0.0), corner)
        scratch[0, p] = max(bound, floor_mm) if d <= core + corner + e_tile else np.inf
        scratch[1, p] = near[NZ0, p] + t * near[NDZ, p] + corner - math.sqrt(corner * corner - w * w)
    n, first = 0, 0
    for p in range(count):
        if scratch[0, p] < top:
            cand[n], cand_bound[n], cand_key[n] = listed[p], scratch[0, p], scratch[1, p]
            if cand_key[n] < cand_key[first]:
                first = n
            n += 1
    return n, first


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
            if wins(g_star[r, m], starts[kept[r]], best[m], idx[m]):
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
            if not wins(g_star[r, m], a, best[m], idx[m]):
                continue
            best[m], idx[m], evaluated = search((ws.qx[m], ws.qy[m]), s_star[r, m], best[m], idx[m], a, starts[c + 1],
                                                run_row(runs, c), pos, tool, bt.stamp_first and a == 0)
            counts[1] += 1
            counts[2] += evaluated
        top = max(top, best[m])
    return top


@njit(cache=True)
def _sweep_runs(r0, r1, zm, bt, starts, runs, ws, counts):
    """The kept runs r0 .. r1-1 at each node of the tile: for a ball one run after the other at every node at
    once (search.sweep_ball), else per node (_search_nodes); returns the tile's highest node."""
    if bt.core != 0.0:
        return _search_nodes(r0, r1, zm, bt, starts, runs, ws, counts)
    tool = (bt.core, bt.corner, zm.floor_mm)
    for r in range(r0, r1):
        c = ws.kept[r]
        a = starts[c]
        sweep_ball(ws.g_star[r], ws.s_star[r], a, starts[c + 1], run_row(runs, c), bt.pos, tool,
                   bt.stamp_first and a == 0, ws.qx, ws.qy, ws.best, ws.idx, ws.need, counts)
    return np.max(ws.best)


@njit(cache=True)
def _sweep_crowded(r0, r1, zm, bt, starts, runs, ws, counts):
    """The kept runs r0 .. r1-1 of a ball whose G* wins at SWEEP_NODES nodes or more: swept
    (search.sweep_ball), their G* then set to inf so that _search_nodes passes them by."""
    tool = (bt.core, bt.corner, zm.floor_mm)
    for r in range(r0, r1):
        c = ws.kept[r]
        a = starts[c]
        lowers = 0
        for m in range(NODES):
            lowers += wins(ws.g_star[r, m], a, ws.best[m], ws.idx[m])
        if lowers >= SWEEP_NODES:
            sweep_ball(ws.g_star[r], ws.s_star[r], a, starts[c + 1], run_row(runs, c), bt.pos, tool,
                       bt.stamp_first and a == 0, ws.qx, ws.qy, ws.best, ws.idx, ws.need, counts)
            ws.g_star[r, :] = np.inf


@njit(cache=True)
def workspace(listed, runs):
    """A block's scratch arrays (one set per thread)."""
    n = listed.shape[0]
    return Workspace(_near(listed, runs), np.empty((2, n)), np.empty(NODES), np.empty(NODES, np.int64),
                     np.empty(n, np.int64), np.empty(n), np.empty(n), np.empty((n, NODES)), np.empty((n, NODES)),
                     np.empty(n, np.int64), np.empty(n, np.int64), np.empty(NODES), np.empty(NODES),
                     np.empty(NODES, np.bool_))


@njit(cache=True, inline="always")
def _keep(q, kept, i0, j0, zm, core, cand, runs, ws):
    """Candidate q becomes kept run number `kept`: its (G*, s*) at the tile's nodes into ws."""
    run = run_row(runs, cand[q])
    origin_x, origin_y, grid_mm, floor_mm = zm.origin_x, zm.origin_y, zm.grid_mm, zm.floor_mm
    if core == 0.0:
        ball_bounds(origin_x, origin_y, grid_mm, i0, j0, TILE, TILE, run, floor_mm, ws.g_star[kept], ws.s_star[kept])
    else:
        for m in range(NODES):
            ws.g_star[kept, m], ws.s_star[kept, m] = bound_node(origin_x + (i0 + m % TILE) * grid_mm,
                                                                origin_y + (j0 + m // TILE) * grid_mm, run, floor_mm)
    ws.kept[kept] = cand[q]


@njit(cache=True)
def cut_tile(ty, tx, zm, bt, starts, runs, listed, ws, counts):
    """STEP 3 and 4 for one tile of zm (ZMap) by the batch bt (Batch), whose runs (removal.plan) start at
    starts, with their table runs; listed: the runs of the tile's block in program order; ws: its block's
    Workspace."""
    z, line, tile_max, lines = zm.z, zm.line, zm.tile_max, bt.lines
    origin_x, origin_y, grid_mm, floor_mm = zm.origin_x, zm.origin_y, zm.grid_mm, zm.floor_mm
    best, idx, cand, cand_bound = ws.best, ws.idx, ws.cand, ws.cand_bound
    ny, nx = z.shape
    e_tile = 0.5 * (TILE - 1) * grid_mm * math.sqrt(2.0)
    i0, j0 = tx * TILE, ty * TILE  # node (i0 + m % TILE, j0 + m // TILE) is at origin + (i, j) g, as everywhere
    mx, my = origin_x + (i0 + 0.5 * (TILE - 1)) * grid_mm, origin_y + (j0 + 0.5 * (TILE - 1)) * grid_mm
    top = tile_max[ty, tx]
    n, first = _candidates(mx, my, e_tile, top, floor_mm, listed, ws)
    if n == 0:
        return
    for m in range(NODES):
        j, i = j0 + m // TILE, i0 + m % TILE
        best[m] = z[j, i] if j < ny and i < nx else -np.inf
        idx[m] = -1
        ws.qx[m], ws.qy[m] = origin_x + i * grid_mm, origin_y + j * grid_mm
    # the first group: the runs whose key is within GROUP_MM of the lowest, so that each node's best is nearly
    # final before the other runs are pruned against it
    key0 = ws.cand_key[first] + GROUP_MM
    kept = 0
    for q in range(n):
        if ws.cand_key[q] <= key0:
            _keep(q, kept, i0, j0, zm, bt.core, cand, runs, ws)
            kept += 1
    group = kept
    top = _sweep_runs(0, group, zm, bt, starts, runs, ws, counts)
    for q in range(n):
        if ws.cand_key[q] <= key0 or cand_bound[q] > top or _plane_prunes(run_row(runs, cand[q]), mx, my, grid_mm,
                                                                          floor_mm, starts[cand[q]], best, idx):
            continue
        _keep(q, kept, i0, j0, zm, bt.core, cand, runs, ws)
        kept += 1
    counts[2] += kept * NODES
    if bt.core == 0.0:
        _sweep_crowded(group, kept, zm, bt, starts, runs, ws, counts)
    _search_nodes(group, kept, zm, bt, starts, runs, ws, counts)
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
