"""One chain -> the fewest blocks: which stretches become G06.2 groups, and their curves.

The chain is cut at its sharp vertices (ipo.fit.chains) into sections. Each section
is fitted on its own (ipo.fit.knot_fit: a clamped spline from vertex to vertex), so
sections join with a knot of multiplicity = degree: the curve passes exactly
through the sharp vertex and the corner stays a corner. A section then costs its
new control points inside a group, or its moves as they are written; opening and
closing a group costs its first block, the degree + 1 closing knot blocks and the
block that restores the motion mode. A dynamic programme over the sections picks
the cheapest mix (G01/G02 kept, sections in groups), so a straight between two
sharp corners stays inside a group where leaving it would cost more blocks.

Written block count of one G06.2 group with m control points and degree p:
1 (the P/F block, control point 0 = the current position) + m - 1 + (p + 1) knot
blocks, plus one block restoring G1/G2/G3 where the program needs it.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ipo.fit.arcs import OneMove
from ipo.fit.chains import Chain, sharp_vertices, turn_rad
from ipo.fit.rational import RationalFit
from ipo.fit.tolerance import MAX_CTRL, FitSettings, fewest_ctrl
from ipr.entities import Arc

MAX_PARTS = 16  # data points added on one segment at most
MAX_FIT_POINTS = 400  # a longer piece is split before any fit is tried
SPLIT_MIN_MOVES = 5  # a piece is split in two only if both halves keep this many moves


@dataclass(frozen=True, slots=True)
class FitOptions:
    tol_mm: float  # the fit's own bound: the user's tolerance less rounding (and arc chords, ipo.fit.chains)
    degree: int
    accel_mm_s2: float  # the machine's smallest axis acceleration: the sharp-corner test
    max_feed_mm_s: float
    corner_deg: float
    joins: bool = True  # pieces may share a group (G06.2); False: each fitted piece is its own (G5.2)
    restore_blocks: int = 1  # a block restoring G1/G2/G3 after a group that ends the chain (0 or 1)
    plane: str = "XY"  # the program's plane there (G17/G18/G19): arcs are written in it where the run lies in it
    arcs: bool = True  # runs of G1 moves may be written as one G1 line or G2/G3 arc (ipo.fit.arcs; G06.2 only)


@dataclass(frozen=True, slots=True)
class Span:
    """Moves first..last-1 of the chain: a fitted curve (fit is not None), G1 lines and G2/G3 arcs
    (one_moves, ipo.fit.arcs) or kept as written."""

    first: int
    last: int
    fit: RationalFit | None = None
    data: np.ndarray | None = None  # the path the fit was checked against (polyline, densified)
    deviation_mm: float = 0.0
    double_knots: int = 0  # knots of multiplicity 2 where the curve stays tangent (ipo.fit.weights), not corners
    one_moves: tuple[OneMove, ...] = ()  # each a G1 line or G2/G3 arc, in path order

    @property
    def kept(self) -> bool:
        return self.fit is None and not self.one_moves

    def corners(self) -> int:
        """The fit's corners: its inner knots of multiplicity = degree, less the double knots."""
        p = self.fit.degree
        return (int(np.sum(np.diff(self.fit.knots) == 0)) - 2 * p) // (p - 1) - self.double_knots if p > 1 else 0


def sharp_of(chain: Chain, opt: FitOptions) -> np.ndarray:
    """The chain's vertices that stay sharp under opt (ipo.fit.chains.sharp_vertices)."""
    return sharp_vertices(chain, opt.tol_mm, opt.accel_mm_s2, opt.max_feed_mm_s, opt.corner_deg)


def group_overhead(degree: int) -> int:
    return degree + 3


