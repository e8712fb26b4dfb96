"""Ball-end finishing passes over a rational surface, written as Fanuc G06.2 groups.

The ball centre of a tool touching the surface at S(u, v) is S + r n (n the unit
normal towards the tool, +Z side). Passes run along u at constant v (or along v);
their v values are spaced so that the distance between neighbouring passes,
measured along the surface, is at most the pick feed everywhere. Each pass is
sampled densely, fitted with 001's rational approximation (fewest control points
within the tolerance, ipo.fit.tolerance) and checked against the surface itself:
every point of the fitted curve must lie at r from the surface within the
tolerance. Passes alternate direction; between passes the tool retracts to a safe
height, moves over the next start and plunges.

Creases: the surface is cut at its C0 knots across the passes (multiplicity >=
degree in u) and every side is offset on its own. Where the normals on the two
sides differ (a convex crease), the ball centre rolls about the crease point on a
circle of radius r from one normal to the other; that arc is written exactly, as a
rational quadratic group, between the fitted offsets of the two sides. A concave
crease (the surface turns towards the tool) is refused: a ball there touches both
sides at once and its centre is where the two offsets meet, not a rolling arc. Only a
slight concave kink (a C0 patch merge of smooth data), where a ball on one side cuts at
most CONCAVE_FRACTION of the tolerance into the other, is passed over through the
centre of the ball touching both sides. Every fit is checked against all the smooth
patches, so a C0 line along the passes is held to the tolerance too.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.errors import TOOLPATH_SETTINGS, TOOLPATH_SURFACE, IpoError
from ipo.fit.tolerance import FitSettings, fewest_ctrl
from ipo.fit.rational import RationalFit, evaluate
from ipo.surface.evaluation import (RationalSurface, nearest_distance, split_at_c0, surface_derivs, surface_points, swap_uv,
                                    unit_normals)

PLUNGE_FRACTION = 0.3  # plunge feed as a fraction of the cutting feed
CLEARANCE_MM = 5.0  # safe height above the highest tool-centre point
SAG_FRACTION = 0.1  # of the tolerance: chord sag allowed between a pass's samples
FIT_FRACTION = 0.8  # of the tolerance: what the fit may use (the rest covers sampling and rounding)
CONCAVE_FRACTION = 0.5  # of the tolerance: how deep a pass may cut into the far side of a concave kink
MAX_CTRL = 48  # a pass needing more control points is cut in two
FIRST_CTRL = 12
ACROSS_SAMPLES, ALONG_SAMPLES = 64, 1024


@dataclass(frozen=True, slots=True)
class ToolpathSettings:
    ball_mm: float
    pick_mm: float
    tol_mm: float = 0.005
    feed_mm_min: float = 1000.0
    spindle_rpm: float = 10000.0
    along: str = "u"
    degree: int = 3

    def check(self) -> None:
        if not self.ball_mm > 0:
            raise IpoError(TOOLPATH_SETTINGS, f"ball radius must be > 0 mm, got {self.ball_mm}")
        if not 0 < self.pick_mm < 2 * self.ball_mm:
            raise IpoError(TOOLPATH_SETTINGS,
                           f"pick feed must be > 0 and below the ball diameter {2 * self.ball_mm} mm, "
                           f"got {self.pick_mm}")
        if not self.tol_mm > 0:
            raise IpoError(TOOLPATH_SETTINGS, f"tolerance must be > 0 mm, got {self.tol_mm}")
        if not self.feed_mm_min > 0 or not self.spindle_rpm > 0:
            raise IpoError(TOOLPATH_SETTINGS, "feed and spindle speed must be > 0")
        if self.along not in ("u", "v"):
            raise IpoError(TOOLPATH_SETTINGS, f"passes run along 'u' or 'v', got {self.along!r}")


@dataclass(frozen=True, slots=True)
class Pass:
    """One pass at v = const: its samples (surface parameter u, tool centre) and its groups: fitted
    offsets and, at each convex crease it crosses, the exact rolling arc (degree 2)."""

    v: float
    u: np.ndarray
    centres: np.ndarray
    pieces: list[RationalFit]
    deviation_mm: float  # bound of | distance(curve point, surface) - r |: checked fit + what joins cut
    rolling_arcs: int = 0


def pass_values(surf: RationalSurface, pick_mm: float) -> np.ndarray:
    """v of each pass: g(v) = max over u of |S_v| bounds every iso-u line's speed, so equal steps
    of its integral G are at most pick_mm apart on the surface along every line."""
    uu = np.linspace(*surf.u_range, ACROSS_SAMPLES)
    vv = np.linspace(*surf.v_range, ALONG_SAMPLES)
    gu, gv = np.meshgrid(uu, vv, indexing="ij")
    s_v = surface_derivs(surf, gu.ravel(), gv.ravel())[2]
    g = np.linalg.norm(s_v, axis=1).reshape(gu.shape).max(axis=0)
    # trapezoids, plus the chord-vs-sample margin of a 1024-sample grid
    big_g = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(vv))]) * 1.01
    n = int(np.ceil(big_g[-1] / pick_mm)) + 1
    return np.interp(np.linspace(0.0, big_g[-1], n), big_g, vv)


def normal_sign(surf: RationalSurface) -> float:
    """+1 or -1 so that sign * (S_u x S_v) points to +Z on the whole; any part facing -Z raises."""
    uu = np.linspace(*surf.u_range, ACROSS_SAMPLES)
    vv = np.linspace(*surf.v_range, ACROSS_SAMPLES)
    gu, gv = np.meshgrid(uu, vv, indexing="ij")
    s, n = unit_normals(surf, gu.ravel(), gv.ravel())
    sign = 1.0 if n[:, 2].mean() >= 0 else -1.0
    nz = sign * n[:, 2]
    if nz.min() < 0:
        k = int(np.argmin(nz))
        raise IpoError(TOOLPATH_SURFACE,
                       f"the surface faces away from a tool coming from +Z near "
                       f"({s[k, 0]:.3f}, {s[k, 1]:.3f}, {s[k, 2]:.3f}): undercut, not machinable with 3 axes")
    return sign


def centres_at(surf: RationalSurface, u: np.ndarray, v: float, r: float, sign: float) -> tuple[np.ndarray, np.ndarray]:
    s, n = unit_normals(surf, u, np.full(len(u), v))
    return s, s + r * sign * n


def _samples(surf: RationalSurface, v: float, r: float, sign: float, tol_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """u samples of a pass dense enough that the centre polyline sags < SAG_FRACTION * tol."""
    u = np.linspace(*surf.u_range, 201)
    _, c = centres_at(surf, u, v, r, sign)
    a, b = c[1:] - c[:-1], c[2:] - c[:-2]
    cross = np.linalg.norm(np.cross(a[:-1], a[1:]), axis=1)
    denom = np.linalg.norm(a[:-1], axis=1) * np.linalg.norm(a[1:], axis=1) * np.linalg.norm(b, axis=1)
    kappa = float(np.max(2 * cross / np.maximum(denom, 1e-300)))  # circle through three samples
    length = float(np.linalg.norm(a, axis=1).sum())
    h = np.sqrt(8 * SAG_FRACTION * tol_mm / max(kappa, 1e-12))
    n = int(np.clip(np.ceil(length / h), 50, 4000)) + 1
    u = np.linspace(*surf.u_range, n)
    s, c = centres_at(surf, u, v, r, sign)
    fold = np.einsum("ij,ij->i", np.diff(c, axis=0), np.diff(s, axis=0)) <= 0
    if fold.any():
        k = int(np.argmax(fold))
        raise IpoError(TOOLPATH_SURFACE,
                       f"the tool-centre path folds back (gouge) near ({s[k, 0]:.3f}, {s[k, 1]:.3f}, "
                       f"{s[k, 2]:.3f}): the ball (r = {r} mm) is larger than the surface's concave radius of "
                       "curvature there, or the surface has a concave crease (a C0 patch joint)")
    return u, c


def offset_deviation(patches: list[RationalSurface], fit: RationalFit, u_data: np.ndarray, v: float,
                     r: float) -> float:
    """Largest | distance to the surface - r | over points of the fitted curve, 4 per data interval;
    the surface is given as its smooth patches (c0_grid), so a pass is checked against both sides of
    every C0 line near it."""
    t = np.linspace(fit.knots[0], fit.knots[-1], 4 * len(u_data))
    dist = nearest_distance(patches, evaluate(fit, t), np.interp(t, fit.params, u_data), v)
    return float(np.max(np.abs(dist - r)))


def _fit_span(patches, v, r, u, c, s: ToolpathSettings) -> tuple[list[RationalFit], float]:
    settings = FitSettings(tol_mm=FIT_FRACTION * s.tol_mm, degree=s.degree)
    fit = None
    for m_max in (FIRST_CTRL, MAX_CTRL):  # fewest_ctrl tries m_max first: a small one first is cheaper
        found = fewest_ctrl(c, settings, min(len(c), m_max))
        if found is not None:
            fit = found[0]
            break
    if fit is not None:
        dev = offset_deviation(patches, fit, u, v, r)
        if dev <= s.tol_mm:
            return [fit], dev
    if len(c) < 4 * (s.degree + 2):
        raise IpoError(TOOLPATH_SURFACE, f"a pass at v = {v:.6g} cannot be fitted within {s.tol_mm} mm")
    mid = len(c) // 2
    left, dev_l = _fit_span(patches, v, r, u[:mid + 1], c[:mid + 1], s)
    right, dev_r = _fit_span(patches, v, r, u[mid:], c[mid:], s)
    return left + right, max(dev_l, dev_r)


def surface_patches(surf: RationalSurface) -> list[RationalSurface]:
    """The surface cut at its C0 knots in u, in order of u; sides that do not meet raise."""
    patches = split_at_c0(surf)
    vv = np.linspace(*surf.v_range, ACROSS_SAMPLES)
    size = float(np.ptp(surf.points.reshape(-1, 3), axis=0).max())
    for a, b in zip(patches, patches[1:]):
        u_c = a.u_range[1]
        gap = np.linalg.norm(surface_points(a, np.full(len(vv), u_c), vv)
                             - surface_points(b, np.full(len(vv), u_c), vv), axis=1).max()
        if gap > 1e-9 * size:
            raise IpoError(TOOLPATH_SURFACE, f"the surface is not continuous across u = {u_c:.6g}: its sides are up to "
                                             f"{gap:.3g} mm apart there")
    return patches


@dataclass(frozen=True, slots=True)
class Crease:
    """Where a pass crosses a convex C0 line: the crease point and the unit normals before and after it."""

    u: float
    corner: np.ndarray
    n_before: np.ndarray
    n_after: np.ndarray


@dataclass(frozen=True, slots=True)
class Join:
    """A joint a pass crosses with its two offsets joined straight; at a concave kink the centre of the
    ball touching both sides' tangent planes, which replaces the offsets' ends."""

    both_sides: np.ndarray | None


def _joint(left: RationalSurface, right: RationalSurface, v: float, sign: float):
    """The joint point at v, the unit normals either side, and whether the surface turns away from the
    tool there (convex)."""
    u_c = left.u_range[1]
    s_l, t_l, _ = surface_derivs(left, [u_c], [v])
    _, t_r, _ = surface_derivs(right, [u_c], [v])
    n_l = sign * unit_normals(left, [u_c], [v])[1][0]
    n_r = sign * unit_normals(right, [u_c], [v])[1][0]
    ahead = t_l[0] / np.linalg.norm(t_l[0]) + t_r[0] / np.linalg.norm(t_r[0])
    return s_l[0], n_l, n_r, bool((n_r - n_l) @ ahead >= 0)  # a concave joint turns the normal back


def _join_cost(r: float, n_l: np.ndarray, n_r: np.ndarray) -> float:
    """How deep a ball centred on one side's offset next to the joint may cut into the other side:
    r (1 - cos angle), its distance r cos(angle) from the other side's tangent plane."""
    return r * (1.0 - float(np.clip(n_l @ n_r, -1.0, 1.0)))


