"""Samples along the path: where the feed limits are evaluated and the look-ahead runs.

Each piece gets samples at both ends (so a corner appears as two samples at the same
arc length, one with each tangent) and inside, dense enough that the tangent turns by
at most MAX_TURN_RAD and no two samples are more than MAX_SPACING_MM apart. NURBS are
sampled adaptively in u until the same holds, which catches every curvature peak the
spacing can resolve, and their arc length comes from Simpson's rule on |C'(u)|.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ipo.nurbs import kernel as nk
from ipo.feed.blends.compiled import bezier_points_at, bezier_tables
from ipo.errors import NURBS_PATH, IpoError
from ipo.feed.blends.curvature_continuous import BEZIER5_KNOTS
from ipo.feed.analytic import frame_into
from ipo.feed.pieces import BEZIER3_KNOTS, KIND_ANALYTIC, Pieces

MAX_TURN_RAD = 0.03
MAX_SPACING_MM = 2.0
_NURBS_START_PER_SPAN = 16
_NURBS_REFINE_ROUNDS = 6
_END_LEVELS = 4  # samples near each end of a NURBS (nurbs_table)
ARC_TOL_MM = 1e-7  # arc-length accuracy of the NURBS tables' s(u) (_refine_arc)
_ARC_REFINE_ROUNDS = 6  # every curve of the corpus and the example programs settles within these
# a curve that moves unevenly in u (uneven weights) gets more, up to a bounded table
_ARC_REFINE_ROUNDS_MAX = 64
_MAX_TABLE_SAMPLES = 50_000
_CHORD_SLACK_MM = 1e-6  # a chord may exceed the tabled arc by this before the table is refused


@dataclass(slots=True)
class Samples:
    """K samples: arc length s (global), tangent t (K, 3), curvature vector kv (K, 3),
    piece index and the arc length sigma inside the piece."""

    s: np.ndarray
    t: np.ndarray
    kv: np.ndarray
    piece: np.ndarray
    sigma: np.ndarray

    def __len__(self) -> int:
        return len(self.s)

    @staticmethod
    def concat(parts: list["Samples"]) -> "Samples":
        return Samples(*(np.concatenate([getattr(p, f) for p in parts]) for f in Samples.__slots__))

    def tail(self, k: int) -> "Samples":
        return Samples(*(getattr(self, f)[k:] for f in Samples.__slots__))


@dataclass(slots=True)
class NurbsTable:
    """A NURBS sampled by arc length: s (M,), u (M,), ds/du (M,), unit tangent and curvature
    vector (M, 3)."""

    s: np.ndarray
    u: np.ndarray
    speed: np.ndarray
    t: np.ndarray
    kv: np.ndarray
    end_gap_mm: float = 0.0  # the end samples' gap (nurbs_table), for tables of trimmed parts
    bezier: bool = False  # a corner blend's table (its points by ipo.feed.blends.compiled)
    _kappa: np.ndarray | None = field(default=None, init=False, repr=False)  # |kv|, on first use

    def s_of_u(self, u: float) -> float:
        """Arc length at u: cubic Hermite on s(u) with ds/du known at the samples."""
        k = min(max(int(np.searchsorted(self.u, u, side="right")) - 1, 0), len(self.u) - 2)
        h = self.u[k + 1] - self.u[k]
        q = (u - self.u[k]) / h
        h00, h10, h01, h11 = 2*q**3 - 3*q**2 + 1, q**3 - 2*q**2 + q, -2*q**3 + 3*q**2, q**3 - q**2
        return float(h00 * self.s[k] + h10 * h * self.speed[k] + h01 * self.s[k + 1] + h11 * h * self.speed[k + 1])

    def points_at(self, e, s: np.ndarray) -> np.ndarray:
        """Points of NURBS e at arc lengths s (see u_at)."""
        if self.bezier:  # the kernel clips s to [0, length] itself
            return bezier_points_at(np.asarray(e.points, dtype=float), self.s, self.u, s, GAUSS_X, GAUSS_W)
        return _derivs(e, self.u_at(e, s), 0)[0]

    def u_at(self, e, s: np.ndarray) -> np.ndarray:
        """Parameters of NURBS e at arc lengths s: u from the table, then Newton on the arc
        length (integrated by 5-point Gauss-Legendre from the nearest sample)."""
        s = np.clip(s, 0.0, self.length)
        k = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        h = self.s[k + 1] - self.s[k]
        q = np.divide(s - self.s[k], h, out=np.zeros_like(s), where=h > 0)
        u = self.u[k] + q * (self.u[k + 1] - self.u[k])
        xg, wg = GAUSS_X, GAUSS_W
        for _ in range(3):
            du = u - self.u[k]
            uu = self.u[k][:, None] + 0.5 * du[:, None] * (xg[None, :] + 1)
            # the Gauss nodes and u in one evaluation (each point's derivative is its own)
            d1_norm = np.linalg.norm(_derivs(e, np.concatenate([uu.ravel(), u]), 1)[1], axis=1)
            sp = d1_norm[:uu.size].reshape(uu.shape)
            s_u = self.s[k] + 0.5 * du * (sp @ wg)
            speed = d1_norm[uu.size:]
            u = np.clip(u - (s_u - s) / speed, self.u[k], self.u[k + 1])
        return u

    @property
    def kappa(self) -> np.ndarray:
        """|kv| at the samples (the NURBS driver reads it every chunk of periods)."""
        if self._kappa is None:
            self._kappa = np.linalg.norm(self.kv, axis=1)
        return self._kappa

    @property
    def length(self) -> float:
        return float(self.s[-1])


GAUSS_X, GAUSS_W = np.polynomial.legendre.leggauss(5)


def _is_bezier3(e) -> bool:
    return (e.degree == 3 and len(e.points) == 4 and np.array_equal(e.knots, BEZIER3_KNOTS)
            and bool(np.all(e.weights == 1)))


def _is_blend(e) -> bool:
    """A corner blend (compiled in ipo.feed.blends.compiled): a cubic or the G2 quintic Bezier."""
    return _is_bezier3(e) or (e.degree == 5 and len(e.points) == 6 and np.array_equal(e.knots, BEZIER5_KNOTS)
                              and bool(np.all(e.weights == 1)))


def _derivs(e, u: np.ndarray, n: int) -> np.ndarray:
    """C(u) and its first n derivatives; a cubic Bezier (the corner blends) in closed form."""
    if _is_bezier3(e):
        p0, p1, p2, p3 = e.points
        a1, a2, a3 = 3 * (p1 - p0), 3 * (p2 - 2 * p1 + p0), p3 - 3 * p2 + 3 * p1 - p0
        uu = np.asarray(u, dtype=float)[:, None]
        out = [p0 + uu * (a1 + uu * (a2 + uu * a3)), a1 + uu * (2 * a2 + 3 * uu * a3), 2 * a2 + 6 * uu * a3]
        return np.stack(out[:n + 1])
    return nk.curve_derivs(e.degree, e.knots, e.weights, e.points, u, n)


def _where(u: float, point) -> str:
    return f"at u = {u:.6g} (X{point[0]:.4f} Y{point[1]:.4f} Z{point[2]:.4f})"


def _nurbs_frame(e, u: np.ndarray, points: list | None = None):
    """|C'(u)|, the unit tangent and the curvature vector; the points too into `points`."""
    d = _derivs(e, u, 2)
    d1, d2 = d[1], d[2]
    speed = np.linalg.norm(d1, axis=1)
    if not np.all(speed > 0):
        k = int(np.flatnonzero(~(speed > 0))[0])
        w = np.asarray(e.weights, dtype=float)
        uneven = (f", or weights so uneven ({w.min():g} to {w.max():g}) that it stands still in double precision"
                  if w.max() > 1e6 * w.min() else "")
        raise IpoError(NURBS_PATH, f"NURBS has a vanishing derivative {_where(u[k], d[0][k])}: a cusp or "
                                   f"coincident control points inside the curve{uneven}", e.line)
    t = d1 / speed[:, None]
    kv = (d2 - np.einsum("ij,ij->i", d2, t)[:, None] * t) / (speed**2)[:, None]
    if points is not None:
        points.append(d[0])
    return speed, t, kv


