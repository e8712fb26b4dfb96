"""STEP 3's float32 scan (machine/workpiece/scan.py) against the float64 distance bound it replaces."""
from __future__ import annotations

import math

import numpy as np

from machine.workpiece.bounds import AX, AY, AZ, BX, BY, BZ, COLUMNS, CORE, CORNER, DROP
from machine.workpiece.envelope import ball_slanted
from machine.workpiece.scan import candidates, near_table, select, threshold
from machine.workpiece.tiles import workspace

GRID_MM = 0.05
HALF_MM = 12 * GRID_MM  # a tile centre's largest offset from its block's centre (blocks of 4 x 4 tiles of 8 nodes)
E_TILE = 3.5 * GRID_MM * math.sqrt(2.0)


def bound64(m, run, floor_mm):
    """The float64 bound the scan had (tiles._candidates at b41a03e): min(z_A, z_B) - drop + h(d - e - core)."""
    a, b = np.array([run[AX], run[AY]]), np.array([run[BX], run[BY]])
    dxy = b - a
    bb = dxy @ dxy
    t = min(max((m - a) @ dxy / bb, 0.0), 1.0) if bb > 1e-18 else 0.0
    d = math.hypot(*(m - a - t * dxy))
    core, corner = run[CORE], run[CORNER]
    if d > core + corner + E_TILE:
        return math.inf
    u = min(max(d - E_TILE - core, 0.0), corner)
    return max(min(run[AZ], run[BZ]) - run[DROP] + corner - math.sqrt(corner * corner - u * u), floor_mm)


def runs_near(rng, centre, n, core, corner):
    """n runs of every kind near a block centred at `centre` (work mm): long lines through it, short and tiny
    ones, vertical ones and ones standing still, level and steep, their ends up to 1000 mm away."""
    runs = np.zeros((n, COLUMNS))
    for c in range(n):
        kind = c % 6
        direction = rng.normal(size=2)
        direction /= np.hypot(*direction)
        foot = centre + rng.uniform(-1, 1, 2) * (core + corner + 1.5)  # the line passes near the block
        length = {0: 2000.0, 1: 3.0, 2: 1e-6, 3: 0.0, 4: 0.3, 5: 40.0}[kind]
        before = rng.uniform(0, 1) * length
        a, b = foot - before * direction, foot + (length - before) * direction
        z = rng.uniform(-5, 5) + 20.0
        dz = {0: 0.0, 1: rng.uniform(-2, 2), 2: 1e-7, 3: rng.choice([0.0, 5.0]), 4: rng.uniform(-0.3, 0.3),
              5: rng.uniform(-30, 30)}[kind]
        runs[c, [AX, AY, AZ, BX, BY, BZ]] = a[0], a[1], z, b[0], b[1], z + dz
        e3 = rng.choice([0.0, 1e-4, 2e-3])
        runs[c, [CORE, CORNER, DROP]] = (0.0, corner + e3, e3) if core == 0.0 else (core + e3, corner, 0.0)
    return runs


