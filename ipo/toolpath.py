"""Ball-end finishing passes over a rational surface, written as Fanuc G06.2 groups.

The ball centre of a tool touching the surface at S(u, v) is S + r n (n the unit
normal towards the tool, +Z side). Passes run along u at constant v (or along v);
their v values are spaced so that the distance between neighbouring passes,
measured along the surface, is at most the pick feed everywhere. Each pass is
sampled densely, fitted with 001's rational approximation (fewest control points
within the tolerance, ipo.fit_tolerance) and checked against the surface itself:
every point of the fitted curve must lie at r from the surface within the
tolerance. Passes alternate direction; between passes the tool retracts to a safe
height, moves over the next start and plunges.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.fit_tolerance import FitSettings, fewest_ctrl
from ipo.rational_fit import RationalFit, evaluate
from ipo.surface import RationalSurface, closest_points, surface_derivs, swap_uv, unit_normals

PLUNGE_FRACTION = 0.3  # plunge feed as a fraction of the cutting feed
CLEARANCE_MM = 5.0  # safe height above the highest tool-centre point
SAG_FRACTION = 0.1  # of the tolerance: chord sag allowed between a pass's samples
FIT_FRACTION = 0.8  # of the tolerance: what the fit may use (the rest covers sampling and rounding)
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
            raise ValueError(f"ball radius must be > 0 mm, got {self.ball_mm}")
        if not 0 < self.pick_mm < 2 * self.ball_mm:
            raise ValueError(f"pick feed must be > 0 and below the ball diameter {2 * self.ball_mm} mm, "
                             f"got {self.pick_mm}")
        if not self.tol_mm > 0:
            raise ValueError(f"tolerance must be > 0 mm, got {self.tol_mm}")
        if not self.feed_mm_min > 0 or not self.spindle_rpm > 0:
            raise ValueError("feed and spindle speed must be > 0")
        if self.along not in ("u", "v"):
            raise ValueError(f"passes run along 'u' or 'v', got {self.along!r}")


@dataclass(frozen=True, slots=True)
class Pass:
    """One pass at v = const: its samples (surface parameter u, tool centre) and fitted pieces."""

    v: float
    u: np.ndarray
    centres: np.ndarray
    pieces: list[RationalFit]
    deviation_mm: float  # largest | distance(curve point, surface) - r | over the fitted pieces


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
        raise ValueError(f"the surface faces away from a tool coming from +Z near "
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
        raise ValueError(f"the tool-centre path folds back (gouge) near ({s[k, 0]:.3f}, {s[k, 1]:.3f}, "
                         f"{s[k, 2]:.3f}): the ball (r = {r} mm) is larger than the surface's concave radius of "
                         "curvature there, or the surface has a concave crease (a C0 patch joint)")
    return u, c


def offset_deviation(surf: RationalSurface, fit: RationalFit, u_data: np.ndarray, v: float, r: float) -> float:
    """Largest | distance to the surface - r | over points of the fitted curve, 4 per data interval."""
    t = np.linspace(fit.knots[0], fit.knots[-1], 4 * len(u_data))
    pts = evaluate(fit, t)
    u0 = np.interp(t, fit.params, u_data)
    _, _, dist = closest_points(surf, pts, u0, np.full(len(t), v))
    return float(np.max(np.abs(dist - r)))


def _fit_span(surf, v, r, u, c, s: ToolpathSettings) -> tuple[list[RationalFit], float]:
    settings = FitSettings(tol_mm=FIT_FRACTION * s.tol_mm, degree=s.degree)
    fit = None
    for m_max in (FIRST_CTRL, MAX_CTRL):  # fewest_ctrl tries m_max first: a small one first is cheaper
        found = fewest_ctrl(c, settings, min(len(c), m_max))
        if found is not None:
            fit = found[0]
            break
    if fit is not None:
        dev = offset_deviation(surf, fit, u, v, r)
        if dev <= s.tol_mm:
            return [fit], dev
    if len(c) < 4 * (s.degree + 2):
        raise ValueError(f"a pass at v = {v:.6g} cannot be fitted within {s.tol_mm} mm")
    mid = len(c) // 2
    left, dev_l = _fit_span(surf, v, r, u[:mid + 1], c[:mid + 1], s)
    right, dev_r = _fit_span(surf, v, r, u[mid:], c[mid:], s)
    return left + right, max(dev_l, dev_r)


def plan_passes(surf: RationalSurface, s: ToolpathSettings) -> list[Pass]:
    """Every pass, fitted and checked; passes alternate direction (zig-zag)."""
    s.check()
    work = surf if s.along == "u" else swap_uv(surf)
    sign = normal_sign(work)
    passes = []
    for k, v in enumerate(pass_values(work, s.pick_mm)):
        u, c = _samples(work, float(v), s.ball_mm, sign, s.tol_mm)
        if k % 2:
            u, c = u[::-1].copy(), c[::-1].copy()
        pieces, dev = _fit_span(work, float(v), s.ball_mm, u, c, s)
        passes.append(Pass(float(v), u, c, pieces, dev))
    return passes


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