def _concave_error(point: np.ndarray, n_l: np.ndarray, n_r: np.ndarray, cost: float, tol_mm: float):
    x, y, z = point
    angle = np.degrees(np.arccos(np.clip(n_l @ n_r, -1.0, 1.0)))
    return IpoError(TOOLPATH_SURFACE,
                    f"concave crease (C0 joint) near ({x:.3f}, {y:.3f}, {z:.3f}): the surface turns by "
                    f"{angle:.2f} deg towards the tool there, so a ball touching one side cuts up to "
                    f"{cost * 1e3:.2f} um into the other, over {CONCAVE_FRACTION * tol_mm * 1e3:.2f} um "
                    f"({CONCAVE_FRACTION:g} of the tolerance); not handled (machine the sides separately)")


def crease_at(left: RationalSurface, right: RationalSurface, v: float, r: float, sign: float,
              tol_mm: float) -> Crease | Join:
    """The crease a pass at v crosses between two patches; or, where the offsets of the two sides can be
    joined straight (a convex kink costing <= SAG_FRACTION * tol, a concave one <= CONCAVE_FRACTION *
    tol), that join. A sharper concave joint raises."""
    point, n_l, n_r, convex = _joint(left, right, v, sign)
    cost = _join_cost(r, n_l, n_r)
    if convex:
        return Crease(left.u_range[1], point, n_l, n_r) if cost > SAG_FRACTION * tol_mm else Join(None)
    if cost > CONCAVE_FRACTION * tol_mm:
        raise _concave_error(point, n_l, n_r, cost, tol_mm)
    return Join(point + r * (n_l + n_r) / (1.0 + n_l @ n_r))  # on the bisector at r / cos(angle / 2)