def _check_resolved(e, u: np.ndarray, points: np.ndarray, ds: np.ndarray) -> None:
    """Refuse a curve whose table does not hold its path: an interval whose chord is longer than
    its arc length (arc >= chord, so the table has stepped over a part of the curve that double
    precision in u cannot resolve: extreme weights), or a length beyond the control polygon's
    (a rational curve is the limit of corner cutting of its polygon, so it is never longer)."""
    chord = np.linalg.norm(np.diff(points, axis=0), axis=1)
    polygon = float(np.sum(np.linalg.norm(np.diff(np.asarray(e.points, dtype=float), axis=0), axis=1)))
    over = chord - ds - (_CHORD_SLACK_MM + 1e-6 * chord)  # not the rounding of a part's knot insertion
    total = float(np.sum(ds))
    w = np.asarray(e.weights, dtype=float)
    weights = f"its weights range from {w.min():g} to {w.max():g} (a ratio of {w.max() / w.min():.3g})"
    if not np.all(over <= 0):
        k = int(np.argmax(np.where(np.isfinite(over), over, np.inf)))
        raise IpoError(NURBS_PATH, f"NURBS moves too fast in its parameter to be followed {_where(u[k], points[k])}: "
                                   f"{chord[k]:.4g} mm between u = {u[k]:.17g} and {u[k + 1]:.17g}, more than the "
                                   f"arc length sampled there; {weights}", e.line)
    if not total <= polygon * (1 + 1e-6) + _CHORD_SLACK_MM:
        raise IpoError(NURBS_PATH, f"NURBS cannot be tabled: its sampled length {total:.6g} mm exceeds its "
                                   f"control polygon's {polygon:.6g} mm; {weights}", e.line)


