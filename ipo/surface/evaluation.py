"""Rational B-spline surfaces: evaluation, normals and closest points (001 eq. 13, 16).

A surface is plain arrays, like the curves of ipo.nurbs.kernel: degrees, clamped knot
vectors in u and v, Cartesian control points P_ij (n_u, n_v, 3) and weights w_ij.
Everything is vectorised over many (u, v) pairs at once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.errors import SKIN, SURFACE_DATA, IpoError
from ipo.nurbs.kernel import basis_derivs, find_span


@dataclass(frozen=True, slots=True, eq=False)
class RationalSurface:
    """S(u, v) = sum N_i(u) N_j(v) w_ij P_ij / sum N_i(u) N_j(v) w_ij (001 eq. 16)."""

    degree_u: int
    degree_v: int
    knots_u: np.ndarray  # (n_u + degree_u + 1,)
    knots_v: np.ndarray  # (n_v + degree_v + 1,)
    weights: np.ndarray  # (n_u, n_v), all > 0
    points: np.ndarray  # (n_u, n_v, 3)

    def __post_init__(self):
        n_u, n_v = self.weights.shape
        if self.points.shape != (n_u, n_v, 3):
            raise IpoError(SURFACE_DATA, f"control net {self.points.shape} does not match weights {self.weights.shape}")
        if len(self.knots_u) != n_u + self.degree_u + 1 or len(self.knots_v) != n_v + self.degree_v + 1:
            raise IpoError(SURFACE_DATA, "knot vector lengths do not match the control net and degrees")
        if not np.all(self.weights > 0):
            raise IpoError(SURFACE_DATA, "surface weights must all be > 0")

    @property
    def u_range(self) -> tuple[float, float]:
        return float(self.knots_u[self.degree_u]), float(self.knots_u[-self.degree_u - 1])

    @property
    def v_range(self) -> tuple[float, float]:
        return float(self.knots_v[self.degree_v]), float(self.knots_v[-self.degree_v - 1])

    @property
    def homogeneous(self) -> np.ndarray:
        """P^w_ij = (w x, w y, w z, w), shape (n_u, n_v, 4) (001 eq. 13)."""
        return np.concatenate([self.points * self.weights[..., None], self.weights[..., None]], axis=2)


class NonPositiveWeight(IpoError):
    """A control net whose weights are not all > 0 (code E-IPO-SKIN: skinning made it)."""

    def __init__(self, message: str):
        super().__init__(SKIN, message)


def from_homogeneous(degree_u: int, degree_v: int, knots_u, knots_v, pw: np.ndarray) -> RationalSurface:
    w = pw[..., 3]
    if not np.all(w > 0):
        i, j = np.unravel_index(np.argmin(w), w.shape)
        raise NonPositiveWeight(f"a surface weight is not positive (w[{i},{j}] = {w[i, j]:.3g}): "
                         "the sections' weights vary too much to skin them")
    return RationalSurface(degree_u, degree_v, np.asarray(knots_u, float), np.asarray(knots_v, float),
                           w.copy(), pw[..., :3] / w[..., None])


def surface_derivs(surf: RationalSurface, u, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S, dS/du, dS/dv at the pairs (u[k], v[k]), each (K, 3) (NURBS Book eq. 4.20 to first order)."""
    u = np.atleast_1d(np.asarray(u, dtype=float))
    v = np.atleast_1d(np.asarray(v, dtype=float))
    p, q = surf.degree_u, surf.degree_v
    su = find_span(surf.knots_u, p, u)
    sv = find_span(surf.knots_v, q, v)
    bu = basis_derivs(surf.knots_u, p, u, 1, su)  # (2, K, p+1)
    bv = basis_derivs(surf.knots_v, q, v, 1, sv)
    iu = su[:, None] - p + np.arange(p + 1)[None, :]
    iv = sv[:, None] - q + np.arange(q + 1)[None, :]
    net = surf.homogeneous[iu[:, :, None], iv[:, None, :]]  # (K, p+1, q+1, 4)
    a = np.einsum("ki,kj,kijd->kd", bu[0], bv[0], net)
    a_u = np.einsum("ki,kj,kijd->kd", bu[1], bv[0], net)
    a_v = np.einsum("ki,kj,kijd->kd", bu[0], bv[1], net)
    w = a[:, 3:]
    s = a[:, :3] / w
    return s, (a_u[:, :3] - a_u[:, 3:] * s) / w, (a_v[:, :3] - a_v[:, 3:] * s) / w


def surface_points(surf: RationalSurface, u, v) -> np.ndarray:
    return surface_derivs(surf, u, v)[0]


def unit_normals(surf: RationalSurface, u, v) -> tuple[np.ndarray, np.ndarray]:
    """S and the unit normal S_u x S_v / |S_u x S_v|; a degenerate point (zero cross product) raises."""
    s, s_u, s_v = surface_derivs(surf, u, v)
    n = np.cross(s_u, s_v)
    length = np.linalg.norm(n, axis=1)
    bad = length <= 1e-12 * np.maximum(np.linalg.norm(s_u, axis=1) * np.linalg.norm(s_v, axis=1), 1e-300)
    if bad.any():
        k = int(np.argmax(bad))
        raise IpoError(SURFACE_DATA, f"the surface has no normal at u={np.atleast_1d(u)[k]:.6g}, "
                                     f"v={np.atleast_1d(v)[k]:.6g} (degenerate parametrisation)")
    return s, n / length[:, None]


