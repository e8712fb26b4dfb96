"""Compatible section curves -> skinned surface -> merged patches (001 §3–4).

The sections arrive fitted with the same order, control-point count and uniform
clamped knot vector (ipo.surface.section_fit), so that they are compatible (001 eq. 12).
Skinning interpolates, for each u-index i, the sections' homogeneous control points
P^w_{i,h} across the sections (001 eq. 15) at parameters v_h from averaged chord
lengths, on knots averaged from them (not 001's uniform knots: see averaged_knots).
Patches built from consecutive groups of sections share their boundary section and
are merged along v with C0 or C1 continuity (001 eq. 17–18) into one surface with a
degree-fold knot at each joint.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.errors import FIT_SETTINGS, SKIN, IpoError
from ipo.fit.rational import RationalFit, basis_matrix
from ipo.surface.evaluation import NonPositiveWeight, RationalSurface, closest_points, from_homogeneous


def chord_v(net: np.ndarray, v_max: float) -> np.ndarray:
    """v_h from chord lengths between consecutive sections, averaged over the u-index i (NURBS Book
    eq. 10.8), scaled to [0, v_max]. net: (n_u, n_sections, 3) Cartesian control points."""
    steps = np.linalg.norm(np.diff(net, axis=1), axis=2)  # (n_u, l)
    total = steps.sum(axis=1)
    if np.any(total <= 0):
        raise IpoError(SKIN, "two sections coincide: cannot skin across them")
    cum = np.concatenate([np.zeros((len(net), 1)), np.cumsum(steps, axis=1)], axis=1) / total[:, None]
    return v_max * cum.mean(axis=0)


def averaged_knots(v_h: np.ndarray, degree: int) -> np.ndarray:
    """Clamped knots by averaging the parameters (NURBS Book eq. 9.8).

    001 skins on uniform knots; with chord-length v_h that interpolation is poorly conditioned
    near the ends (condition number 106 for 41 sections against 3.9 here) and it amplified 5 um
    of measurement noise into a 0.59 mm wave between the first sections of a bump; averaged
    knots kept the same data within 14 um of the true surface."""
    q = degree
    inner = np.array([v_h[j:j + q].mean() for j in range(1, len(v_h) - q)])
    return np.concatenate([np.full(q + 1, v_h[0]), inner, np.full(q + 1, v_h[-1])])


def skin(fits: list[RationalFit], degree_v: int | None = None) -> tuple[RationalSurface, np.ndarray]:
    """The skinned surface through compatible section curves and the sections' v parameters."""  # 001 eq. 15
    if len(fits) < 2:
        raise IpoError(SKIN, f"skinning needs at least 2 sections, got {len(fits)}")
    first = fits[0]
    for h, f in enumerate(fits[1:], 1):
        if f.degree != first.degree or not np.array_equal(f.knots, first.knots):
            raise IpoError(SKIN, f"section {h + 1} is not compatible with section 1 (degree or knots differ)")
    n_sec = len(fits)
    q = min(first.degree if degree_v is None else degree_v, n_sec - 1)
    # each section's weights are only defined up to a factor: a geometric mean of 1 keeps them
    # level across the sections, so that their interpolant (eq. 15) overshoots least
    scale = [np.exp(-np.mean(np.log(f.weights))) for f in fits]
    pw = np.stack([np.concatenate([f.points * f.weights[:, None], f.weights[:, None]], axis=1) * c
                   for f, c in zip(fits, scale)], axis=1)  # (n_u, n_sec, 4): P^w_{i,h} (001 eq. 12)
    v_h = chord_v(np.stack([f.points for f in fits], axis=1), float(n_sec - q))
    knots_v = averaged_knots(v_h, q)
    n_mat = basis_matrix(knots_v, q, v_h, n_sec)
    n_u = pw.shape[0]
    rhs = pw.transpose(1, 0, 2).reshape(n_sec, n_u * 4)
    sol = np.linalg.solve(n_mat, rhs)  # Gaussian elimination, all i at once (001 eq. 15)
    net = sol.reshape(n_sec, n_u, 4).transpose(1, 0, 2)
    return from_homogeneous(first.degree, q, first.knots, knots_v, net), v_h


