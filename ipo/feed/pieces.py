"""Path pieces for the feed stage: motion entities turned into one arc-length-parametrised path.

Every analytic piece (a line, a G2/G3 arc or helix, or a G64 corner blend) shares one
form, evaluated by arc length sigma in [0, length]:

    p(sigma) = c + r(phi) (cos(phi) e1 + sin(phi) e2) + w sigma,  phi = omega sigma,
    r(phi) = radius + dr * phi

(a line has radius 0 and w its unit direction; an arc whose end lies slightly off the
circle spirals by dr so that it ends exactly on its end point). NURBS pieces refer to
their entity and are walked by its stepper; the planner only samples their geometry.

Corner blending (G64 P): the corner between two line-like moves is replaced by the
circular arc tangent to both whose deviation from the corner is P,
R (1/cos(theta/2) - 1) <= P, and whose tangent points lie within half of each move
(theta the change of direction). A corner that involves an arc or a NURBS gets a cubic
sized by the same rule, then checked against the programmed corner and shrunk until within P,
since the moves bend within the trim (ipo.feed.blends.curve_corner); a NURBS is trimmed to
the part between its blends (ipo.nurbs.subcurve), which its stepper walks. In S-curve mode a
corner between two lines gets a curvature-continuous quintic within P instead of the arc
(ipo.feed.blends.curvature_continuous): the arc's curvature steps cap v^2 / R <= J T. Likewise
a joint next to an arc or a NURBS, tangent or at a corner, gets a quintic that matches the
curvature of both moves (ipo.feed.blends.g2_joints) where that beats crossing the curvature
step, the cubic, or a stop; and a run of small turns between lines becomes one curve of such
quintics from move midpoint to midpoint (ipo.feed.blends.g2_chains). G61 and P0 corners,
reversals and corners where no blend fits are not blended: the planner crosses them within
one period at the corner cap (ipo.feed.cap_kernels.geometric_caps).
"""
from __future__ import annotations

from dataclasses import dataclass
import itertools
from operator import add, attrgetter, is_, itemgetter
from typing import NamedTuple

import numpy as np

from ipo.nurbs import kernel as nk
from ipo.errors import ARC_RADIUS, IpoError
from ipo.feed.blends.curvature_continuous import BEZIER5_KNOTS, g2_control_points, g2_corners
from ipo.feed.blends.g2_chains import CHAIN_MAX_RAD, chain_runs, g2_chains
from ipo.feed.blends.g2_joints import g2_joint
from ipo.feed.blends.curve_corner import Side, corner_blend
from ipo.feed.arc_corners import arc_corner_blends
from ipo.feed.analytic import Geometry, frame, point_tangent, points_along_piece
from ipo.feed.arcs import ArcSpecs, arc_pieces, trimmed_arcs
from ipo.feed.driver_changes import DriverChanges
from ipr.arc_arrays import arc_sweeps
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs, Rapid

KIND_ANALYTIC = 0
KIND_NURBS = 1  # a NURBS entity: walked by its stepper
KIND_BLEND = 2  # a corner blend curve (a cubic or quintic Bezier): evaluated by arc length directly
_COLLINEAR_RAD = 1e-9  # corners sharper than this are crossed as they are
_REVERSAL_RAD = np.pi - 1e-6  # a reversal cannot be blended: the machine stops
_CURVE_BLEND_MIN_RAD = 1e-4  # gentler corners next to arcs and NURBS are crossed as they are
_MIN_PIECE_MM = 1e-6  # shorter straights left between blends are dropped (a 1 nm step)
BEZIER3_KNOTS = np.array([0, 0, 0, 0, 1, 1, 1, 1.0])  # a corner blend: one cubic Bezier span
_START, _END, _PATH = attrgetter("start"), attrgetter("end"), attrgetter("path")
_FEED, _LINE, _RPM = attrgetter("feed_mm_s"), attrgetter("line"), itemgetter(1)


def _is_kind(kinds: list[type], cls: type) -> np.ndarray:
    return np.fromiter(map(is_, kinds, itertools.repeat(cls)), bool, len(kinds))


