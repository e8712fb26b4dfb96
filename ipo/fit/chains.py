"""Chains: the stretches of a program that one fit may replace, and where they must stay sharp.

A chain is a maximal sequence of feed moves (G1 lines and G2/G3 arcs) that follow
each other without a gap, at one feed (or feeds that are all at or above what the
machine's axes can reach together: they move it alike), under continuous path control (G64), with
nothing else in between; a caller adds its own condition (`joinable`, e.g. adjacent
source lines written as plain motion blocks). Corners do not end a chain: a fit
rounds them within the tolerance or keeps them sharp inside the curve (a knot of
multiplicity = degree). G61/G61.1 (exact stop) moves never join a chain: the
program asks for every corner there to be kept.

A corner is kept sharp where rounding it within the tolerance cannot be done at
the feed the move is programmed at: the largest circular rounding that stays
within tol of a corner that turns by theta has radius R = tol / (sec(theta/2) - 1)
(the distance from the vertex to the arc is R (sec(theta/2) - 1)), and the
centripetal acceleration v^2 / R must stay within the machine's a_max. A turn
above `corner_deg` that fails this is sharp; smaller turns are always left to the
fit (CAM polylines of a fillet turn a few degrees per vertex, and each is a
point of a curve, not a corner).

Why the feed decides, not only the room the moves give: the conic planner
(ipo.fit.conic_plan) can round any turn below about 150 degrees within tol
(arms of a few tol, or a weight that pulls the span into the corner), but such a
rounding costs a block, as a corner does (the vertex is a control point either way),
and its tiny radius slows the machine as much as the corner. Leaving every turn to
the fit (corner_deg 179) on LinuxCNC's lhchips4 at 10 um, whose G64 P0.1 lets the
controller round its corners by 0.1 mm: 4729 blocks instead of 4645 (more weight
restarts behind tight roundings: 456 double knots instead of 374), cycle time 179.3 s
instead of 178.6 s (170.0 s as G1), and two groups the controller could not table
(kept as G1, ipo.fit.convert's walkable check); on g1_3d_chips 1722 blocks instead of
1290 (cycle 47.4 s instead of 46.3 s, 50.1 s as G1).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from ipr.entities import PLANE_AXES, Arc, Line

DEFAULT_CORNER_DEG = 30.0
ARC_SAG_FRACTION = 0.1  # arcs become chords within this fraction of the tolerance


@dataclass(frozen=True, slots=True)
class Chain:
    """Moves in program order and their path as a polyline: `points[ends[i]]` is where move i ends
    (`ends[-1] == len(points) - 1`, `points[0]` is the chain's start). tan_in/tan_out: the exact
    direction in which the path arrives at / leaves each point (a line's own, an arc's tangent;
    at the chain's ends the one there is); on_arc: points inside an arc."""

    moves: tuple
    points: np.ndarray  # (n, 3) mm
    ends: np.ndarray  # (len(moves),) index of each move's end in points
    sag_mm: float  # largest distance of an arc from its chords (0 without arcs)
    tan_in: np.ndarray  # (n, 3) unit
    tan_out: np.ndarray  # (n, 3) unit
    on_arc: np.ndarray  # (n,) bool


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _arc_points(arc: Arc, sag_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Points on the arc after its start, the last one its end, chords within sag_mm; and the arc's
    unit tangent at its start and at each of them."""
    a, b, n = PLANE_AXES[arc.plane]
    r = arc.radius_mm
    sweep = arc.sweep_rad
    step = 2.0 * np.arccos(max(0.0, 1.0 - sag_mm / r)) if r > sag_mm else np.pi / 2
    k = max(2, int(np.ceil(abs(sweep) / max(step, 1e-6))))
    t = np.arange(0, k + 1) / k
    a0 = np.arctan2(arc.start[b] - arc.center[b], arc.start[a] - arc.center[a])
    out = np.empty((k + 1, 3))
    out[:, a] = arc.center[a] + r * np.cos(a0 + sweep * t)
    out[:, b] = arc.center[b] + r * np.sin(a0 + sweep * t)
    out[:, n] = arc.start[n] + (arc.end[n] - arc.start[n]) * t
    out[-1] = arc.end
    tan = np.empty((k + 1, 3))
    tan[:, a] = -r * sweep * np.sin(a0 + sweep * t)
    tan[:, b] = r * sweep * np.cos(a0 + sweep * t)
    tan[:, n] = arc.end[n] - arc.start[n]
    return out[1:], _unit(tan)


def _path_of(moves: list, sag_mm: float) -> Chain:
    """The chain of moves: its points, each move's blocks of points and tangents after its start (the
    lines' directions at once: a chain can hold tens of thousands of them)."""
    line_at = [i for i, m in enumerate(moves) if not isinstance(m, Arc)]
    line_ends = np.array([moves[i].end for i in line_at], dtype=float).reshape(-1, 3)
    line_dir = _unit(line_ends - np.array([moves[i].start for i in line_at], dtype=float).reshape(-1, 3))
    leave = np.empty((len(moves), 3))  # the direction each move leaves its start in
    leave[line_at] = line_dir
    pts, tans, inside = [np.array([moves[0].start], dtype=float)], [np.zeros((1, 3))], [np.zeros(1, dtype=bool)]
    k = 0
    for i, m in enumerate(moves):
        if isinstance(m, Arc):
            p, tan = _arc_points(m, sag_mm)
            leave[i] = tan[0]
            pts.append(p)
            tans.append(tan[1:])
            inside.append(np.arange(len(p)) < len(p) - 1)
        else:
            pts.append(line_ends[k:k + 1])
            tans.append(line_dir[k:k + 1])
            inside.append(np.zeros(1, dtype=bool))
            k += 1
    ends = np.cumsum([len(p) for p in pts[1:]])
    tan_in = np.vstack(tans)
    tan_out = tan_in.copy()  # at the last point, the direction it arrives in
    tan_out[np.r_[0, ends[:-1]]] = leave
    tan_in[0] = tan_out[0]
    sag = sag_mm if any(isinstance(m, Arc) for m in moves) else 0.0
    return Chain(tuple(moves), np.vstack(pts), ends, sag, tan_in, tan_out, np.concatenate(inside))


def sub_chain(chain: Chain, first: int, last: int) -> Chain:
    """Moves first..last-1 of a chain as a chain of their own (its points and tangents)."""
    a = 0 if first == 0 else int(chain.ends[first - 1])
    b = int(chain.ends[last - 1]) + 1
    moves = chain.moves[first:last]
    tan_in, tan_out = chain.tan_in[a:b].copy(), chain.tan_out[a:b].copy()
    tan_in[0], tan_out[-1] = tan_out[0], tan_in[-1]  # at its ends, the direction there (as _path_of)
    sag = chain.sag_mm if any(isinstance(m, Arc) for m in moves) else 0.0
    return Chain(moves, chain.points[a:b], chain.ends[first:last] - a, sag, tan_in, tan_out, chain.on_arc[a:b])


def same_feed(a: float, b: float, reach_mm_s: float | None) -> bool:
    """Do two programmed feeds move the machine alike? Equal, or both at or above the fastest path
    speed its axes can reach together (neither ever limits the motion)."""
    return a == b or (reach_mm_s is not None and min(a, b) >= reach_mm_s)


def _continues(a, b, reach_mm_s: float | None) -> bool:
    return (b.start == a.end and same_feed(a.feed_mm_s, b.feed_mm_s, reach_mm_s) and b.path == a.path
            and not b.path.exact_stop and not (isinstance(b, Arc) and b.turns))


def split_chains(entities: Iterable, tol_mm: float, joinable: Callable[[object, object], bool] | None = None,
                 reach_mm_s: float | None = None) -> list[Chain]:
    """Every chain of two moves or more, in program order; zero-length moves end a chain. reach_mm_s:
    the machine's fastest path speed (same_feed), None: feeds must be equal."""
    runs: list[list] = []
    current: list = []
    for e in entities:
        movable = isinstance(e, (Line, Arc)) and not e.path.exact_stop and e.start != e.end
        if not movable or (isinstance(e, Arc) and e.turns):
            current = []
            continue
        if current and _continues(current[-1], e, reach_mm_s) and (joinable is None or joinable(current[-1], e)):
            current.append(e)
        else:
            current = [e]
            runs.append(current)
    sag = ARC_SAG_FRACTION * tol_mm
    return [_path_of(r, sag) for r in runs if len(r) >= 2]


def turn_rad(points: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Turning angle of the polyline at the vertices `at` (interior indices)."""
    d_in = points[at] - points[at - 1]
    d_out = points[at + 1] - points[at]
    n = np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1)
    c = np.einsum("ij,ij->i", d_in, d_out) / np.where(n > 0, n, 1.0)
    return np.where(n > 0, np.arccos(np.clip(c, -1.0, 1.0)), np.pi)


def rounding_radius_mm(turn: np.ndarray, tol_mm: float) -> np.ndarray:
    """The largest circular rounding of a corner turning by `turn` that stays within tol_mm of it."""
    excess = 1.0 / np.cos(np.minimum(turn, np.pi - 1e-9) / 2.0) - 1.0
    return np.where(excess > 0, tol_mm / np.maximum(excess, 1e-300), np.inf)


def sharp_vertices(chain: Chain, tol_mm: float, accel_mm_s2: float, max_feed_mm_s: float,
                   corner_deg: float = DEFAULT_CORNER_DEG) -> np.ndarray:
    """Indices into chain.points of the move ends that stay sharp corners (see the module docstring)."""
    at = chain.ends[:-1]
    turn = turn_rad(chain.points, at)
    feed = min(chain.moves[0].feed_mm_s, max_feed_mm_s)
    too_fast = feed**2 > accel_mm_s2 * rounding_radius_mm(turn, tol_mm)
    return at[(turn > np.radians(corner_deg)) & too_fast]