def nurbs_table(e, end_gap_mm: float = 0.0, u_fine: np.ndarray | None = None) -> NurbsTable:
    """Adaptive arc-length table of a NURBS entity; u_fine, parameters already as fine as the
    refinement makes them (a part of a tabled curve: ipo.feed.nurbs_driver.trimmed), skips it.

    With end_gap_mm > 0 the table also gets samples end_gap_mm * 4^-j (j < _END_LEVELS)
    from each end: the profile is linear in v^2 between samples (a constant path
    acceleration), and the machine brakes into an unblended corner at a curve's end
    within about that distance, at the halved acceleration of the interval next to it.
    """
    if _is_blend(e):  # a corner blend: the same table, compiled
        return blend_tables([e.points], [e.line])[0]
    p = e.degree
    brk = np.unique(e.knots[p:len(e.knots) - p])
    u = np.unique(np.concatenate([np.linspace(a, b, _NURBS_START_PER_SPAN + 1)
                                  for a, b in zip(brk[:-1], brk[1:])])) if u_fine is None else u_fine
    for _ in range(0 if u_fine is not None else _NURBS_REFINE_ROUNDS):
        speed, t, kv = _nurbs_frame(e, u)
        ds = 0.5 * (speed[:-1] + speed[1:]) * np.diff(u)
        kmax = np.maximum(np.linalg.norm(kv[:-1], axis=1), np.linalg.norm(kv[1:], axis=1))
        turn = np.maximum(kmax * ds, np.arccos(np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1, 1)))
        split = np.maximum(np.ceil(turn / MAX_TURN_RAD), np.ceil(ds / MAX_SPACING_MM))
        split = np.where(split <= 64, split, 64).astype(int)  # inf, nan too: _check_resolved says why
        if np.all(split <= 1):
            break
        u = np.unique(np.concatenate([u, _inner_points(u, split)]))
    if u_fine is None:
        u = _refine_arc(e, u)
    if end_gap_mm > 0:
        u = _with_end_samples(e, u, end_gap_mm)
    points = []
    speed, t, kv = _nurbs_frame(e, u, points)
    mid_speed, _, _ = _nurbs_frame(e, 0.5 * (u[:-1] + u[1:]))
    ds = (speed[:-1] + 4 * mid_speed + speed[1:]) / 6 * np.diff(u)
    _check_resolved(e, u, points[0], ds)
    return NurbsTable(np.concatenate([[0.0], np.cumsum(ds)]), u, speed, t, kv, end_gap_mm)


