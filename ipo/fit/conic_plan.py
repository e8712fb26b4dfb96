"""One chain -> the fewest written blocks with rational quadratic (conic) spans.

The candidates are junctions (ipo.fit.conic): every vertex of the chain's path with a
smooth tangent (the exact one inside an arc, else the tangent of the parabola through it
and its neighbours), with its incoming and outgoing directions as well where the path
turns there, and the middle of every line segment with the segment's direction (where
a corner is rounded, or the path has an inflection, the junction sits on the leg). A
shortest path over them counts written blocks (ipo.fit.quadratic writes one G06.2 group
of degree 2 for each stretch inside a group):

- a conic span from one junction to a later one: +1 (its control point C);
- a corner (C0, a knot of multiplicity 2) at a vertex, from one of its junctions to
  another: +1 (the vertex is a control point); the only way past a sharp vertex
  (ipo.fit.chains) inside a group;
- opening a group at a move end: +1 (the G06.2 block, control point 0 = where the
  machine is); closing it at a move end: +1 for its last control point, + 3 closing
  knots (+1 where the program needs G1/G2/G3 restored after the chain);
- a move kept as written, between two move ends outside a group: +1;
- a run of G1 moves as one G1 line or one G2/G3 arc (ipo.fit.arcs), between two move
  ends outside a group with no sharp vertex inside: +1 (+1 where it ends the chain as an arc and
  the program needs G1 restored after it); from each move end, runs are tried ever longer until
  ONE_MOVE_FAILS lengths in a row fail, except to move ends already reached with no more blocks
  (g1_contour, 10000 chords of one circle: 23 -> 2.5 s of plan at 10 um, the same plan).

The farthest start of a span into a junction is searched from the one the previous
junctions reached (doubling steps, then halving), so each junction costs a few span tests,
not one per earlier junction; every start between that one and the junction is then tried
as well where the way to it is cheap enough to help (spans that fit from far usually fit
from nearer, and the cheapest way in need not come from the farthest start: on g1_lhchips4
at 10 um, 4645 -> 4257 written blocks, for about the same plan time). The plan is
near-shortest, not provably shortest (trying all starts up to 80 positions back plans 26 blocks
fewer there, for 3-4 times the plan time).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ipo.fit.arcs import ARC, NONE, one_move
from ipo.fit.conic import MAX_SAMPLES, control_point, fitting_rho, load_path
from ipo.fit.weights import STATE, follow, may_continue

DEGREE = 2
OPEN_COST = 1
CORNER_COST = 1
CLOSE_COST = 1 + DEGREE + 1  # the last control point and the closing knots
CORNER_OPTION_RAD = np.radians(0.5)
LONG_LEG = 1.5  # a segment this much longer than its shorter neighbour gets a junction at its middle  # a vertex that turns more also gets its in/out directions as junctions
MAX_SPAN_POINTS = 400  # path points inside one span at most
MAX_FAILS = 8  # spans from the nearest junctions back that may fail before a junction gives up
MAX_ONE_MOVE_POINTS = 400  # moves one line or arc replaces at most
ONE_MOVE_FAILS = 3  # longer runs tried after this many lengths in a row are not one move
INF = 1 << 40
SLOTS = 6  # junctions per vertex at most (junctions)
BOTH, ARRIVE, LEAVE = 0, 1, 2  # what spans a junction may take: a sharp corner's sides are one-way


@dataclass(frozen=True, slots=True)
class Junctions:
    """Candidate junctions in path order: `pos` is the vertex index (vertex nodes) or i + 0.5
    (the middle of segment i); `vertex` is -1 for segment nodes."""

    pos: np.ndarray
    point: np.ndarray  # (N, 3) mm
    tangent: np.ndarray  # (N, 3) unit
    vertex: np.ndarray  # (N,) int
    role: np.ndarray  # (N,) BOTH, or at a sharp vertex ARRIVE (its incoming directions) or LEAVE


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def junctions(points: np.ndarray, tan_in: np.ndarray, tan_out: np.ndarray, on_arc: np.ndarray,
              sharp: np.ndarray) -> Junctions:
    """The candidates of a path (see the module doc). tan_in/tan_out: the exact direction in which
    the path arrives at / leaves each point (lines: their direction; arcs: the arc's tangent);
    on_arc: points inside an arc (one exact tangent); sharp: vertices kept sharp."""
    n = len(points) - 1
    d = np.diff(points, axis=0)
    h = np.linalg.norm(d, axis=1)
    u = d / h[:, None]
    # tangents of the parabola through three points: at the middle one, and at the first (leaving,
    # `ahead`) or the last (arriving, `behind`): the smooth directions on either side of a corner
    smooth, ahead, behind = np.empty_like(points), tan_out.copy(), tan_in.copy()
    if n >= 2:
        a, b = h[:-1, None], h[1:, None]
        smooth[1:-1] = _unit(b * u[:-1] + a * u[1:])
        ahead[:-2] = _unit((2 * a + b) * u[:-1] - a * u[1:])
        behind[2:] = _unit((2 * b + a) * u[1:] - b * u[:-1])
        smooth[0], smooth[-1] = ahead[0], behind[-1]
    else:
        smooth[:] = u[0]
    smooth[on_arc] = tan_out[on_arc]
    chord = np.zeros(n + 1, dtype=bool)  # an arc's chord leaves / arrives: its exact tangent is known
    chord[:-1] |= on_arc[1:]
    ahead[chord] = tan_out[chord]
    chord[:] = False
    chord[1:] |= on_arc[:-1]
    behind[chord] = tan_in[chord]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", tan_in, tan_out), -1.0, 1.0))
    leg = _leg_junctions(points, u, h, turn, on_arc)
    # up to SLOTS junctions per vertex, in this order: the smooth or arc tangent; leaving: tan_out, then
    # `ahead` at a corner; arriving: tan_in, then `behind`; the middle of the segment after it
    idx = np.arange(n + 1)
    corner = ~on_arc & ((turn > CORNER_OPTION_RAD) | sharp)
    first, last = idx == 0, idx == n
    leave = np.where(sharp, LEAVE, BOTH)
    arrive = np.where(sharp, ARRIVE, BOTH)
    take = np.zeros((n + 1, SLOTS), dtype=bool)
    take[:, 0] = on_arc | ~sharp
    take[:, 1] = ~on_arc & (first | corner)
    take[:, 2] = corner & (idx > 0) & (idx < n - 1)
    take[:, 3] = ~on_arc & (last | corner) & ~first
    take[:, 4] = corner & (idx > 1) & (idx < n)
    take[:-1, 5] = leg
    tan = np.stack([np.where(on_arc[:, None], tan_out, smooth), tan_out, ahead, tan_in, behind,
                    np.vstack([u, u[-1:]])], axis=1)
    pt = np.repeat(points[:, None, :], SLOTS, axis=1)
    pt[:-1, 5] = 0.5 * (points[:-1] + points[1:])
    pos = np.repeat(idx[:, None].astype(float), SLOTS, axis=1)
    pos[:, 5] += 0.5
    vert = np.repeat(idx[:, None], SLOTS, axis=1)
    vert[:, 5] = -1
    role = np.stack([np.full(n + 1, BOTH), leave, leave, arrive, arrive, np.full(n + 1, BOTH)], axis=1)
    return Junctions(pos[take], pt[take], _unit(tan[take]), vert[take].astype(np.int64), role[take].astype(np.int64))


def _leg_junctions(points: np.ndarray, u: np.ndarray, h: np.ndarray, turn: np.ndarray,
                   on_arc: np.ndarray) -> np.ndarray:
    """The line segments whose middle is a junction: where a corner may be rounded (an end turns by
    more than CORNER_OPTION_RAD), the path has an inflection (it turns one way before the segment
    and the other after), or the segment is long beside its neighbours. Not on arcs' chords: an
    arc's points carry its exact tangents."""
    n = len(h)
    leg = np.zeros(n, dtype=bool)
    leg |= (turn[:-1] > CORNER_OPTION_RAD) | (turn[1:] > CORNER_OPTION_RAD)
    if n >= 3:
        bend = np.cross(u[:-1], u[1:])  # at the inner vertices 1..n-1
        leg[1:-1] |= np.einsum("ij,ij->i", bend[:-1], bend[1:]) < 0.0
        leg[1:-1] |= h[1:-1] > LONG_LEG * np.minimum(h[:-2], h[2:])
    return leg & ~on_arc[:-1] & ~on_arc[1:]


class Nodes(NamedTuple):
    """The junctions as the kernels read them (Junctions' arrays) and the span rule."""

    pos: np.ndarray
    pt: np.ndarray
    tan: np.ndarray
    role: np.ndarray
    tol_mm: float
    gap_mm: float


class MoveRule(NamedTuple):
    """Where a run may be one move (ipo.fit.arcs): line_run[i] numbers the run of G1 moves
    that the move ending at point i belongs to (-1: the move is an arc, or i is not a move end), axes
    the plane's (a, b, normal) indices, tol_mm the bound."""

    line_run: np.ndarray
    axes: np.ndarray
    tol_mm: float


class Found(NamedTuple):
    """Per junction, the cheapest way found to it with a group open (plan_kernel's doc), and the
    kernels' scratch arrays."""

    ins: np.ndarray
    ins_from: np.ndarray
    ctrl: np.ndarray
    rho: np.ndarray
    state: np.ndarray
    double: np.ndarray
    curve: np.ndarray
    path: np.ndarray
    c: np.ndarray
    new: np.ndarray


@njit(cache=True)
def _relax(j, z, q, nodes, found):
    """Test the span from junction j to junction z and take it where it makes z cheaper; whether
    the span fits (whatever it costs)."""
    pos, pt, tan, role, tol_mm, gap_mm = nodes
    ins, ins_from, ctrl, rho, state, double, curve, path, c, new = found
    if role[j] == ARRIVE or role[z] == LEAVE:
        return False
    lo = int(np.floor(pos[j])) + 1
    count = int(np.ceil(pos[z])) - 1 - lo + 3
    if not control_point(pt[j], tan[j], pt[z], tan[z], gap_mm, c):
        return False
    load_path(q, pt[j], pt[z], lo, count, path)
    r = fitting_rho(path, count, c, tol_mm, curve)
    if r <= 0.0:
        return False
    if ins[j] >= INF:  # nothing reaches j (yet): no state to follow
        return True
    cost = follow(ins_from[j] < 0, ctrl[j], pt[j], rho[j], state[j], c, r, new)
    if cost > 0 and ins[j] + cost < ins[z]:
        ins[z] = ins[j] + cost
        ins_from[z] = j
        ctrl[z] = c
        rho[z] = r
        state[z] = new
        double[z] = cost == 2
    return True


@njit(cache=True)
def _may_help(j, z, nodes, found):
    """Could the span from junction j make junction z cheaper, where it would at one block (the caller
    knows: ins[j] + 1 < ins[z])? A bound before _relax's test of the path, most of the plan's time: a
    span that cannot continue the weights' run at j costs two blocks, whatever its weight
    (ipo.fit.weights.may_continue). On gcmc's trochoidal.ngc at 10 um 819,590 of the 843,489 nearer
    starts tested fit, but with a double knot, no cheaper: plan 15.7 -> 4.4 s, the same plan."""
    pos, pt, tan, role, tol_mm, gap_mm = nodes
    ins, ins_from, ctrl, rho, state, double, curve, path, c, new = found
    if ins[j] + 2 < ins[z] or ins_from[j] < 0:
        return True
    if role[j] == ARRIVE or role[z] == LEAVE or not control_point(pt[j], tan[j], pt[z], tan[z], gap_mm, c):
        return False
    return may_continue(ctrl[j], pt[j], rho[j], state[j], c, new)


@njit(cache=True)
def _relax_at(g, z, group, q, nodes, found):
    """_relax from every junction of position g; whether any span fits (once one does, only those
    that may help are tested)."""
    fits = False
    ins = found.ins
    for j in range(group[g], group[g + 1]):
        if (not fits or (ins[j] + 1 < ins[z] and _may_help(j, z, nodes, found))) and _relax(j, z, q, nodes, found):
            fits = True
    return fits


@njit(cache=True)
def _one_moves(q, v, rule, sharp, restore_cost, out, out_from, kind, centre):
    """Runs from move end v as one move each (MoveRule), where they make their end cheaper."""
    line_run, axes, tol_mm = rule
    n_pts = q.shape[0]
    if v + 1 >= n_pts or line_run[v + 1] < 0:
        return
    fails = 0
    w = v + 2
    while w < n_pts and w - v <= MAX_ONE_MOVE_POINTS and line_run[w] == line_run[v + 1] and not sharp[w - 1]:
        if out[v] + 1 < out[w]:  # else no move from v makes w cheaper: not tested, not counted
            k = one_move(q, v, w, axes[0], axes[1], axes[2], tol_mm, centre)
            if k == NONE:
                fails += 1
                if fails > ONE_MOVE_FAILS:
                    return
            else:
                fails = 0
                cost = out[v] + 1 + (restore_cost if k == ARC and w == n_pts - 1 else 0)
                if cost < out[w]:
                    out[w] = cost
                    out_from[w] = -1 - v
                    kind[w] = k
        w += 1


@njit(cache=True)
def plan_kernel(q, nodes, vert, is_end, sharp, restore_cost, rule):
    """The shortest path of the module doc over the junctions and span rule nodes (Nodes). Returns (out, out_from, ins, ins_from, ctrl, rho, double,
    state, kind): out[v] the fewest blocks up to move end v with no group open, out_from[v] >= 0 the
    junction whose group closed there, -1 - e: from move end e, kept (kind[v] NONE) or as one
    move (kind[v] STRAIGHT or ARC, ipo.fit.arcs, where rule allows, MoveRule); ins[k] with a group
    open at junction k, ins_from[k] >= 0 the junction its span came from, -1: opened there,
    -2 - z: a corner from junction z; ctrl, rho: the control point and weight of that span;
    double: the span starts with a knot of multiplicity 2 (ipo.fit.weights), one block more;
    state: the weights' state there (ipo.fit.weights)."""
    pos, role = nodes.pos, nodes.role
    n_nodes = pos.shape[0]
    n_pts = q.shape[0]
    out = np.full(n_pts, INF, dtype=np.int64)
    out_from = np.full(n_pts, -INF, dtype=np.int64)
    kind = np.zeros(n_pts, dtype=np.int64)
    centre = np.empty(3)
    ins = np.full(n_nodes, INF, dtype=np.int64)
    ins_from = np.full(n_nodes, -INF, dtype=np.int64)
    ctrl = np.zeros((n_nodes, 3))
    rho = np.ones(n_nodes)
    state = np.zeros((n_nodes, STATE))
    double = np.zeros(n_nodes, dtype=np.bool_)
    curve = np.empty((MAX_SAMPLES, 3))
    path = np.empty((MAX_SPAN_POINTS + 2, 3))
    c = np.empty(3)
    new = np.empty(STATE)
    found = Found(ins, ins_from, ctrl, rho, state, double, curve, path, c, new)
    out[0] = 0
    group = np.empty(n_nodes + 1, dtype=np.int64)  # first junction of each position
    at_group = np.empty(n_nodes, dtype=np.int64)
    n_groups = 0
    for i in range(n_nodes):
        if i == 0 or pos[i] != pos[i - 1]:
            group[n_groups] = i
            n_groups += 1
        at_group[i] = n_groups - 1
    group[n_groups] = n_nodes
    lowest = 0  # position index: no span starts before the last sharp vertex
    reach = -1  # the farthest start of the previous position
    k = 0
    while k < n_nodes:
        gk = at_group[k]  # the position's index; its junctions are group[gk]..group[gk + 1] - 1
        e = group[gk + 1]
        while lowest < gk and pos[k] - pos[group[lowest]] > MAX_SPAN_POINTS:
            lowest += 1
        far = -1
        for z in range(k, e):
            if vert[z] >= 0 and is_end[vert[z]] and role[z] != ARRIVE and out[vert[z]] + OPEN_COST < ins[z]:
                ins[z] = out[vert[z]] + OPEN_COST
                ins_from[z] = -1
                state[z] = 0.0
                rho[z] = 0.0  # no span before: follow's sign that the group opens here
            # the farthest position with a start that fits: from the previous position's, doubling
            # steps back while spans fit (or forward while they do not), then halving
            good, bad = -1, lowest - 1
            guess = min(max(reach, lowest), gk - 1)
            if reach >= 0 and _relax_at(guess, z, group, q, nodes, found):
                good = guess
            else:
                step = 1
                bad = guess
                while bad + step < gk and not _relax_at(bad + step, z, group, q, nodes, found):
                    bad += step
                    step *= 2
                if bad + step < gk:
                    good = bad + step
                else:  # the nearest few positions, one by one
                    p = gk - 1
                    while p > max(bad, gk - 1 - MAX_FAILS) and good < 0:
                        if _relax_at(p, z, group, q, nodes, found):
                            good = p
                        p -= 1
                    bad = lowest - 1
                    if good < 0:
                        continue
            if good == guess:
                step = 1
                while good - step >= lowest:
                    if not _relax_at(good - step, z, group, q, nodes, found):
                        bad = good - step
                        break
                    good -= step
                    step *= 2
            while good - bad > 1:
                mid = (good + bad) // 2
                if _relax_at(mid, z, group, q, nodes, found):
                    good = mid
                else:
                    bad = mid
            for g in range(good + 1, gk):  # the nearer starts, where they could make z cheaper
                for j in range(group[g], group[g + 1]):
                    if ins[j] + 1 < ins[z] and _may_help(j, z, nodes, found):
                        _relax(j, z, q, nodes, found)
            far = good if far < 0 else min(far, good)
        if far >= 0:
            reach = far
        v = vert[k]
        if v >= 0:
            best = k
            for z in range(k, e):
                if ins[z] < ins[best]:
                    best = z
            for z in range(k, e):
                if ins[best] + CORNER_COST < ins[z]:
                    ins[z] = ins[best] + CORNER_COST
                    ins_from[z] = -2 - best
                    state[z] = state[best]
                    ctrl[z] = ctrl[best]
                    rho[z] = rho[best]
            if is_end[v]:
                close = CLOSE_COST + (restore_cost if v == n_pts - 1 else 0)
                if ins[best] + close < out[v]:
                    out[v] = ins[best] + close
                    out_from[v] = best
                    kind[v] = NONE
                nxt = v + 1
                while nxt < n_pts and not is_end[nxt]:
                    nxt += 1
                if nxt < n_pts and out[v] + 1 < out[nxt]:
                    out[nxt] = out[v] + 1
                    out_from[nxt] = -1 - v
                    kind[nxt] = NONE
                _one_moves(q, v, rule, sharp, restore_cost, out, out_from, kind, centre)
            if sharp[v]:
                lowest = gk
        k = e
    return out, out_from, ins, ins_from, ctrl, rho, double, state, kind