def _read_only(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    for a in arrays:
        a.flags.writeable = False
    return arrays


# a corner blend's knots and weights by its number of control points (one Bezier span), shared by
# every blend of that degree (entities' arrays are read-only)
BLEND_SPANS = {4: _read_only(BEZIER3_KNOTS.copy(), np.ones(4)), 6: _read_only(BEZIER5_KNOTS.copy(), np.ones(6))}


@dataclass(slots=True)
class Pieces:
    """P consecutive pieces: arrays of length P (vectors (P, 3))."""

    c: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    w: np.ndarray
    radius: np.ndarray
    dr: np.ndarray
    omega: np.ndarray
    length: np.ndarray
    kind: np.ndarray  # KIND_*
    nurbs: np.ndarray  # index into the owner's NURBS list, -1 for analytic pieces
    line: np.ndarray  # source line
    feed_mm_s: np.ndarray  # programmed feed; the rapid rate for G0
    rapid: np.ndarray  # bool: G0 (feed override does not apply)
    stop_after: np.ndarray  # bool: the machine stands still at the piece's end
    corner_tol_mm: np.ndarray  # path deviation tolerated where the piece ends in a sharp corner
    rpm: np.ndarray  # spindle speed while the piece runs (roughness limiter)

    def __len__(self) -> int:
        return len(self.length)

    @staticmethod
    def concat(parts: list["Pieces"]) -> "Pieces":
        return Pieces(*(np.concatenate([getattr(p, f) for p in parts]) for f in Pieces.__slots__))

    def take(self, idx) -> "Pieces":
        return Pieces(*(getattr(self, f)[idx] for f in Pieces.__slots__))

    @property
    def geometry(self) -> Geometry:
        """The analytic pieces' shape, as the compiled kernels take it (ipo.feed.analytic)."""
        return Geometry(self.c, self.e1, self.e2, self.w, self.radius, self.dr, self.omega)


def _empty(n: int) -> Pieces:
    z3 = np.zeros((n, 3))
    return Pieces(z3.copy(), z3.copy(), z3.copy(), z3.copy(), np.zeros(n), np.zeros(n), np.zeros(n),
                  np.zeros(n), np.zeros(n, np.int8), np.full(n, -1, np.int32), np.zeros(n, np.int32),
                  np.zeros(n), np.zeros(n, bool), np.zeros(n, bool), np.zeros(n), np.zeros(n))


class Motion(NamedTuple):
    """A motion entity with the state it runs under, as the builder receives it."""

    entity: Line | Rapid | Arc | Nurbs
    rpm: float
    nurbs_index: int  # index into the owner's NURBS list, -1 otherwise


def motion_length(m: Motion, nurbs) -> float:
    """Arc length of a pending motion (its NURBS's from the driver in `nurbs`)."""
    e = m[0]
    if isinstance(e, Nurbs):
        return nurbs[m[2]].table.length
    if isinstance(e, Arc):
        a, b, n = PLANE_AXES[e.plane]
        return float(np.hypot(e.radius_mm * abs(e.sweep_rad), e.end[n] - e.start[n]))
    return float(np.linalg.norm(np.subtract(e.end, e.start)))


def _lay_out_arcs(arcs: Pieces, t_in: np.ndarray, t_out: np.ndarray, rows: np.ndarray, ents: list[Arc]) -> None:
    """The arcs ents as rows `rows` of arcs (untrimmed), with their end tangents."""
    g = arc_sweeps(ents)   # radius_mm and sweep_rad of each, at once (~4 us a property call: 40 ms for 9,000 arcs)
    specs = ArcSpecs(g.start, g.end, g.centre, g.r_start_mm, g.sweep_rad, g.axes)
    bad = arc_pieces(arcs.geometry, arcs.length, t_in, t_out, rows, specs)
    if bad >= 0:
        raise IpoError(ARC_RADIUS, "arc radius is zero (start point on the centre)", ents[bad].line)


class Built(NamedTuple):
    """What one build made: the pieces, the trim of the held-back motion, and the drivers
    it added or trimmed (to apply to the owner's window)."""

    pieces: Pieces
    trim_mm: float
    drivers: DriverChanges


def build(motions: list[Motion], *, final: bool, lead_trim_mm: float, blend_default_mm: float,
          rapid_mm_s: float, drivers, next_index: int, make_drivers, min_blend_radius_mm: float = 0.0,
          g2_limits: tuple[float, float, float, float] | None = None) -> Built:
    """Pieces for motions[0..n-2] and, if `final`, motions[n-1] too (ending at a stop).

    Without `final`, the last motion is held back (its end corner needs the next move);
    the returned trim is how much of its start the corner blend already took: pass it
    back as lead_trim_mm with the held-back motion first in the next call.
    `drivers` maps the owner's NURBS index to its driver (ipo.feed.nurbs_driver: entity,
    arc-length table, trimmed()) and is only read; the result's `drivers` holds a NURBS
    trimmed by corner blends with the driver of its remaining part at the same index, and
    each corner blend curve with the driver `make_drivers` made for it (all in one call) at the next free
    index from `next_index` on. A corner whose blend radius would be below min_blend_radius_mm is not blended
    (S-curve mode: ipo.feed.limits.min_blend_radius_mm). With g2_limits = (a, j, x_min, step)
    (S-curve mode: ipo.feed.limits.g2_blend_limits) a corner between two lines gets the
    curvature-continuous blend of ipo.feed.blends.curvature_continuous where it is faster than both the arc and a
    stop (ipo.feed.blends.curvature_continuous.g2_corners).
    """
    nurbs = DriverChanges(drivers, next_index, make_drivers)
    # 1. the moves as arrays: ends, feed, tolerance, length, tangents at both ends
    n = len(motions)
    ents = [m[0] for m in motions]
    paths = list(map(_PATH, ents))  # a program has a few PathControls for its thousands of moves
    path_ids = list(map(id, paths))
    tol_of: dict = {}
    exact_of: dict = {}
    for path in dict(zip(path_ids, paths)).values():
        tol_of[id(path)] = (0.0 if path.exact_stop else blend_default_mm if path.blend_tol_mm is None
                            else float(path.blend_tol_mm))
        exact_of[id(path)] = path.exact_stop
    kinds = list(map(type, ents))
    # both ends of every move, straight from the tuples into one array (no list of rows)
    pts = np.fromiter(itertools.chain.from_iterable(map(add, map(_START, ents), map(_END, ents))), float, 6 * n).reshape(n, 6)
    start, end = pts[:, :3], pts[:, 3:]
    # per move, without a Python expression per move (a build takes ~2,000): a rapid's feed is None
    rapid = _is_kind(kinds, Rapid)
    line_like = rapid | _is_kind(kinds, Line)
    feed = np.where(rapid, rapid_mm_s, np.array(list(map(_FEED, ents)), dtype=float))
    lines = np.fromiter(map(_LINE, ents), np.int32, n)
    rpm = np.fromiter(map(_RPM, motions), float, n)
    tol = np.fromiter(map(tol_of.__getitem__, path_ids), float, n)
    exact = np.fromiter(map(exact_of.__getitem__, path_ids), bool, n)
    vec = end - start
    length = np.sqrt(np.einsum("ij,ij->i", vec, vec))
    unit = np.divide(vec, length[:, None], out=np.zeros_like(vec), where=length[:, None] > 0)
    arcs = _empty(n)  # the untrimmed arcs, for their lengths, tangents and points
    is_arc = _is_kind(kinds, Arc)
    is_nurbs = _is_kind(kinds, Nurbs)
    t_in, t_out = unit.copy(), unit.copy()
    arc_rows = np.nonzero(is_arc)[0]
    if len(arc_rows):
        _lay_out_arcs(arcs, t_in, t_out, arc_rows, [ents[i] for i in arc_rows])
        length[arc_rows] = arcs.length[arc_rows]
    for i in np.nonzero(is_nurbs)[0]:
        tab = nurbs[motions[i][2]].table
        length[i] = tab.length
        t_in[i], t_out[i] = tab.t[0], tab.t[-1]
    # 2. size the corner blends: junction j joins moves j and j+1
    trim_in, trim_out = np.zeros(n), np.zeros(n)
    trim_in[0] = lead_trim_mm
    both = line_like[:-1] & line_like[1:] & (length[:-1] > 0) & (length[1:] > 0) & (tol[:-1] > 0)
    cos_t = np.clip(np.einsum("ij,ij->i", t_out[:-1], t_in[1:]), -1.0, 1.0)
    theta = np.arccos(cos_t)
    blend = both & (theta > _COLLINEAR_RAD) & (theta < _REVERSAL_RAD)
    half = np.where(blend, 0.5 * theta, 0.25)
    # a blend may take half of each move, and on an arc no more than a tenth of its radius
    reach = np.where(is_arc, np.minimum(0.5 * length, 0.1 * arcs.radius), 0.5 * length)
    avail = np.minimum(reach[:-1], reach[1:])
    with np.errstate(divide="ignore"):  # a turn so slight that sec = 1 in floats: any R is within P
        r_tol = tol[:-1] / (1.0 / np.cos(half) - 1.0)  # deviation R (sec(theta/2) - 1) <= P
    radius = np.where(blend, np.minimum(r_tol, avail / np.tan(half)), 0.0)
    g2, d_g2, x_corner = np.zeros_like(blend), np.zeros(n - 1), np.zeros(n - 1)
    if g2_limits is not None:
        # the held-back last move's end corner is not known yet: taken as one that fills its half
        g2, d_g2, x_corner = g2_corners(2.0 * half, tol[:-1], avail, radius, blend & (radius >= min_blend_radius_mm),
                                        length, lead_trim_mm, 0.0 if final else 0.5 * length[-1], g2_limits)
        g2 &= blend
    blend &= g2 | (radius >= min_blend_radius_mm)
    chain = np.zeros_like(blend)
    if g2_limits is not None:  # runs of small turns between lines: one curvature-continuous curve
        # a quintic takes half of each of its moves: a run keeps to feed moves or rapids, under one spindle speed
        alike = (rapid[:-1] == rapid[1:]) & (rpm[:-1] == rpm[1:])
        runs = chain_runs(both & alike & (theta > _COLLINEAR_RAD) & (theta < CHAIN_MAX_RAD),
                          x_corner < np.minimum(feed[:-1], feed[1:]) ** 2)
        chain, chain_ctrl = g2_chains(start, unit, length, runs, tol[:-1], g2_limits)
        blend &= ~chain
        g2 &= ~chain
    radius = np.where(blend, radius, 0.0)
    d = np.where(g2, d_g2, radius * np.tan(half))
    d = np.where(chain, 0.5 * length[:-1], d)
    # a corner next to an arc or a NURBS gets a cubic blend from the point d before it to the
    # point d after it, tangent to both moves, with the handles of a circular arc: sized like the
    # circular blend between lines, then checked against the moves (which bend within d) and
    # shrunk until within P (ipo.feed.blends.curve_corner)
    movable = line_like | is_arc
    at_curve = (((movable[:-1] & movable[1:] & ~both) | is_nurbs[:-1] | is_nurbs[1:]) & (tol[:-1] > 0)
                & (length[:-1] > 0) & (length[1:] > 0) & (theta > _CURVE_BLEND_MIN_RAD) & (theta < _REVERSAL_RAD))
    jc = np.nonzero(at_curve)[0]
    ja = jc[~(is_nurbs[jc] | is_nurbs[jc + 1])]  # lines and arcs: all at once (ipo.feed.arc_corners)
    ok, d_a, ctrl_a = arc_corner_blends(arcs.geometry, is_arc, start, unit, length, end, ja, theta[ja], tol[ja],
                                        avail[ja])
    ok &= d_a / np.tan(0.5 * theta[ja]) >= min_blend_radius_mm
    found_at = dict(zip(ja[ok].tolist(), zip(d_a[ok], ctrl_a[ok])))
    for j in np.setdiff1d(jc, ja).tolist():
        before = _side(ents[j], motions[j][2], nurbs, arcs, start, unit, length, j, from_end=True)
        after = _side(ents[j + 1], motions[j + 1][2], nurbs, arcs, start, unit, length, j + 1, from_end=False)
        found = corner_blend(before, after, end[j], float(theta[j]), float(tol[j]), float(avail[j]))
        if found is not None and found[0] / np.tan(0.5 * theta[j]) >= min_blend_radius_mm:
            found_at[j] = found
    bezier_blends = {}
    for j in sorted(found_at):
        d[j], bezier_blends[j] = found_at[j]
    d_after = np.where(chain, 0.5 * length[1:], d)
    if chain.any():
        bezier_blends.update(zip(np.flatnonzero(chain).tolist(), chain_ctrl[chain]))
    if g2_limits is not None:  # S-curve mode: joints next to arcs and NURBS curvature-continuous where faster
        cubic_r = np.zeros(n - 1)
        jb = np.fromiter(bezier_blends, np.int64, len(bezier_blends))
        cubic_r[jb] = d[jb] / np.tan(0.5 * theta[jb])
        a_lim, j_lim = g2_limits[0], g2_limits[1]
        x_own = np.where(is_arc, np.minimum(a_lim * arcs.radius, (j_lim * arcs.radius**2) ** (2.0 / 3.0)), np.inf)
        x_own = np.minimum(x_own, feed**2)
        reach_g2 = 0.5 * length
        for j in np.nonzero(~both & (tol[:-1] > 0) & (length[:-1] > 0) & (length[1:] > 0)
                            & (theta < _REVERSAL_RAD))[0]:
            found = g2_joint(_side(ents[j], motions[j][2], nurbs, arcs, start, unit, length, j, from_end=True),
                             _side(ents[j + 1], motions[j + 1][2], nurbs, arcs, start, unit, length, j + 1,
                                   from_end=False), end[j], float(tol[j]), float(reach_g2[j]),
                             float(reach_g2[j + 1]), float(cubic_r[j]) if theta[j] > _CURVE_BLEND_MIN_RAD else None,
                             float(min(x_own[j], x_own[j + 1])), g2_limits)
            if found is not None:
                d[j], d_after[j], bezier_blends[j] = found
    trim_out[:-1] = d
    trim_in[1:] += d_after
    # 3. lay out the pieces: each move's own piece, then the blend at its end
    emit = n if final else n - 1
    pc = _empty(2 * emit)  # even slots: each move's own piece; odd slots: the blend at its end
    own, bl = np.arange(0, 2 * emit, 2), np.arange(1, 2 * emit, 2)
    for arr, vals in ((pc.line, lines), (pc.rapid, rapid), (pc.feed_mm_s, feed), (pc.rpm, rpm)):
        arr[own] = vals[:emit]
        arr[bl] = vals[:emit]
    ll = line_like[:emit]
    pc.c[own] = start[:emit] + unit[:emit] * trim_in[:emit, None]
    pc.w[own] = unit[:emit]
    pc.length[own] = np.where(ll, np.maximum(length[:emit] - trim_in[:emit] - trim_out[:emit], 0.0), 0.0)
    pc.stop_after[own] = exact[:emit]
    if final:
        pc.stop_after[own[-1]] = True
    pc.corner_tol_mm[own] = tol[:emit]
    jb = np.nonzero(blend[:emit] & ~g2[:emit])[0]
    t1, t2 = unit[jb], unit[jb + 1]
    m_perp = (t2 - np.cos(theta[jb])[:, None] * t1) / np.sin(theta[jb])[:, None]
    k = bl[jb]
    pc.c[k] = end[jb] - t1 * d[jb, None] + radius[jb, None] * m_perp
    pc.e1[k], pc.e2[k] = -m_perp, t1
    pc.radius[k] = radius[jb]
    pc.omega[k] = 1.0 / radius[jb]
    pc.length[k] = radius[jb] * theta[jb]
    # 4. the Bezier blends (at arcs, at NURBS, curvature-continuous) with their drivers
    jc = np.nonzero(chain[:emit])[0]  # a chain's quintic at the lower feed of its two moves
    pc.feed_mm_s[bl[jc]] = np.minimum(feed[jc], feed[jc + 1])
    blends = list(bezier_blends.items()) + [(j, g2_control_points(end[j], unit[j], unit[j + 1], float(d[j])))
                                            for j in np.nonzero(g2[:emit])[0]]
    _put_blends(pc, bl[[j for j, _ in blends]], [ctrl for _, ctrl in blends], nurbs)
    # 5. arcs and NURBS without what their blends took
    ra = np.nonzero(is_arc[:emit])[0]
    trimmed_arcs(arcs.geometry, arcs.length, pc.geometry, pc.length, ra, 2 * ra, trim_in[ra], trim_out[ra])
    for i in np.nonzero(is_nurbs[:emit])[0]:
        _trimmed_nurbs(pc, 2 * i, motions[i][2], nurbs, trim_in[i], trim_out[i])
    keep = pc.length > _MIN_PIECE_MM  # blends may leave float-noise remnants of a straight
    return Built(pc.take(np.nonzero(keep)[0]), 0.0 if final else float(trim_in[n - 1]), nurbs)


def _put_blends(pc: Pieces, slots: np.ndarray, ctrls: list[np.ndarray], nurbs: DriverChanges) -> None:
    """The cubic (or G2 quintic) Beziers with control points ctrls as the blend pieces in slots
    (whose line and feed, those of the move before each, are set)."""
    if not ctrls:
        return
    idx, curves = nurbs.add(list(zip(pc.line[slots].tolist(), pc.feed_mm_s[slots].tolist(), ctrls)))
    pc.kind[slots] = KIND_BLEND
    pc.nurbs[slots] = idx
    pc.length[slots] = [c.table.length for c in curves]
    pc.c[slots] = [ctrl[0] for ctrl in ctrls]


def _trimmed_nurbs(pc: Pieces, slot: int, k: int, nurbs, trim_in: float, trim_out: float) -> None:
    """The NURBS with owner index k without its first trim_in and last trim_out millimetres of
    arc length; its driver is replaced by the one of that part (dropped if nothing is left)."""
    drv = nurbs[k]
    tab = drv.table
    if trim_in > 0 or trim_out > 0:
        if tab.length - trim_in - trim_out <= _MIN_PIECE_MM:
            del nurbs[k]
            pc.length[slot] = 0.0  # dropped with the other remnants
            return
        u0, u1 = tab.u_at(drv.entity, np.array([trim_in, tab.length - trim_out]))
        drv = nurbs[k] = drv.trimmed(float(u0), float(u1))
    pc.kind[slot] = KIND_NURBS
    pc.nurbs[slot] = k
    pc.length[slot] = drv.table.length
    pc.c[slot] = drv.entity.points[0]


def _side(e, k: int, nurbs, arcs: Pieces, start, unit, length, i: int, *, from_end: bool) -> Side:
    """Move i next to a corner at its end (from_end) or start, by distance from the corner."""
    sign, base = (-1.0, length[i]) if from_end else (1.0, 0.0)
    if isinstance(e, Nurbs):
        drv = nurbs[k]
        u_corner = float(e.knots[-1] if from_end else e.knots[0])
        known: dict[float, float] = {}
        derivs: dict[float, np.ndarray] = {}  # C, C', C'' at x: the joints ask at(x) and kv(x) alike

        def u_of(x):
            if x not in known:
                known[x] = float(drv.table.u_at(drv.entity, np.array([base + sign * x]))[0])
            return known[x]

        def derivs_at(x):
            if x not in derivs:
                derivs[x] = nk.curve_derivs(e.degree, e.knots, e.weights, e.points, np.array([u_of(x)]), 2)[:, 0]
            return derivs[x]

        def at(x):
            p, d1, _ = derivs_at(x)
            return p, d1 / np.linalg.norm(d1)

        def kv(x):  # the curvature vector (d2 - (d2.t) t) / |d1|^2
            _, d1, d2 = derivs_at(x)
            t = d1 / np.linalg.norm(d1)
            return (d2 - np.dot(d2, t) * t) / np.dot(d1, d1)

        return Side(at, lambda x, n: nk.curve_points(e.degree, e.knots, e.weights, e.points,
                                                     np.linspace(u_corner, u_of(x), n)), kv)
    if isinstance(e, Arc):
        g = arcs.geometry
        return Side(lambda x: point_tangent(g, i, base + sign * x),
                    lambda x, n: points_along_piece(g, i, base, sign, x, n),
                    lambda x: frame(g, np.array([i]), np.array([base + sign * x]))[1][0])
    return Side(lambda x: (start[i] + unit[i] * (base + sign * x), unit[i]),
                lambda x, n: start[i] + unit[i] * (base + sign * np.array([0.0, x]))[:, None], lambda x: np.zeros(3))
