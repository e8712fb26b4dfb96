"""One chain -> spans of `vcnc fit` with rational quadratic groups: the plan of ipo.fit.conic_plan
walked back into groups (their curves by ipo.fit.weights), runs written as one G1 line or G2/G3 arc
(ipo.fit.arcs) and moves kept as written, and each data point's parameter on its group's curve (for
the checks that use them).
"""
from __future__ import annotations

import numpy as np

from ipo.fit.arcs import NONE, fit_move
from ipo.fit.chains import Chain
from ipo.fit.compiled import foot_params
from ipo.fit.conic_plan import DEGREE, MoveRule, Nodes, junctions, plan_kernel
from ipo.fit.groups import Span, sharp_of
from ipo.fit.move_runs import free_junctions
from ipo.fit.rational import RationalFit, SpanPolynomials
from ipo.fit.weights import X, spline
from ipr.entities import PLANE_AXES, Line

TEST_MARGIN = 0.05  # spans are tested this fraction inside the tolerance (the joined curve moves a little)
GAP_FRACTION = 0.1  # of the tolerance: how far apart two tangent lines of a span may pass (3-D)


def data_params(fit: RationalFit, data: np.ndarray, brackets: np.ndarray) -> np.ndarray:
    """Each data point's parameter: the nearest curve point within its bracket (lo, hi)."""
    spans = SpanPolynomials(fit.knots, fit.degree)
    poly = spans.homogeneous(fit.points * fit.weights[:, None], fit.weights)
    u = foot_params(poly, spans.starts, np.ascontiguousarray(data), brackets[:, 0].copy(),
                    brackets[:, 1].copy(), 40)
    u[0], u[-1] = fit.knots[0], fit.knots[-1]
    return np.maximum.accumulate(u)


def _group_items(back: tuple, close_node: int) -> tuple[int, list, list]:
    """Walk a group back from the junction where it closes: its opening vertex, its items in
    order and the path positions of its junctions (start, then each span's end)."""
    _, _, _, ins_from, ctrl, rho, double, state, _, pos, pt, vert = back
    items, at = [], []
    k = close_node
    while True:
        g = int(ins_from[k])
        if g >= 0:
            items.append(("span", ctrl[k].copy(), float(rho[k]), pt[k].copy(), bool(double[k]), float(state[k][X])))
            at.append(pos[k])
            k = g
        elif g == -1:
            items.append(("start", pt[k].copy()))
            at.append(pos[k])
            return int(vert[k]), items[::-1], at[::-1]
        else:
            items.append(("corner", pt[k].copy()))
            k = -2 - g


def plan_chain_conic(chain: Chain, opt) -> list[Span]:
    """The chain as consecutive spans, groups of conic spans or moves kept, with the fewest blocks
    (ipo.fit.conic_plan); opt: ipo.fit.groups.FitOptions (tol_mm, the machine for sharp corners)."""
    n = len(chain.points) - 1
    sharp = np.zeros(n + 1, dtype=bool)
    sharp[sharp_of(chain, opt)] = True
    cand = junctions(chain.points, chain.tan_in, chain.tan_out, chain.on_arc, sharp)
    is_end = np.zeros(n + 1, dtype=bool)
    is_end[0] = True
    is_end[chain.ends] = True
    tol = opt.tol_mm * (1.0 - TEST_MARGIN) - chain.sag_mm
    nodes = Nodes(cand.pos, cand.point, cand.tangent, cand.role, tol, GAP_FRACTION * opt.tol_mm)
    # a run's one move is checked exactly (ipo.fit.arcs) and loses only its centre's rounding as written
    runs = _line_runs(chain) if opt.arcs else np.full(len(chain.points), -1, dtype=np.int64)
    rule = MoveRule(runs, np.array(PLANE_AXES[opt.plane], dtype=np.int64), opt.tol_mm)
    result = plan_kernel(chain.points, nodes, cand.vertex, is_end, sharp, opt.restore_blocks, rule)
    back = result + (cand.pos, cand.point, cand.vertex)
    out_from, kind = result[1], result[8]
    move_at = {int(e): i + 1 for i, e in enumerate(chain.ends)}
    move_at[0] = 0
    spans: list[Span] = []
    v = n
    while v > 0:
        f = int(out_from[v])
        if f < 0:
            e = -1 - f
            if kind[v] == NONE:
                spans.append(Span(move_at[e], move_at[v]))
            else:
                move = fit_move(chain.points[e:v + 1].copy(), opt.plane, opt.tol_mm)
                spans.append(Span(move_at[e], move_at[v], data=move.path, one_moves=(move,)))
            v = e
            continue
        a, items, at = _group_items(back, f)
        points, weights, knots = spline(items, DEGREE)
        fit = RationalFit(DEGREE, knots, weights, points, np.empty(0), np.empty(0), True)
        data = chain.points[a:v + 1]
        doubles = sum(1 for item in items if item[0] == "span" and item[4])
        spans.append(Span(move_at[a], move_at[v], fit_params(fit, data, a, at), data, double_knots=doubles))
        v = a
    spans = _merge_kept(spans[::-1])
    return _merge_kept(free_junctions(chain, spans, opt, sharp)) if opt.arcs else spans


def fit_params(fit: RationalFit, data: np.ndarray, first: int, at: list) -> RationalFit:
    """The fit with each data point's parameter (its foot within the span its vertex lies in)."""
    t = np.concatenate([[0.0], np.unique(fit.knots[DEGREE:-DEGREE])[1:]])
    at = np.asarray(at)
    idx = np.arange(first, first + len(data), dtype=float)
    lo = t[np.searchsorted(at, idx, side="right") - 1]
    hi = t[np.minimum(np.searchsorted(at, idx, side="left"), len(at) - 1)]
    u = data_params(fit, data, np.c_[lo, hi])
    return RationalFit(fit.degree, fit.knots, fit.weights, fit.points, u, fit.rms_history, True)


def _line_runs(chain: Chain) -> np.ndarray:
    """MoveRule.line_run of the chain: runs of G1 moves, numbered. A chain's feeds differ only where all are
    beyond the machine's reach (ipo.fit.chains.same_feed): a run may cross them, as a group does, and is
    written at the lowest (ipo.fit.convert)."""
    runs = np.full(len(chain.points), -1, dtype=np.int64)
    run, prev = -1, None
    for m, end in zip(chain.moves, chain.ends):
        if isinstance(m, Line):
            if not isinstance(prev, Line):
                run += 1
            runs[end] = run
        prev = m
    return runs


def _merge_kept(spans: list[Span]) -> list[Span]:
    out: list[Span] = []
    for s in spans:
        if out and s.kept and out[-1].kept:
            out[-1] = Span(out[-1].first, s.last)
        else:
            out.append(s)
    return out