def rolling_arc(corner: np.ndarray, n_from: np.ndarray, n_to: np.ndarray, r: float) -> RationalFit:
    """The ball centre rolling about a crease point from one unit normal to the other: the circle of
    radius r as rational quadratic segments of at most 90 deg (middle weight cos of the half angle)."""
    cos_a = float(np.clip(n_from @ n_to, -1.0, 1.0))
    angle = float(np.arccos(cos_a))
    e2 = n_to - cos_a * n_from
    e2 = e2 / np.linalg.norm(e2)
    segs = int(np.ceil(angle / (np.pi / 2)))
    half = angle / (2 * segs)
    a = np.linspace(0.0, angle, 2 * segs + 1)
    middle = np.arange(2 * segs + 1) % 2 == 1
    radius = np.where(middle, r / np.cos(half), r)
    points = corner + radius[:, None] * (np.cos(a)[:, None] * n_from + np.sin(a)[:, None] * e2)
    weights = np.where(middle, np.cos(half), 1.0)
    knots = np.concatenate([np.zeros(3), np.repeat(np.arange(1.0, segs), 2), np.full(3, float(segs))])
    return RationalFit(2, knots, weights, points, np.array([0.0, float(segs)]), np.empty(0), True)


def _refuse_gouge(grid: list[RationalSurface], u: np.ndarray, v: float, c: np.ndarray, s: ToolpathSettings):
    """The exact tool centres of a pass against every smooth patch: a ball on one side of a concave C0
    line (along the pass, or a kink joined straight across it) may reach into the other side."""
    d = nearest_distance(grid, c, u, v)
    k = int(np.argmin(d))
    if d[k] < s.ball_mm - CONCAVE_FRACTION * s.tol_mm:
        x, y, z = c[k]
        raise IpoError(TOOLPATH_SURFACE,
                       f"concave crease (C0 joint): the ball centred at ({x:.3f}, {y:.3f}, {z:.3f}) cuts "
                       f"{(s.ball_mm - d[k]) * 1e3:.2f} um into the surface beyond the joint, over "
                       f"{CONCAVE_FRACTION * s.tol_mm * 1e3:.2f} um ({CONCAVE_FRACTION:g} of the tolerance); "
                       "not handled (machine the sides separately)")