def densify(q: np.ndarray, min_points: int) -> np.ndarray:
    """The polyline with points added on segments longer than its median one (a spline between
    two far-apart data points is not held to the segment)."""
    seg = np.linalg.norm(np.diff(q, axis=0), axis=1)
    h = max(float(np.median(seg)), float(seg.sum()) / (3 * MAX_CTRL), 1e-9)
    parts = np.clip(np.ceil(seg / h).astype(int), 1, MAX_PARTS)
    if parts.sum() + 1 < min_points:
        parts = parts + int(np.ceil((min_points - parts.sum() - 1) / len(seg)))
    t = np.concatenate([np.arange(k) / k for k in parts])
    owner = np.repeat(np.arange(len(seg)), parts)
    return np.vstack([q[owner] + t[:, None] * (q[owner + 1] - q[owner]), q[-1:]])


def fit_section(q: np.ndarray, opt: FitOptions, max_ctrl: int) -> tuple[RationalFit, np.ndarray, float] | None:
    """The fewest control points for which 001's rational fit of q (ends pinned) is within opt.tol_mm
    both ways, the data it was checked on and its deviation; None if none within max_ctrl."""
    p = opt.degree
    data = densify(q, 2 * (p + 1))
    found = fewest_ctrl(data, FitSettings(opt.tol_mm, p), min(max_ctrl, MAX_CTRL, len(data)))
    if found is None:
        return None
    return found[0], data, found[1]


def straight(a: np.ndarray, b: np.ndarray, degree: int) -> tuple[RationalFit, np.ndarray, float]:
    """A G01 move as one Bézier span inside a group: control points evenly on the segment (exact)."""
    t = np.linspace(0.0, 1.0, degree + 1)
    pts = a[None, :] + t[:, None] * (b - a)[None, :]
    knots = np.concatenate([np.zeros(degree + 1), np.ones(degree + 1)])
    return RationalFit(degree, knots, np.ones(degree + 1), pts, np.array([0.0, 1.0]), np.empty(0), True), \
        np.vstack([a, b]), 0.0


def join(fits: list[RationalFit]) -> RationalFit:
    """Section fits that meet end to start -> one curve, a knot of multiplicity p at each joint
    (each section's parameters continue where the previous one's end). A rational curve is unchanged
    when all its weights scale together, so each section's weights are scaled to meet the previous
    section's last weight at the shared control point; knots start at 0, the largest weight is 1."""
    p = fits[0].degree
    start = fits[0].knots[0]
    knots, ctrl, params = [fits[0].knots[:-1] - start], [fits[0].points], [fits[0].params - start]
    weights = [fits[0].weights]
    end = fits[0].knots[-1] - start
    for f in fits[1:]:
        shift = end - f.knots[0]
        knots.append(f.knots[p + 1:-1] + shift)
        ctrl.append(f.points[1:])
        params.append(f.params[1:] + shift)
        weights.append(f.weights[1:] * (weights[-1][-1] / f.weights[0]))
        end = f.knots[-1] + shift
    knots.append([end])
    w = np.concatenate(weights)
    return RationalFit(p, np.concatenate(knots), w / w.max(), np.vstack(ctrl), np.concatenate(params),
                       np.empty(0), True)