def _inner_points(u: np.ndarray, split: np.ndarray) -> np.ndarray:
    """The inner points of np.linspace(u[i], u[i + 1], split[i] + 1) for every i with split[i] > 1,
    in one pass: k (u[i + 1] - u[i]) / split[i] + u[i], k = 1 .. split[i] - 1, as linspace has them."""
    i = np.flatnonzero(split > 1)
    count = split[i] - 1
    k = np.arange(1, count.sum() + 1) - np.repeat(np.cumsum(count) - count, count)
    return k * np.repeat((u[i + 1] - u[i]) / split[i], count) + np.repeat(u[i], count)


def blend_tables(ctrls, lines) -> list[NurbsTable]:
    """nurbs_table of each corner blend (a cubic or quintic Bezier, as _is_blend says, with control
    points ctrls[i], from program line lines[i]; not checked here: ipo.feed.pieces makes them),
    those of one degree in one compiled call."""
    out: list = [None] * len(ctrls)
    bad = []
    for size in {len(c) for c in ctrls}:
        rows = [i for i, c in enumerate(ctrls) if len(c) == size]
        s, u, speed, t, kv, first, ok = bezier_tables(np.array([ctrls[i] for i in rows], dtype=float),
                                                      _NURBS_START_PER_SPAN, _NURBS_REFINE_ROUNDS, MAX_TURN_RAD,
                                                      MAX_SPACING_MM)
        bad += [rows[r] for r in np.flatnonzero(~ok)]
        first = first.tolist()
        for i, a, z in zip(rows, first[:-1], first[1:]):
            out[i] = NurbsTable(s[a:z], u[a:z], speed[a:z], t[a:z], kv[a:z], 0.0, True)
    if bad:
        raise IpoError(NURBS_PATH, "NURBS has a vanishing derivative (a cusp or repeated points)", lines[min(bad)])
    return out


def _refine_arc(e, u: np.ndarray) -> np.ndarray:
    """u with intervals halved until the table's Hermite s(u) at each interval's midpoint
    agrees with Simpson's rule on its half within ARC_TOL_MM. The NURBS driver reads the
    stepper's arc position back through s(u) and corrects the difference: an error there
    becomes a real path error, which in a tight turn rotates with the tangent (an
    acceleration of error * kappa^2 v^2, 60 mm/s^2 per 0.1 um at kappa = 500/mm, 1.5 mm/s)."""
    for _ in range(_ARC_REFINE_ROUNDS_MAX):
        h = np.diff(u)
        q = u[:-1, None] + h[:, None] * np.array([0.25, 0.5, 0.75])
        sp = np.linalg.norm(_derivs(e, u, 1)[1], axis=1)
        sq = np.linalg.norm(_derivs(e, q.ravel(), 1)[1], axis=1).reshape(-1, 3)
        left = h / 12 * (sp[:-1] + 4 * sq[:, 0] + sq[:, 1])
        right = h / 12 * (sq[:, 1] + 4 * sq[:, 2] + sp[1:])
        hermite = 0.5 * (left + right) + h / 8 * (sp[:-1] - sp[1:])  # s_of_u at the midpoint
        bad = ~(np.abs(hermite - left) <= ARC_TOL_MM)
        if not bad.any():
            return u
        halves = q[bad, 1]
        if len(u) + len(halves) > _MAX_TABLE_SAMPLES or np.any((halves <= u[:-1][bad]) | (halves >= u[1:][bad])):
            break  # too many samples, or an interval double precision cannot halve
        u = np.unique(np.concatenate([u, halves]))
    # a curve whose s(u) does not settle moves too unevenly in u (extreme weights) for the
    # table, and so the steppers, to hold it
    k = int(np.flatnonzero(bad)[0])
    w = np.asarray(e.weights, dtype=float)
    raise IpoError(NURBS_PATH, f"NURBS moves too unevenly in its parameter to be followed "
                               f"{_where(u[k], _derivs(e, u[k:k + 1], 0)[0][0])}: its arc length does not "
                               f"settle to {ARC_TOL_MM:g} mm there within {len(u)} samples; its weights "
                               f"range from {w.min():g} to {w.max():g} (a ratio of {w.max() / w.min():.3g})", e.line)