def _plan_pass(patches: list[RationalSurface], grid: list[RationalSurface], v: float, sign: float,
               s: ToolpathSettings, reverse: bool) -> Pass:
    """One pass: the offsets of runs of patches joined straight, each fitted, and rolling arcs between
    the runs; every fit is checked against all smooth patches (grid)."""
    r = s.ball_mm
    joints = [crease_at(a, b, v, r, sign, s.tol_mm) for a, b in zip(patches, patches[1:])]
    samples = [_samples(patch, v, r, sign, s.tol_mm) for patch in patches]
    runs = [[samples[0]]]
    for sample, joint in zip(samples[1:], joints):
        if isinstance(joint, Crease):
            runs.append([sample])
            continue
        if joint.both_sides is not None:  # the offsets overlap: both ends give way to that one centre
            u, c = runs[-1][-1]
            runs[-1][-1] = (u, np.vstack([c[:-1], joint.both_sides]))
        runs[-1].append(sample)  # its first sample is dropped below
    creases = [c for c in joints if isinstance(c, Crease)]
    segments = []
    for k, run in enumerate(runs):
        u = np.concatenate([run[0][0]] + [x[0][1:] for x in run[1:]])
        c = np.concatenate([run[0][1]] + [x[1][1:] for x in run[1:]])
        if len(grid) > 1:
            _refuse_gouge(grid, u, v, c, s)
        segments.append((u, c))
        if k < len(creases):
            segments.append(creases[k])
    if reverse:
        segments = [seg if isinstance(seg, Crease) else (seg[0][::-1].copy(), seg[1][::-1].copy())
                    for seg in segments[::-1]]
    pieces, devs, us, cs = [], [], [], []
    for seg in segments:
        if isinstance(seg, Crease):
            n_from, n_to = (seg.n_after, seg.n_before) if reverse else (seg.n_before, seg.n_after)
            arc = rolling_arc(seg.corner, n_from, n_to, r)
            c = evaluate(arc, np.linspace(0.0, arc.knots[-1], 8 * len(arc.points)))
            pieces.append(arc)
            devs.append(float(np.max(np.abs(np.linalg.norm(c - seg.corner, axis=1) - r))))
            u = np.full(len(c), seg.u)
        else:
            u, c = seg
            fitted, dev = _fit_span(grid, v, r, u, c, s)
            pieces += fitted
            devs.append(dev)
        us.append(u)
        cs.append(c)
    return Pass(v, np.concatenate(us), np.concatenate(cs), pieces, max(devs), len(creases))


