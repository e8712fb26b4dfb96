"""A run of G1 moves as one move: a G1 line or a G2/G3 arc within the tolerance of it both ways.

CAM output writes lines and fillets as G1 chords; a stretch whose vertices lie within tol of
one line, or of one circle in a principal plane, is one block as a G1 line or a G2/G3 arc, where
a G06.2 group would cost its opening and closing blocks as well. The plane is the program's
(G17/G18/G19) where the run lies in it, else the other one it lies in: the passes of a raster
finish run in vertical planes (ipo.fit.convert writes such an arc with its plane code and gives
the program its own back after it; on LinuxCNC's 3D_Chips at 10 um, YZ passes in a G17 program:
1774 -> 1365 written blocks). The plan
(ipo.fit.conic_plan) weighs these moves against the groups and the moves kept as written.

The circle passes through the run's two ends (the arc starts where the machine is and ends on
the source's own end point); its centre lies on their perpendicular bisector, at the least-squares
solution of |p_i - c|^2 = r^2 over the inner vertices and the chords' middles (CAM chords bulge
inside the circle by their sagitta, vertices lie on it: the circle goes between them); where that
circle fails the test, at the curvature with the least radial error (golden section). On
g1_lhchips4 at 10 um: 3668 written blocks with vertices only, 3586 with the middles, 3435 with
the second try. The test (`one_move`) is exact for the two-way distance, not sampled:

- every inner vertex within tol of the circle radially, at an angle from the start that grows along
  the arc and stays within its sweep (its nearest point of the circle is on the arc);
- every chord's nearest approach to the centre at least r - tol (a chord's farthest point from the
  centre is one of its ends, already within r + tol).

Then every point of the polyline lies within tol of the arc, and every point of the arc (at an
angle between two vertices' angles) within tol of the chord between them. A line is tested the
same way: vertices within tol of it, their projections growing along it. Only short arcs are
written (sweep below MAX_SWEEP_RAD < 180 degrees, in the plane at one normal coordinate): no full
circles, no arcs over 180 degrees, no helices. Each is checked again as written (ipo.fit.convert:
rounded centre, the controller's own arc geometry ipr.arcs.make_arc, as the rational quadratic a
short arc is exactly).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ipo.fit.rational import RationalFit
from ipo.fit.written import END_DIGITS, Frame, fmt
from ipr.arcs import make_arc
from ipr.entities import CONTINUOUS, PLANE_AXES, Arc

NONE, STRAIGHT, ARC = 0, 1, 2
NORMAL_PLANE = {n: plane for plane, (_, _, n) in PLANE_AXES.items()}  # normal axis -> plane (XY, ZX, YZ)
PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}
MAX_SWEEP_RAD = math.radians(150.0)  # an arc's conic check (weight cos(sweep / 2)) stays well conditioned
MAX_RADIUS_MM = 1.0e4  # beyond this a run that is not straight within tol is left to the groups
CENTRE_LETTERS = "IJK"
MINIMAX_BULGE = 2.0  # where the least-squares circle fails: curvatures tried, as the arc's middle moves (x tol)
MINIMAX_STEPS = 30


@njit(cache=True)
def flat_normal(q, v, w, nrm):
    """The normal axis of the principal plane an arc through q[v..w] lies in: nrm (the program's plane's)
    where the points keep its coordinate, else the first other axis they keep; -1 if none."""
    for n in (nrm, 0, 1, 2):
        flat = True
        for i in range(v + 1, w + 1):
            if q[i, n] != q[v, n]:
                flat = False
                break
        if flat:
            return n
    return -1


@njit(cache=True)
def one_move(q, v, w, a, b, nrm, tol_mm, centre):
    """Can points q[v..w] be one move within tol_mm both ways (module doc)? NONE, STRAIGHT or ARC;
    for ARC the centre (mm, its normal coordinate the run's) goes into centre[:3]. a, b, nrm: the
    program's plane's axes (ipr.entities.PLANE_AXES); the arc lies in the plane flat_normal finds
    (the program's where it can), and runs counter-clockwise where the centre lies left of the chord
    q[v] -> q[w] (seen in that plane's a, b)."""
    d0, d1, d2 = q[w, 0] - q[v, 0], q[w, 1] - q[v, 1], q[w, 2] - q[v, 2]
    length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if length == 0.0:
        return NONE
    u0, u1, u2 = d0 / length, d1 / length, d2 / length
    straight = True
    prev = 0.0
    for i in range(v + 1, w):
        p0, p1, p2 = q[i, 0] - q[v, 0], q[i, 1] - q[v, 1], q[i, 2] - q[v, 2]
        s = p0 * u0 + p1 * u1 + p2 * u2
        if s < prev or s > length or p0 * p0 + p1 * p1 + p2 * p2 - s * s > tol_mm * tol_mm:
            straight = False
            break
        prev = s
    if straight:
        return STRAIGHT
    nrm = flat_normal(q, v, w, nrm)
    if nrm < 0:
        return NONE
    a, b = (nrm + 1) % 3, (nrm + 2) % 3  # the plane of that normal (PLANE_AXES)
    half = 0.5 * math.hypot(q[w, a] - q[v, a], q[w, b] - q[v, b])
    if half == 0.0:
        return NONE
    ua, ub = (q[w, a] - q[v, a]) / (2.0 * half), (q[w, b] - q[v, b]) / (2.0 * half)
    na, nb = -ub, ua  # left of the chord
    ma, mb = 0.5 * (q[v, a] + q[w, a]), 0.5 * (q[v, b] + q[w, b])
    num, den = 0.0, 0.0
    for i in range(v + 1, 2 * w - v):  # the inner vertices, then the middles of the chords
        k, f = (i, 0.0) if i < w else (i - w + v, 0.5)
        pa, pb = q[k, a] + f * (q[k + 1, a] - q[k, a]), q[k, b] + f * (q[k + 1, b] - q[k, b])
        x = (pa - ma) * ua + (pb - mb) * ub
        y = (pa - ma) * na + (pb - mb) * nb
        num += y * (x * x + y * y - half * half)
        den += y * y
    if den == 0.0:
        return NONE
    t = num / (2.0 * den)
    if not _arc_fits(q, v, w, a, b, ma + t * na, mb + t * nb, half, t, tol_mm):
        if not _may_fit(q, v, w, a, b, ma, mb, na, nb, half, t, tol_mm):
            return NONE
        t = _minimax_offset(q, v, w, a, b, ma, mb, na, nb, half, t, tol_mm)
        if not _arc_fits(q, v, w, a, b, ma + t * na, mb + t * nb, half, t, tol_mm):
            return NONE
    centre[a], centre[b], centre[nrm] = ma + t * na, mb + t * nb, q[v, nrm]
    return ARC


@njit(cache=True)
def _arc_fits(q, v, w, a, b, ca, cb, half, t, tol_mm):
    """The test of the module doc for the circle of centre (ca, cb) through q[v] and q[w], t its signed
    distance from their chord (> 0: left of it, the arc counter-clockwise)."""
    r = math.hypot(half, t)
    sweep = 2.0 * math.atan2(half, abs(t))
    if r > MAX_RADIUS_MM or r <= 2.0 * tol_mm or sweep > MAX_SWEEP_RAD:
        return False
    sense = 1.0 if t > 0.0 else -1.0
    sa, sb = q[v, a] - ca, q[v, b] - cb
    prev = 0.0
    for i in range(v + 1, w + 1):
        pa, pb = q[i, a] - ca, q[i, b] - cb
        if i < w:
            if abs(math.hypot(pa, pb) - r) > tol_mm:
                return False
            phi = math.atan2(sense * (sa * pb - sb * pa), sa * pa + sb * pb)
            if phi < prev or phi > sweep:
                return False
            prev = phi
        if _inner_gap(q, i, a, b, ca, cb, r) > tol_mm:
            return False
    return True


@njit(cache=True)
def _inner_gap(q, i, a, b, ca, cb, r):
    """How far the chord q[i - 1] q[i] comes inside the circle (centre (ca, cb), radius r)."""
    pa, pb = q[i, a] - ca, q[i, b] - cb
    qa, qb = q[i - 1, a] - ca, q[i - 1, b] - cb
    ea, eb = pa - qa, pb - qb
    f = min(1.0, max(0.0, -(qa * ea + qb * eb) / (ea * ea + eb * eb)))
    return r - math.hypot(qa + f * ea, qb + f * eb)


@njit(cache=True)
def _radial_error(q, v, w, a, b, ma, mb, na, nb, half, kappa):
    """The circle through q[v], q[w] of signed curvature kappa (> 0: centre left of the chord): the largest
    distance of an inner vertex from it, or of a chord inside it."""
    if kappa == 0.0:
        return np.inf
    r = max(1.0 / abs(kappa), half)
    t = math.copysign(math.sqrt(r * r - half * half), kappa)
    ca, cb = ma + t * na, mb + t * nb
    worst = 0.0
    for i in range(v + 1, w + 1):
        if i < w:
            worst = max(worst, abs(math.hypot(q[i, a] - ca, q[i, b] - cb) - r))
        worst = max(worst, _inner_gap(q, i, a, b, ca, cb, r))
    return worst


@njit(cache=True)
def _kappa_range(half, t, tol_mm):
    """The signed curvatures _minimax_offset searches around that of the centre offset t: the middle of
    the arc moves by MINIMAX_BULGE tol either way."""
    kappa = math.copysign(1.0, t) / math.hypot(half, t)
    reach = 2.0 * MINIMAX_BULGE * tol_mm / (half * half)
    return kappa - reach, kappa + reach


@njit(cache=True)
def _may_fit(q, v, w, a, b, ma, mb, na, nb, half, t, tol_mm):
    """False only where no circle of _kappa_range keeps every inner vertex within tol_mm radially (so
    _minimax_offset's would fail _arc_fits): a vertex at (x, y) in the chord's frame is |p - c| - r =
    L / (|p - c| + r) from the circle of centre offset s, L = x^2 + y^2 - half^2 - 2 y s linear in s, so
    within tol only if |L| <= tol (2 r + tol): an interval of s per vertex, none shared, no circle."""
    lo, hi = _kappa_range(half, t, tol_mm)
    if lo <= 0.0 <= hi:  # nearly straight: the offsets are unbounded
        return True
    sense = 1.0 if lo > 0.0 else -1.0
    r_max = 1.0 / min(abs(lo), abs(hi))
    r_min = max(1.0 / max(abs(lo), abs(hi)), half)
    s0, s1 = sense * math.sqrt(r_min * r_min - half * half), sense * math.sqrt(r_max * r_max - half * half)
    s_lo, s_hi = min(s0, s1), max(s0, s1)
    bound = tol_mm * (2.0 * r_max + tol_mm) * (1.0 + 1e-7) + 1e-9  # a margin over rounding: never prunes a fit
    ua, ub = nb, -na
    for i in range(v + 1, w):
        x = (q[i, a] - ma) * ua + (q[i, b] - mb) * ub
        y = (q[i, a] - ma) * na + (q[i, b] - mb) * nb
        c = x * x + y * y - half * half
        if y == 0.0:
            if abs(c) > bound:
                return False
            continue
        e0, e1 = (c - bound) / (2.0 * y), (c + bound) / (2.0 * y)
        s_lo, s_hi = max(s_lo, min(e0, e1)), min(s_hi, max(e0, e1))
        if s_lo > s_hi:
            return False
    return True


@njit(cache=True)
def _minimax_offset(q, v, w, a, b, ma, mb, na, nb, half, t, tol_mm):
    """The centre's offset t from the chord with the least _radial_error, by golden section over the
    curvature of _kappa_range."""
    lo, hi = _kappa_range(half, t, tol_mm)
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1 = _radial_error(q, v, w, a, b, ma, mb, na, nb, half, x1)
    f2 = _radial_error(q, v, w, a, b, ma, mb, na, nb, half, x2)
    for _ in range(MINIMAX_STEPS):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = _radial_error(q, v, w, a, b, ma, mb, na, nb, half, x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = _radial_error(q, v, w, a, b, ma, mb, na, nb, half, x2)
    kappa = 0.5 * (lo + hi)
    if kappa == 0.0:
        return t
    r = max(1.0 / abs(kappa), half)
    return math.copysign(math.sqrt(r * r - half * half), kappa)


@dataclass(frozen=True, slots=True)
class OneMove:
    """The polyline `path` (mm) replaced by one G1 line (centre_mm None) or one G2/G3 arc from its first
    point to its last; vertex_end: the last point is a vertex of the source (written as exactly as the
    source's numbers), not a point inside one of its segments (ipo.fit.move_runs)."""

    path: np.ndarray
    plane: str
    centre_mm: np.ndarray | None = None
    vertex_end: bool = True

    @property
    def start(self) -> np.ndarray:
        return self.path[0]

    @property
    def end(self) -> np.ndarray:
        return self.path[-1]

    @property
    def code(self) -> str:
        if self.centre_mm is None:
            return "G1"
        a, b, _ = PLANE_AXES[self.plane]
        chord = self.end - self.start
        left = chord[a] * (self.centre_mm[b] - self.start[b]) - chord[b] * (self.centre_mm[a] - self.start[a])
        return "G3" if left > 0.0 else "G2"


def fit_move(path: np.ndarray, plane: str, tol_mm: float, vertex_end: bool = True) -> OneMove:
    """The move one_move finds for the polyline path in a program of plane `plane` (the plan's choice,
    found again; an arc in the plane it lies in)."""
    a, b, nrm = PLANE_AXES[plane]
    centre = np.empty(3)
    kind = one_move(path, 0, len(path) - 1, a, b, nrm, tol_mm, centre)
    if kind == NONE:
        raise ValueError(f"the {len(path)} points are not one move within {tol_mm} mm")
    if kind == STRAIGHT:
        return OneMove(path, plane, None, vertex_end)
    return OneMove(path, NORMAL_PLANE[flat_normal(path, 0, len(path) - 1, nrm)], centre, vertex_end)


def _words(values_mm: np.ndarray, digits: int) -> list[str]:
    return [fmt(float(np.rint(x * 10**digits)) / 10**digits, digits) for x in values_mm]


def move_text(move: OneMove, frame: Frame, digits: int, line: int, feed_mm_s: float,
              start_mm: np.ndarray) -> tuple[str, RationalFit, float, np.ndarray]:
    """The block that writes the move from start_mm (where the machine is: the move's start, or the
    previous move's end as written) in the program's frame (G90/G91, units, offsets, plane; a vertex
    end as exact as the source's numbers, another end and an arc's centre, in the program's
    arc-distance mode, to `digits` decimals), the path as written as a rational quadratic, how far the
    controller's arc may end from that curve's end (the end off the circle through the start, mm),
    and the end as written (mm)."""
    unit, off = frame.unit_mm, np.array(frame.offset_mm)
    end = (move.end - off) / unit if frame.absolute else (move.end - start_mm) / unit
    end_words = _words(end, END_DIGITS if move.vertex_end else digits)
    start_words = _words((start_mm - off) / unit, END_DIGITS) if frame.absolute else ["0"] * 3
    a, b, nrm = PLANE_AXES[move.plane]
    if move.centre_mm is not None:  # an arc stays at its start's normal coordinate (one_move: the path's)
        end_words[nrm] = start_words[nrm]
    written = np.array([float(v) for v in end_words])
    end_mm = written * unit + off if frame.absolute else start_mm + written * unit
    axes = [i for i in range(3) if float(end_words[i]) != float(start_words[i])]
    if move.centre_mm is None:
        text = move.code + "".join(f" {'XYZ'[i]}{end_words[i]}" for i in axes)
        pts = np.vstack([start_mm, 0.5 * (start_mm + end_mm), end_mm])
        return text, _conic(pts, 1.0), 0.0, end_mm
    centre = (move.centre_mm - off) / unit if frame.arc_absolute else (move.centre_mm - start_mm) / unit
    centre_words = _words(centre, digits)
    text = (move.code + "".join(f" {'XYZ'[i]}{end_words[i]}" for i in axes if i in (a, b))
            + "".join(f" {CENTRE_LETTERS[i]}{centre_words[i]}" for i in (a, b)))
    if any(i not in (a, b) for i in axes):
        raise ValueError(f"arc from {start_mm} to {move.end} leaves the {move.plane} plane")
    c = np.array([float(v) for v in centre_words]) * unit + (off if frame.arc_absolute else start_mm)
    arc = make_arc(line, tuple(start_mm), tuple(end_mm), move.plane, move.code == "G3", feed_mm_s, CONTINUOUS,
                   center_ab=(float(c[a]), float(c[b])), unit_mm=unit)
    return text, *arc_curve(arc), end_mm


def arc_curve(arc: Arc) -> tuple[RationalFit, float]:
    """A short arc (sweep below 180 degrees, in its plane) as the rational quadratic that is exactly its
    circle from the start, and the distance of the arc's end from that curve's end (the controller's
    end point is its own; a radius that differs at the end by rounding is this far off)."""
    a, b, n = PLANE_AXES[arc.plane]
    sweep = arc.sweep_rad
    if not 0.0 < abs(sweep) < math.pi or arc.start[n] != arc.end[n]:
        raise ValueError(f"not a short arc in the {arc.plane} plane: sweep {math.degrees(sweep):.1f} deg")
    r = arc.radius_mm
    a0 = math.atan2(arc.start[b] - arc.center[b], arc.start[a] - arc.center[a])
    pts = np.repeat(np.array([arc.start], dtype=float), 3, axis=0)
    for k, (angle, reach) in enumerate(((a0 + 0.5 * sweep, r / math.cos(0.5 * sweep)), (a0 + sweep, r)), 1):
        pts[k, a] = arc.center[a] + reach * math.cos(angle)
        pts[k, b] = arc.center[b] + reach * math.sin(angle)
    return _conic(pts, math.cos(0.5 * sweep)), float(np.linalg.norm(pts[2] - np.array(arc.end)))


def _conic(pts: np.ndarray, middle_weight: float) -> RationalFit:
    knots = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    return RationalFit(2, knots, np.array([1.0, middle_weight, 1.0]), pts, np.array([0.0, 1.0]), np.empty(0), True)
