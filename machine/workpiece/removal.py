"""The Z-map's update: lower each node to the exact envelope of every period segment that passes over it,
asking about runs of segments (chains.py) and bounding them from below (bounds.py) rather than evaluating
one period at a time.

A node's height after a batch of periods is min(height before, min over the segments k of env_k(q)),
floored at the stock's bottom. Evaluating every segment near every node costs about 36 envelopes per node
and pass of a 3 mm ball at 83 um a period (most of them lowering the node a little as the ball
approaches), and again at every later pass within the tool's reach. Instead, per batch:

STEP 1  Split the batch into runs, each within its deviation of one straight line (chains.py), with the
        tools that bound them from below (bounds.run_table).
STEP 2  List, per block of BLOCK x BLOCK tiles, the runs that reach it, in program order.
STEP 3  Per tile, the listed runs its distance bound does not rule out (tiles.py).
STEP 4  Per tile, the runs passing closest first, then the others their planes do not rule out; per node,
        the exact envelopes of the few segments near where each run's bound is least (tiles.py).

Blocks are independent: each thread takes the next block from a cursor the threads share (an atomic
addition in the nogil kernel), so no thread waits for another before the batch's end; while one thread
cuts alone, it looks between chunks of CHUNK_BLOCKS whether more may join. The heights are those of
evaluating every segment at every node, to the float32 rounding of the stored heights
(tests/machine/test_workpiece.py checks it against the per-segment minimum).
"""
from __future__ import annotations

import math
import time
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from machine.workpiece.bounds import AX, AY, BX, BY, CORE, CORNER, run_table
from machine.workpiece.chains import CHAIN_TOL_MM, MAX_SEGMENTS, build_chains
from machine.workpiece.envelope import seg_distance
from machine.workpiece.scan import near_table
from machine.workpiece.tiles import TILE, Batch, ZMap, cut_tile, workspace

BLOCK = 4  # tiles along a block's side
CHUNK_BLOCKS = 16  # blocks one thread cuts between two looks at how many threads may cut


@intrinsic
def _take(typingctx, cursor):
    """cursor[0] += 1 as one atomic operation (monotonic: the blocks share no node, and the threads' results
    reach the caller through the pool's futures); returns the value before."""
    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, args[0]).data
        return builder.atomic_rmw("add", data, context.get_constant(types.int64, 1), "monotonic")
    return types.int64(cursor), codegen