def plan_passes(surf: RationalSurface, s: ToolpathSettings) -> list[Pass]:
    """Every pass, fitted and checked; passes alternate direction (zig-zag)."""
    s.check()
    work = surf if s.along == "u" else swap_uv(surf)
    sign = normal_sign(work)
    patches = surface_patches(work)
    grid = [swap_uv(q) for p in patches for q in surface_patches(swap_uv(p))]  # smooth: cut in v as well
    return [_plan_pass(patches, grid, float(v), sign, s, bool(k % 2))
            for k, v in enumerate(pass_values(work, s.pick_mm))]


def _fmt(value: float, digits: int) -> str:
    text = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def group_blocks(fit: RationalFit, feed_mm_min: float) -> list[str]:
    """Fanuc G06.2 blocks: the first carries no axis word (control point 1 is the current position)."""
    k, w, p = fit.knots, fit.weights, fit.points

    def r_word(i):
        return "" if w[i] == 1.0 else f" R{_fmt(w[i], 9)}"

    out = [f"G06.2 P{fit.degree + 1} K{_fmt(k[0], 6)}{r_word(0)} F{_fmt(feed_mm_min, 3)}"]
    for i in range(1, len(p)):
        x, y, z = (_fmt(c, 4) for c in p[i])
        out.append(f"K{_fmt(k[i], 6)} X{x} Y{y} Z{z}{r_word(i)}")
    out += [f"K{_fmt(x, 6)}" for x in k[len(p):]]
    return out


def program_text(passes: list[Pass], s: ToolpathSettings, source: str = "surface") -> str:
    """The finishing program: tool-centre coordinates, G21 G90, one G06.2 group per fitted piece."""
    safe_z = max(float(p.centres[:, 2].max()) for p in passes) + CLEARANCE_MM
    plunge = s.feed_mm_min * PLUNGE_FRACTION
    n_groups = sum(len(p.pieces) for p in passes)
    lines = [
        f"(vcnc toolpath: ball-end finishing of {source})",
        f"(ball radius {s.ball_mm} mm, pick feed {s.pick_mm} mm, {len(passes)} passes along {s.along}, "
        f"{n_groups} G06.2 groups, tolerance {s.tol_mm} mm)",
        "(coordinates are the ball CENTRE: surface point + r x unit normal)",
        f"(roughness limiter: run with a machine file whose [finishing] has pick_feed_mm = {s.pick_mm} "
        f"and a tool of ball_radius_mm = {s.ball_mm})",
        "G21 G17 G90 G94 G64",
        f"S{_fmt(s.spindle_rpm, 1)} M3",
        f"G0 Z{_fmt(safe_z, 4)}",
    ]
    for p in passes:
        x, y, z = (_fmt(c, 4) for c in p.centres[0])
        lines += [f"G0 X{x} Y{y}", f"G1 Z{z} F{_fmt(plunge, 3)}"]
        for fit in p.pieces:
            lines += group_blocks(fit, s.feed_mm_min)
        lines.append(f"G0 Z{_fmt(safe_z, 4)}")
    lines += ["M5", "M30"]
    return "\n".join(lines) + "\n"