def grid(surf: RationalSurface, n_u: int, n_v: int) -> tuple[np.ndarray, np.ndarray]:
    """Parameters of an n_u x n_v grid over the whole surface, flattened (u fastest in rows of v)."""
    uu = np.linspace(*surf.u_range, n_u)
    vv = np.linspace(*surf.v_range, n_v)
    gu, gv = np.meshgrid(uu, vv, indexing="ij")
    return gu.ravel(), gv.ravel()


def closest_points(surf: RationalSurface, q: np.ndarray, u0, v0, iterations: int = 30):
    """Foot points of q (K, 3) on the surface by damped Gauss–Newton from (u0, v0), clamped to the
    parameter box; returns (u, v, distance). The start must be near the answer (a local method)."""
    q = np.asarray(q, dtype=float)
    u = np.array(u0, dtype=float, copy=True)
    v = np.array(v0, dtype=float, copy=True)
    (u_lo, u_hi), (v_lo, v_hi) = surf.u_range, surf.v_range
    for _ in range(iterations):
        s, s_u, s_v = surface_derivs(surf, u, v)
        r = q - s
        a11 = np.einsum("kd,kd->k", s_u, s_u)
        a12 = np.einsum("kd,kd->k", s_u, s_v)
        a22 = np.einsum("kd,kd->k", s_v, s_v)
        b1 = np.einsum("kd,kd->k", s_u, r)
        b2 = np.einsum("kd,kd->k", s_v, r)
        det = a11 * a22 - a12**2
        det = np.where(np.abs(det) > 1e-300, det, 1e-300)
        du = (a22 * b1 - a12 * b2) / det
        dv = (a11 * b2 - a12 * b1) / det
        u_new = np.clip(u + du, u_lo, u_hi)
        v_new = np.clip(v + dv, v_lo, v_hi)
        step = np.max(np.abs(np.concatenate([u_new - u, v_new - v]))) if len(u) else 0.0
        u, v = u_new, v_new
        if step < 1e-13 * max(u_hi - u_lo, v_hi - v_lo):
            break
    return u, v, np.linalg.norm(q - surface_points(surf, u, v), axis=1)


def swap_uv(surf: RationalSurface) -> RationalSurface:
    """The same surface with the parameter directions exchanged (the normal flips)."""
    return RationalSurface(surf.degree_v, surf.degree_u, surf.knots_v, surf.knots_u, surf.weights.T.copy(),
                           surf.points.transpose(1, 0, 2).copy())


def c0_knots(knots: np.ndarray, degree: int) -> np.ndarray:
    """Interior knot values repeated `degree` times or more: across them the surface is only C0."""
    inner = np.asarray(knots, dtype=float)[degree + 1:-degree - 1]
    values, counts = np.unique(inner, return_counts=True)
    return values[counts >= degree]


def split_u(surf: RationalSurface, u_c: float) -> tuple[RationalSurface, RationalSurface]:
    """The patches u <= u_c and u >= u_c of a surface whose knot u_c is repeated degree_u times or more
    (no knot insertion needed: each side keeps its own control points, NURBS Book §5.3)."""
    p, k = surf.degree_u, surf.knots_u
    at = np.flatnonzero(k == u_c)
    if len(at) < p or at[0] <= p or at[-1] >= len(k) - p - 1:
        raise ValueError(f"u = {u_c} is not an interior knot of multiplicity >= {p}")
    first, mult = int(at[0]), len(at)
    j0 = first + mult - p - 1  # the right side's first control point (the shared one when mult == p)
    left = RationalSurface(p, surf.degree_v, np.concatenate([k[:first], np.full(p + 1, u_c)]), surf.knots_v,
                           surf.weights[:first].copy(), surf.points[:first].copy())
    right = RationalSurface(p, surf.degree_v, np.concatenate([np.full(p + 1, u_c), k[first + mult:]]),
                            surf.knots_v, surf.weights[j0:].copy(), surf.points[j0:].copy())
    return left, right


def split_at_c0(surf: RationalSurface) -> list[RationalSurface]:
    """The surface cut at every C0 knot in u, in order of u."""
    patches = [surf]
    for u_c in c0_knots(surf.knots_u, surf.degree_u):
        patches += split_u(patches.pop(), float(u_c))
    return patches


def nearest_distance(patches: list[RationalSurface], q: np.ndarray, u0, v0) -> np.ndarray:
    """Distance of points q (K, 3) to the union of patches: closest_points on each patch from (u0, v0)
    clamped into it, skipping a patch for points already nearer than its control hull's bounding box
    (the patch lies inside that box: positive weights)."""
    best = np.full(len(q), np.inf)
    u0 = np.broadcast_to(np.asarray(u0, dtype=float), (len(q),))
    v0 = np.broadcast_to(np.asarray(v0, dtype=float), (len(q),))
    for patch in patches:
        pts = patch.points.reshape(-1, 3)
        box = np.linalg.norm(np.maximum(np.maximum(pts.min(axis=0) - q, q - pts.max(axis=0)), 0.0), axis=1)
        near = box < best
        if near.any():
            d = closest_points(patch, q[near], np.clip(u0[near], *patch.u_range),
                               np.clip(v0[near], *patch.v_range))[2]
            best[near] = np.minimum(best[near], d)
    return best