def merge_v(s1: RationalSurface, s2: RationalSurface, continuity: str = "C1") -> RationalSurface:
    """S1 then S2 along v as one surface. s2's first control column must be s1's last
    (shared boundary section, 001 eq. 17); C1 moves s2's second column, in homogeneous
    coordinates, to P_l + (d2/d1)(P_l - P_{l-1}) with d1, d2 the knot spans either side of the
    joint: 001 eq. 18 (2 P_l - P_{l-1}) where the spans are equal, as on its uniform knots."""
    if continuity not in ("C0", "C1"):
        raise IpoError(FIT_SETTINGS, f"continuity must be C0 or C1, got {continuity!r}")
    if (s1.degree_u, s1.degree_v) != (s2.degree_u, s2.degree_v) or not np.array_equal(s1.knots_u, s2.knots_u):
        raise IpoError(SKIN, "patches to merge need the same degrees and u knot vector")
    q = s1.degree_v
    a, b = s1.homogeneous, s2.homogeneous.copy()
    gap = np.max(np.linalg.norm(s1.points[:, -1] - s2.points[:, 0], axis=1))
    if gap > 1e-9 * max(np.ptp(s1.points.reshape(-1, 3), axis=0).max(), 1.0):
        raise IpoError(SKIN, f"patches do not share a boundary (control points {gap:.3g} mm apart)")
    b[:, 0] = a[:, -1]  # 001 eq. 17
    if continuity == "C1":
        span1 = s1.knots_v[-1] - s1.knots_v[-q - 2]
        span2 = s2.knots_v[q + 1] - s2.knots_v[0]
        b[:, 1] = a[:, -1] + (span2 / span1) * (a[:, -1] - a[:, -2])  # 001 eq. 18, general spans
    joint = s1.knots_v[-1]
    knots_v = np.concatenate([s1.knots_v[:-1], s2.knots_v[q + 1:] - s2.knots_v[0] + joint])
    net = np.concatenate([a, b[:, 1:]], axis=1)
    return from_homogeneous(s1.degree_u, q, s1.knots_u, knots_v, net)


def patch_groups(n_sections: int, per_patch: int) -> list[tuple[int, int]]:
    """(first, last) section index of each patch; neighbours share their boundary section."""
    if per_patch < 2:
        raise IpoError(FIT_SETTINGS, f"a patch needs at least 2 sections, got {per_patch}")
    n_patches = max(1, int(np.ceil((n_sections - 1) / (per_patch - 1))))
    bounds = np.linspace(0, n_sections - 1, n_patches + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


@dataclass(frozen=True, slots=True)
class SkinResult:
    surface: RationalSurface
    section_v: np.ndarray  # v of each section on the merged surface (before any C1 move)
    patches: list[tuple[int, int]]


def skin_patches(fits: list[RationalFit], per_patch: int | None = None, continuity: str = "C1") -> SkinResult:
    """One skinned patch, or patches of `per_patch` sections merged along v.

    The v degree is the sections' degree (at most a patch's section count - 1); where the
    interpolated weights would not all stay positive, the next lower degree is used (degree 1
    blends neighbouring sections' homogeneous points convexly, so its weights are positive)."""
    if len(fits) < 2:
        raise IpoError(SKIN, f"a surface is skinned through two or more sections; the points hold {len(fits)}")
    groups = [(0, len(fits) - 1)] if per_patch is None else patch_groups(len(fits), per_patch)
    top = min(fits[0].degree, min(b - a for a, b in groups))
    for degree_v in range(top, 0, -1):
        try:
            return _skin_groups(fits, groups, degree_v, continuity)
        except NonPositiveWeight:
            if degree_v == 1:
                raise
    raise AssertionError("unreachable")


def _skin_groups(fits, groups, degree_v, continuity) -> SkinResult:
    surface, section_v = None, []
    for a, b in groups:
        patch, v_h = skin(fits[a:b + 1], degree_v)
        if surface is None:
            surface, section_v = patch, list(v_h)
        else:
            offset = surface.knots_v[-1]
            surface = merge_v(surface, patch, continuity)
            section_v += list(v_h[1:] + offset)
    return SkinResult(surface, np.array(section_v), groups)


def deviation_from_points(surf: RationalSurface, fits: list[RationalFit], sections: list[np.ndarray],
                          section_v: np.ndarray) -> np.ndarray:
    """Distance of every input point to the surface (foot point found from the section fit's u and
    the section's v); one array over all sections in order."""
    q = np.concatenate(sections)
    u0 = np.concatenate([f.params for f in fits])
    v0 = np.concatenate([np.full(len(s), v) for s, v in zip(sections, section_v)])
    return closest_points(surf, q, u0, v0)[2]