def test_the_float32_bound_is_never_above_the_float64_one():
    """On runs of every kind (long lines, tiny ones, vertical, sloped, level), far from the origin, each tile
    centre of the block and centres placed at the tool's rim and at the edge of its flat core: the scan's
    bound, back in float64 (+ z_ref), at or below the float64 bound; a run the float64 bound keeps (below a
    height) is kept by the float32 test against the threshold of that height."""
    rng = np.random.default_rng(20)
    for centre, z_ref, core, corner, floor_mm in (((0.3, -0.2), 22.0, 0.0, 1.5, 10.0),
                                                  ((987.6, -734.1), 18.5, 0.0, 3.0, 17.0),
                                                  ((-1000.0, 999.9), 25.0, 2.0, 1.0, -np.inf),
                                                  ((512.3, 3.3), 20.0, 3.0, 0.0, 19.99)):
        centre = np.array(centre)
        runs = runs_near(rng, centre, 120, core, corner)
        listed = np.arange(runs.shape[0])
        ws = workspace(runs.shape[0])
        ws.frame[:] = centre[0], centre[1], z_ref
        near_table(listed, runs, ws.frame, HALF_MM, E_TILE, ws.columns, ws.near)
        offsets = [np.array([i, j]) * 8 * GRID_MM for i in (-1.5, -0.5, 0.5, 1.5) for j in (-1.5, -0.5, 0.5, 1.5)]
        for c in range(0, runs.shape[0], 7):  # centres at the rim and at the core's edge of some runs
            a = runs[c, [AX, AY]]
            for reach in (core + runs[c, CORNER] + E_TILE, core + E_TILE):
                for side in (-1e-9, 0.0, 1e-9):
                    v = centre - a
                    m = a + v / max(np.hypot(*v), 1e-300) * (reach + side)
                    if np.all(np.abs(m - centre) <= HALF_MM):
                        offsets.append(m - centre)
        for offset in offsets:
            m = centre + offset
            top = z_ref + rng.uniform(-3, 0.5)
            candidates(m[0], m[1], top, floor_mm, listed, ws.frame, ws.near, ws.scratch)
            top32 = threshold(top, ws.frame)
            for p in range(runs.shape[0]):
                b64 = bound64(m, runs[p], floor_mm)
                b32 = float(ws.scratch[0, p])
                assert z_ref + b32 <= b64, (centre, offset, p, b32, b64 - z_ref)
                assert not b64 < top or b32 < top32


def test_the_key_of_a_ball_is_its_lowest_point_over_the_centre():
    """A ball's key (float32, relative to z_ref) is G* at the tile centre to 1e-5 mm on lines of every
    slope within its reach (envelope.ball_slanted in float64): it only orders the runs."""
    rng = np.random.default_rng(21)
    centre, z_ref = np.array([123.4, -56.7]), 20.0
    runs = runs_near(rng, centre, 120, 0.0, 1.5)
    keep = [c for c in range(runs.shape[0]) if np.hypot(runs[c, BX] - runs[c, AX], runs[c, BY] - runs[c, AY]) > 1e-4]
    runs = runs[keep]
    listed = np.arange(runs.shape[0])
    ws = workspace(runs.shape[0])
    ws.frame[:] = centre[0], centre[1], z_ref
    near_table(listed, runs, ws.frame, HALF_MM, E_TILE, ws.columns, ws.near)
    checked = 0
    for _ in range(10):
        m = centre + rng.uniform(-HALF_MM, HALF_MM, 2)
        candidates(m[0], m[1], np.inf, -np.inf, listed, ws.frame, ws.near, ws.scratch)
        for p in range(runs.shape[0]):
            r = runs[p]
            g = ball_slanted(m[0], m[1], r[AX], r[AY], r[AZ] - r[DROP], r[BX], r[BY], r[BZ] - r[DROP], r[CORNER])[0]
            if g < np.inf:
                assert abs(z_ref + float(ws.scratch[1, p]) - g) < 1e-5, (p, ws.scratch[1, p], g - z_ref)
                checked += 1
    assert checked > 100


def test_select_takes_the_runs_its_tests_name_in_order():
    """scan.select (64 runs a word of bits) against the tests run by run, over lists that end inside a word, at
    its end and after it, ties with the thresholds included."""
    rng = np.random.default_rng(22)
    for count in (0, 1, 63, 64, 65, 130, 300):
        scratch = rng.choice(np.float32([-1.0, -0.5, 0.0, 0.2, 0.5, 1.0, np.inf]), (2, max(count, 1)))
        chosen = np.full(max(count, 1), -1, np.int64)
        top32, top_now32, key0 = np.float32(0.5), np.float32(0.2), np.float32(0.0)
        n = select(count, scratch, top32, top_now32, key0, True, chosen)
        assert list(chosen[:n]) == [p for p in range(count) if scratch[0, p] < 0.5 and scratch[1, p] <= 0.0]
        n = select(count, scratch, top32, top_now32, key0, False, chosen)
        assert list(chosen[:n]) == [p for p in range(count)
                                    if scratch[0, p] < 0.5 and scratch[1, p] > 0.0 and scratch[0, p] <= 0.2]