@njit(cache=True)
def _block_pairs(nby, nbx, origin_x, origin_y, grid_mm, runs, fill, blocks, owners):
    """STEP 2: with fill, (block, run) for every block within a run's reach, in run order, into blocks and
    owners, and their number; without, a bound of that number for the arrays: the blocks of each run's rows
    of blocks between the run's ends widened by its reach, without the test of each block's distance."""
    span = BLOCK * TILE
    half = 0.5 * (span - 1)
    e_block = half * grid_mm * math.sqrt(2.0)
    n = 0
    for c in range(runs.shape[0]):
        run = runs[c]
        x0, y0, x1, y1 = run[AX], run[AY], run[BX], run[BY]
        reach = run[CORE] + run[CORNER] + e_block
        y_lo, y_hi = min(y0, y1), max(y0, y1)
        by0 = max(int(math.floor((y_lo - reach - origin_y) / grid_mm - half)) // span, 0)
        by1 = min(int(math.ceil((y_hi + reach - origin_y) / grid_mm - half)) // span + 1, nby - 1)
        for by in range(by0, by1 + 1):
            my = origin_y + (by * span + half) * grid_mm
            dy_row = max(y_lo - my, my - y_hi, 0.0)
            if dy_row > reach:
                continue
            w = math.sqrt(reach * reach - dy_row * dy_row)
            bx0 = max(int(math.floor((min(x0, x1) - w - origin_x) / grid_mm - half)) // span, 0)
            bx1 = min(int(math.ceil((max(x0, x1) + w - origin_x) / grid_mm - half)) // span + 1, nbx - 1)
            if not fill:
                n += max(bx1 - bx0 + 1, 0)
                continue
            for bx in range(bx0, bx1 + 1):
                if seg_distance(origin_x + (bx * span + half) * grid_mm, my, x0, y0, x1, y1)[0] > reach:
                    continue
                blocks[n], owners[n] = by * nbx + bx, c
                n += 1
    return n


@njit(cache=True, nogil=True)
def plan(zm, bt):
    """STEP 1 and 2: (run starts, run table, per block the offsets of its runs in `listed`, listed, the
    blocks that have runs)."""
    origin_x, origin_y, grid_mm = zm.origin_x, zm.origin_y, zm.grid_mm
    nty, ntx = zm.tile_max.shape
    pos = bt.pos
    nby, nbx = -(-nty // BLOCK), -(-ntx // BLOCK)
    starts = np.empty(pos.shape[0], np.int64)
    starts = starts[:build_chains(pos, CHAIN_TOL_MM, MAX_SEGMENTS, starts) + 1]
    runs = run_table(pos, starts, bt.core, bt.corner)
    empty = np.empty(0, np.int64)
    n = _block_pairs(nby, nbx, origin_x, origin_y, grid_mm, runs, False, empty, empty)
    blocks, owners = np.empty(n, np.int64), np.empty(n, np.int64)
    n = _block_pairs(nby, nbx, origin_x, origin_y, grid_mm, runs, True, blocks, owners)
    blocks, owners = blocks[:n], owners[:n]
    # the runs grouped by block (a stable counting sort keeps each block's runs in program order)
    offsets = np.zeros(nby * nbx + 1, np.int64)
    for p in range(blocks.shape[0]):
        offsets[blocks[p] + 1] += 1
    for t in range(nby * nbx):
        offsets[t + 1] += offsets[t]
    listed = np.empty(blocks.shape[0], np.int64)
    fill = offsets[:-1].copy()
    for p in range(blocks.shape[0]):
        listed[fill[blocks[p]]] = owners[p]
        fill[blocks[p]] += 1
    return starts, runs, offsets, listed, np.nonzero(offsets[1:] > offsets[:-1])[0]


@njit(cache=True, nogil=True, error_model="numpy")
def cut_blocks(blocks, zm, bt, starts, runs, offsets, listed, counts, cursor, end):
    """STEP 3 and 4 over blocks[cursor[0]:end], each block taken from the cursor (_take: the threads that
    share it cut disjoint blocks, which share no node). Numpy's error model, for the divisions of
    bounds.ball_bounds, inlined here: no check of each for a zero, so that its loop vectorizes (no divisor in
    these kernels is zero)."""
    nty, ntx = zm.tile_max.shape
    nbx = -(-ntx // BLOCK)
    most = 0
    for u in range(blocks.shape[0]):
        most = max(most, offsets[blocks[u] + 1] - offsets[blocks[u]])
    ws = workspace(most)
    span = BLOCK * TILE
    half_mm = 0.5 * (BLOCK - 1) * TILE * zm.grid_mm  # a tile centre's offset from its block's centre, at most
    e_tile = 0.5 * (TILE - 1) * zm.grid_mm * math.sqrt(2.0)
    while cursor[0] < end:
        u = _take(cursor)
        if u >= end:
            break
        b = blocks[u]
        mine = listed[offsets[b]:offsets[b + 1]]
        by, bx = b // nbx, b % nbx
        # the scan's frame: the block's centre and its highest node (scan.near_table)
        ws.frame[0] = zm.origin_x + (bx * span + 0.5 * (span - 1)) * zm.grid_mm
        ws.frame[1] = zm.origin_y + (by * span + 0.5 * (span - 1)) * zm.grid_mm
        z_ref = np.max(zm.tile_max[by * BLOCK:by * BLOCK + BLOCK, bx * BLOCK:bx * BLOCK + BLOCK])
        ws.frame[2] = z_ref if np.isfinite(z_ref) else 0.0
        near_table(mine, runs, ws.frame, half_mm, e_tile, ws.columns, ws.near)
        counts[0] += mine.shape[0]
        for ty in range(by * BLOCK, min(by * BLOCK + BLOCK, nty)):
            for tx in range(bx * BLOCK, min(bx * BLOCK + BLOCK, ntx)):
                cut_tile(ty, tx, zm, bt, starts, runs, mine, ws, counts)


def timed_plan(zm: ZMap, bt: Batch) -> tuple[tuple, float]:
    """(plan(zm, bt), the CPU seconds it took on this thread), for a plan made ahead on another thread."""
    c0 = time.thread_time()
    return plan(zm, bt), time.thread_time() - c0


def cut(zm: ZMap, bt: Batch, counts: np.ndarray, threads: int | Callable[[], int] = 1,
        planned: Future | None = None) -> float:
    """Lower zm.z along the batch's segments bt.pos[k] -> bt.pos[k+1]; zm.line[j, i] takes bt.lines[k] of the
    segment that set node (i, j). counts (COUNTS, updated): (block, run) pairs, searches, envelopes
    evaluated, nodes lowered. threads: how many threads cut, or a callable asked again after each chunk of
    CHUNK_BLOCKS blocks this thread cuts alone (the removal thread takes every core as soon as the run has
    ended, in the middle of a batch); once more than one, they cut to the batch's end, each taking the next
    block from the cursor. Returns the CPU seconds of the threads that cut (this one's and the pool's): the
    removal's own, whatever else the process runs meanwhile. planned: the batch's timed_plan, made ahead on
    another thread (its CPU time is counted too)."""
    c0 = time.thread_time()
    (starts, runs, offsets, listed, touched), plan_cpu_s = (planned.result() if planned is not None
                                                                   else (plan(zm, bt), 0.0))
    n = touched.shape[0]
    cursor = np.zeros(1, np.int64)
    tallies = [counts]  # one per thread: this one's, then the pool's
    pool_cpu_s = 0.0

    def helper(tally: np.ndarray) -> float:
        t0 = time.thread_time()
        cut_blocks(touched, zm, bt, starts, runs, offsets, listed, tally, cursor, n)
        return time.thread_time() - t0

    while cursor[0] < n:
        k = max(int(threads() if callable(threads) else threads), 1)
        if k == 1:
            end = min(cursor[0] + CHUNK_BLOCKS, n)
            cut_blocks(touched, zm, bt, starts, runs, offsets, listed, counts, cursor, end)
            continue
        tallies += [np.zeros(counts.shape[0], np.int64) for _ in range(k - 1)]
        with ThreadPoolExecutor(k - 1, thread_name_prefix="vcnc-cut") as pool:
            helpers = [pool.submit(helper, tally) for tally in tallies[1:]]
            cut_blocks(touched, zm, bt, starts, runs, offsets, listed, counts, cursor, n)
            pool_cpu_s += sum(job.result() for job in helpers)
    for tally in tallies[1:]:
        counts += tally
    return time.thread_time() - c0 + pool_cpu_s + plan_cpu_s