def _pieces(chain: Chain, first: int, last: int, opt: FitOptions) -> list[tuple]:
    """Moves first..last-1 (between sharp vertices) as pieces (first, last, fit or None, all moves
    lines): one fit where it is within MAX_CTRL and not worth splitting, else two parts, cut at
    the sharpest move end (the middle where turns are even), fitted the same way."""
    a = 0 if first == 0 else int(chain.ends[first - 1])
    b = int(chain.ends[last - 1])
    moves = last - first
    arcs = sum(isinstance(m, Arc) for m in chain.moves[first:last])
    has_arc = arcs > 0
    # a fit with more control points than moves (an arc: degree + 1 of them) hardly ever pays, and
    # fewest_ctrl tries its largest count first: a near-interpolating fit wiggles out of tolerance
    # and would end the search
    useful = min(MAX_CTRL, max(moves + opt.degree * arcs, opt.degree + 2))
    found = None
    if 2 <= b - a <= MAX_FIT_POINTS:
        # arcs are data as chords: their sag comes off the tolerance
        own = replace(opt, tol_mm=opt.tol_mm - chain.sag_mm) if has_arc else opt
        found = fit_section(chain.points[a:b + 1], own, useful)
    whole = [(first, last, found, not has_arc)]
    if moves < 2 * SPLIT_MIN_MOVES or (found is not None and len(found[0].points) <= MAX_CTRL // 2):
        return whole
    lo, hi = first + SPLIT_MIN_MOVES, last - SPLIT_MIN_MOVES
    cut = (first + last) // 2
    if hi > lo:  # the sharpest move end, where it stands out
        turn = turn_rad(chain.points, chain.ends[lo - 1:hi])
        k = int(np.argmax(turn))
        cut = lo + k if turn[k] > 2.0 * np.median(turn) + 1e-3 else cut
    halves = _pieces(chain, first, cut, opt) + _pieces(chain, cut, last, opt)
    return halves if found is None or _cost(halves, opt.degree) < _cost(whole, opt.degree) else whole


def _cost(pieces, degree: int) -> float:
    return sum(_in_group(pc, degree) for pc in pieces)


def _in_group(piece, degree: int) -> float:
    first, last, found = piece[:3]
    if found is not None:
        return len(found[0].points) - 1
    return degree * (last - first) if piece[3] else float("inf")


def plan_chain(chain: Chain, opt: FitOptions) -> list[Span]:
    """The chain as consecutive spans, fitted or kept, with the fewest blocks (see the module doc)."""
    p = opt.degree
    sharp = sharp_of(chain, opt)
    move_at = {int(e): i + 1 for i, e in enumerate(chain.ends)}  # point index -> moves up to it
    cuts = [0] + [move_at[int(v)] for v in sharp] + [len(chain.moves)]
    pieces = []
    for first, last in zip(cuts[:-1], cuts[1:]):
        pieces += _pieces(chain, first, last, opt)
    if not opt.joins:  # G5.2: m control points cost m blocks (m - 1 and G5.3), no knots, no joints
        return [Span(f, l, found[0], found[1], found[2]) if found and len(found[0].points) < l - f else Span(f, l)
                for f, l, found, _ in pieces]
    overhead = group_overhead(p)
    # dynamic programme: the fewest blocks up to each piece, ending outside / inside a group
    inf = float("inf")
    out, inn = [0.0], [inf]
    came_out, came_in = [], []
    for pc in pieces:
        keep, curve = pc[1] - pc[0], _in_group(pc, p)
        came_out.append(out[-1] > inn[-1])  # True: a group closes before this piece
        came_in.append(inn[-1] > out[-1] + overhead)  # True: a group opens at this piece
        out.append(min(out[-1], inn[-1]) + keep)
        inn.append(min(inn[-1], out[-2] + overhead) + curve)
    inside = inn[-1] < out[-1]
    chosen = []
    for s in range(len(pieces) - 1, -1, -1):
        chosen.append(inside)
        inside = (not came_in[s]) if inside else came_out[s]
    chosen.reverse()
    spans: list[Span] = []
    s = 0
    while s < len(pieces):
        e = s
        while e < len(pieces) and chosen[e] == chosen[s]:
            e += 1
        first, last = pieces[s][0], pieces[e - 1][1]
        if chosen[s]:
            parts = []
            for f, l, found, _ in pieces[s:e]:
                if found is not None:
                    parts.append(found)
                else:
                    parts += [straight(np.array(m.start), np.array(m.end), p) for m in chain.moves[f:l]]
            fit = join([f for f, _, _ in parts])
            data = np.vstack([parts[0][1]] + [d[1:] for _, d, _ in parts[1:]])
            spans.append(Span(first, last, fit, data, max(d for _, _, d in parts)))
        else:
            spans.append(Span(first, last))
        s = e
    return spans