def _with_end_samples(e, u: np.ndarray, gap_mm: float) -> np.ndarray:
    """u with samples about gap_mm * 4^-j of arc length from either end (u by linear
    interpolation of the trapezoidal arc length; the table's s stays exact)."""
    speed = np.linalg.norm(_derivs(e, u, 1)[1], axis=1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[:-1] + speed[1:]) * np.diff(u))])
    if s[-1] <= 3 * gap_mm:
        return u
    d = gap_mm * 0.25 ** np.arange(_END_LEVELS)
    return np.unique(np.concatenate([u, np.interp(np.concatenate([d, s[-1] - d]), s, u)]))


@njit(cache=True)
def _fill(g, length, n_int, analytic, gap, mid, gap_mm, starts, total):
    """Samples of all pieces: n_int[i] equal intervals of each, plus (analytic pieces) the
    samples gap_mm from either end (gap) or the midpoint (mid), in order of arc length, a
    tie after the regular sample (the order a stable sort by (piece, sigma) gives). The
    frames of analytic pieces too; the rows of the others are left for their tables."""
    piece = np.empty(total, np.int64)
    sigma = np.empty(total)
    s = np.empty(total)
    t = np.zeros((total, 3))
    kv = np.zeros((total, 3))
    first = np.empty(length.shape[0], np.int64)
    extra = np.empty(2)
    m = 0
    for i in range(length.shape[0]):
        first[i] = m
        n, ln = n_int[i], length[i]
        ne = 0
        if gap[i]:
            extra[0], extra[1], ne = gap_mm, ln - gap_mm, 2
        elif mid[i]:
            extra[0], ne = 0.5 * ln, 1
        je = 0
        for j in range(n + 1):
            sg = ln * j / n
            while je < ne and extra[je] < sg:
                piece[m], sigma[m] = i, extra[je]
                je += 1
                m += 1
            piece[m], sigma[m] = i, sg
            m += 1
        while je < ne:
            piece[m], sigma[m] = i, extra[je]
            je += 1
            m += 1
        if analytic[i]:
            for k in range(first[i], m):
                frame_into(g, i, sigma[k], t, kv, k)
                s[k] = starts[i] + sigma[k]
    return piece, sigma, s, t, kv, first


def sample(pc: Pieces, s0: float, tables: dict[int, NurbsTable], end_gap_mm: float = 0.0) -> Samples:
    """Samples of all pieces, arc length counted from s0 at the first piece's start.

    Analytic pieces also get a sample end_gap_mm from each end, so that the short
    stretch next to a sharp corner (where the planner halves the path acceleration) stays
    short; a shorter one gets its midpoint instead.
    """
    n_int = np.maximum(np.ceil(pc.length / MAX_SPACING_MM), np.ceil(pc.omega * pc.length / MAX_TURN_RAD))
    n_int = np.maximum(n_int, 1).astype(np.int64)
    nurbs_idx = np.nonzero(pc.kind != KIND_ANALYTIC)[0]
    tabs = [tables[k] for k in pc.nurbs[nurbs_idx].tolist()]
    rows = np.array([len(tab.s) for tab in tabs], dtype=np.int64)  # each table's samples
    n_int[nurbs_idx] = rows - 1
    analytic = pc.kind == KIND_ANALYTIC
    gap = analytic & (pc.length > 3 * end_gap_mm) & (end_gap_mm > 0)
    # a short piece between two corners gets its midpoint: the profile is linear in v^2
    # between samples, so without it the piece is crossed at its slower corner's speed
    mid = analytic & ~gap & (n_int == 1) & (end_gap_mm > 0)
    total = int(n_int.sum() + len(n_int) + 2 * gap.sum() + mid.sum())
    starts = s0 + np.concatenate([[0.0], np.cumsum(pc.length)[:-1]])
    piece, sigma, s, t, kv, first = _fill(pc.geometry, pc.length, n_int, analytic, gap, mid, float(end_gap_mm),
                                          starts, total)
    if tabs:  # the tables' rows in one assignment each (a build has thousands of blends)
        to = np.repeat(first[nurbs_idx] - (np.cumsum(rows) - rows), rows) + np.arange(rows.sum())
        sigma[to] = np.concatenate([tab.s for tab in tabs])
        t[to], kv[to] = np.concatenate([tab.t for tab in tabs]), np.concatenate([tab.kv for tab in tabs])
        s[to] = np.repeat(starts[nurbs_idx], rows) + sigma[to]
    return Samples(s, t, kv, piece, sigma)
