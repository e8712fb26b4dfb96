"""What a machined surface shows: deviation from a reference, gouges with their program line, the scallop
across the passes and the roughness and facets along them.

Profiles are rows (along X) or columns (along Y) of the Z-map. Along the feed, a profile is measured as
its deviation from the reference when there is one (the form removed exactly), else from its mean line,
ISO 16610-31's Gaussian regression filter of degree 2 (mean_line_kernel) with cut-off CUTOFF_MM (2.5 mm, ISO 4288's for Ra 2-10 um: longer than
the chords of a finishing program, so facets stay in the roughness; a fifth of the profile where it is
shorter than ISO's five cut-offs). Rz is the profile's peak-to-valley, Ra its mean absolute deviation
from its mean. Facets are the arches between consecutive valleys of the deviation (the tool's path has a
vertex over each valley; a valley must stand out by FACET_PROMINENCE of the profile's Rz): spacing is the valleys' median distance, depth the median height of each arch
above the line joining its two valleys. The scallop across the passes is measured the same way on a
profile across them, and set beside the classical cusp h = r - sqrt(r^2 - (s/2)^2).

Where the program is known, the facets of its straight blocks are found by the Z-map's lines instead
(chord_facets): the shape cannot show chords whose sagitta is as low as the BLU ripple.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from machine.workpiece.zmap import Surface

NOISE_FLOOR_MM = 2e-5  # 0.02 um: arches lower than this are float32 noise, not facets
FACET_PROMINENCE = 0.5  # a facet's valleys stand out by half the profile's Rz: BLU ripple does not split it
CUTOFF_MM = 2.5
GAUSS_ALPHA = math.sqrt(math.log(2.0) / math.pi)  # ISO 16610-21 weighting function


@dataclass(frozen=True, slots=True)
class ProfileFigures:
    length_mm: float
    rz_um: float
    ra_um: float
    facets: int
    facet_spacing_mm: float | None
    facet_depth_um: float | None


def profile(surface: Surface, along: str, at_mm: float, lo_mm: float = -math.inf, hi_mm: float = math.inf,
            reference: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(s_mm, d_mm): positions along X (along = "x", the row nearest y = at_mm) or Y, and the heights, or
    their deviation from `reference` (same shape as z_mm) when given, restricted to [lo_mm, hi_mm]."""
    values = surface.z_mm if reference is None else surface.z_mm - reference
    s, at = _section(surface, along, at_mm)
    d = values[at]
    keep = (s >= lo_mm) & (s <= hi_mm) & np.isfinite(d)
    return s[keep], d[keep]


def _section(surface: Surface, along: str, at_mm: float) -> tuple[np.ndarray, tuple]:
    """The positions along a profile and its index into the Z-map's arrays."""
    if along == "x":
        return surface.x_mm, (int(np.argmin(np.abs(surface.y_mm - at_mm))), slice(None))
    return surface.y_mm, (slice(None), int(np.argmin(np.abs(surface.x_mm - at_mm))))


def chord_facets(surface: Surface, along: str, at_mm: float, lo_mm: float, hi_mm: float, reference: np.ndarray,
                 straight: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """(lengths, depths) in mm of the facets that straight blocks left along a profile, found by the lines
    that cut its nodes rather than by its shape: each run of nodes cut by one straight block (a line in
    `straight`) is a facet, but for the runs at the window's ends (cut short); its length is the run's
    extent, its depth the most the deviation from the reference sinks below the chord joining its ends."""
    s, at = _section(surface, along, at_mm)
    d, lines = (surface.z_mm - reference)[at], surface.line[at]
    keep = (s >= lo_mm) & (s <= hi_mm) & np.isfinite(d)
    s, d, lines = s[keep], d[keep], lines[keep]
    bounds = np.flatnonzero(np.diff(lines)) + 1
    lengths, depths = [], []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a >= 3 and int(lines[a]) in straight:
            chord = np.interp(s[a:b], [s[a], s[b - 1]], [d[a], d[b - 1]])
            lengths.append(float(s[b] - s[a]))
            depths.append(float(np.max(chord - d[a:b])))
    return np.array(lengths), np.array(depths)


def mean_line_kernel(step_mm: float, cutoff_mm: float) -> np.ndarray:
    """The weights of ISO 16610-31's Gaussian regression filter of degree 2 at a uniform step: at each point
    the value at it of the quadratic fitted by least squares with the Gaussian weights w(u) of ISO 16610-21
    (50 % transmission at the cut-off). For a symmetric w that is w(u) (m4 - m2 u^2) / (m0 m4 - m2^2) with
    the moments m_k = sum w u^k: it passes quadratics unchanged, so a curved form leaves no offset in the
    roughness (the plain Gaussian's mean line sags by about sigma^2 / 2R into a surface of radius R)."""
    half = int(math.ceil(cutoff_mm / step_mm))
    u = step_mm * np.arange(-half, half + 1)
    w = np.exp(-math.pi * (u / (GAUSS_ALPHA * cutoff_mm)) ** 2)
    m0, m2, m4 = w.sum(), (w * u**2).sum(), (w * u**4).sum()
    return w * (m4 - m2 * u**2) / (m0 * m4 - m2 * m2)


def detrend(s_mm: np.ndarray, d_mm: np.ndarray) -> np.ndarray:
    """The profile less its mean line (mean_line_kernel: the form, where no reference removes it); nan
    within one cut-off of either end, where the mean line has no data on one side (ISO 16610's end
    effect)."""
    if len(s_mm) < 3:
        return d_mm - d_mm.mean()
    step = float(s_mm[1] - s_mm[0])
    cutoff = min(CUTOFF_MM, (s_mm[-1] - s_mm[0]) / 5.0)
    kernel = mean_line_kernel(step, cutoff)
    if len(kernel) > len(d_mm):
        return np.full_like(d_mm, np.nan)
    r = d_mm - np.convolve(d_mm, kernel, mode="same")
    return np.where((s_mm >= s_mm[0] + cutoff) & (s_mm <= s_mm[-1] - cutoff), r, np.nan)


def period_mm(s_mm: np.ndarray, r_mm: np.ndarray) -> float | None:
    """The dominant wavelength of a residual profile (the pass spacing across the passes): the peak of its
    spectrum between 3 samples and half the cut-off, refined by a parabola through the log power of the
    peak and its neighbours; None on a profile too short or flat."""
    keep = np.isfinite(r_mm)
    r = r_mm[keep] - np.mean(r_mm[keep]) if keep.any() else r_mm[:0]
    if len(r) < 16 or not np.ptp(r) > NOISE_FLOOR_MM:
        return None
    step = float(s_mm[1] - s_mm[0])
    n = 8 * len(r)  # zero-padded: bins 8 times finer than the profile's length
    power = np.abs(np.fft.rfft(r * np.hanning(len(r)), n)) ** 2
    freq = np.fft.rfftfreq(n, step)
    band = np.nonzero((freq >= 2.0 / CUTOFF_MM) & (freq <= 1.0 / (3.0 * step)))[0]
    if len(band) < 3:
        return None
    k = int(band[np.argmax(power[band])])
    if 0 < k < len(power) - 1:
        lo, mid, hi = np.log(power[k - 1:k + 2] + 1e-300)
        k = k + 0.5 * (lo - hi) / (lo - 2.0 * mid + hi) if lo - 2.0 * mid + hi < 0.0 else k
    return float(1.0 / (k * (freq[1] - freq[0])))


def facets(s_mm: np.ndarray, d_mm: np.ndarray, arch_mm: np.ndarray | None = None,
           floor_mm: float = NOISE_FLOOR_MM, period: float | None = None):
    """Valley positions in d_mm, and each arch's height above the chord of its valleys (module docstring),
    measured on arch_mm (default d_mm): the undetrended profile, so a mean line does not flatten the arches.
    With a known period (the pass spacing) valleys are the lowest points at least 0.6 periods apart that
    stand out by the noise floor, so that coarse sampling of each arch does not hide every other one."""
    if len(d_mm) < 3:
        return s_mm[:0], np.zeros(0)
    arch = d_mm if arch_mm is None else arch_mm
    if period:
        step = float(s_mm[1] - s_mm[0])
        valleys, _ = find_peaks(-d_mm, distance=max(1, int(0.6 * period / step)), prominence=floor_mm)
    else:
        valleys, _ = find_peaks(-d_mm, prominence=max(floor_mm, FACET_PROMINENCE * float(np.ptp(d_mm))))
    depths = []
    for a, b in zip(valleys[:-1], valleys[1:]):
        chord = np.interp(s_mm[a:b + 1], [s_mm[a], s_mm[b]], [arch[a], arch[b]])
        depths.append(float(np.max(arch[a:b + 1] - chord)))
    return s_mm[valleys], np.array(depths)


def profile_figures(s_mm: np.ndarray, d_mm: np.ndarray, *, form_removed: bool, periodic: bool = False
                    ) -> ProfileFigures:
    """Rz, Ra and the facets of a profile; periodic: across the passes (the spacing is the dominant
    wavelength, period_mm, and the arches are found at it)."""
    r = d_mm if form_removed else detrend(s_mm, d_mm)
    keep = np.isfinite(r)
    s_mm, r, d_mm = s_mm[keep], r[keep], d_mm[keep]
    period = period_mm(s_mm, r) if periodic else None
    at, depth = facets(s_mm, r, d_mm, period=period)
    # a spacing only where arches stand out of the float32 noise (a slot's flat floor has none)
    spacing = (period or float(np.median(np.diff(at)))) if np.any(depth > NOISE_FLOOR_MM) else None
    return ProfileFigures(
        length_mm=float(np.ptp(s_mm)) if len(s_mm) else 0.0,
        rz_um=float(np.ptp(r) * 1e3) if len(r) else 0.0,
        ra_um=float(np.mean(np.abs(r - r.mean())) * 1e3) if len(r) else 0.0,
        facets=len(depth),
        facet_spacing_mm=spacing,
        facet_depth_um=float(np.median(depth) * 1e3) if len(depth) else None)


def classical_scallop_mm(r_mm: float, pick_mm: float) -> float:
    """h = r - sqrt(r^2 - (s/2)^2), written without cancellation."""
    half = pick_mm / 2.0
    return half * half / (r_mm + math.sqrt(r_mm * r_mm - half * half))


def gouges(surface: Surface, reference: np.ndarray, tol_mm: float) -> np.ndarray:
    """gouge_line: the line that last cut each node left more than tol_mm below the reference, else 0."""
    below = (surface.z_mm < reference - tol_mm) & (surface.line > 0)
    return np.where(below, surface.line, 0).astype(np.int32)


def gouge_report(gouge_line: np.ndarray, surface: Surface, reference: np.ndarray) -> list[dict]:
    """One entry per program line that gouged: nodes, the deepest depth (um) and where."""
    out = []
    for ln in np.unique(gouge_line[gouge_line > 0]):
        mask = gouge_line == ln
        depth = np.where(mask, reference - surface.z_mm, -np.inf)
        j, i = np.unravel_index(int(np.argmax(depth)), depth.shape)
        out.append({"line": int(ln), "nodes": int(mask.sum()), "depth_um": float(depth[j, i] * 1e3),
                    "x_mm": float(surface.x_mm[i]), "y_mm": float(surface.y_mm[j])})
    return sorted(out, key=lambda g: -g["depth_um"])


def iges_reference(surface: Surface, path, chunk: int = 200_000) -> np.ndarray:
    """The IGES surfaces' heights over the grid (nan off them): the vertical through each node meets a
    patch where S_xy(u, v) = (x, y), solved by Newton from the nearest of a dense parameter sample; the
    highest patch wins where several lie over a node."""
    from scipy.spatial import cKDTree

    from ipo.surface.evaluation import grid, surface_derivs
    from ipo.surface.iges import read_surfaces

    X, Y = np.meshgrid(surface.x_mm, surface.y_mm)
    q = np.column_stack((X.ravel(), Y.ravel()))
    out = np.full(len(q), np.nan)
    for surf in read_surfaces(path):
        u_s, v_s = grid(surf, 120, 120)
        tree = cKDTree(surface_derivs(surf, u_s, v_s)[0][:, :2])
        (u_lo, u_hi), (v_lo, v_hi) = surf.u_range, surf.v_range
        for a in range(0, len(q), chunk):
            qq = q[a:a + chunk]
            _, k = tree.query(qq)
            u, v = u_s[k], v_s[k]
            for _ in range(12):
                s, s_u, s_v = surface_derivs(surf, u, v)
                r = qq - s[:, :2]
                det = s_u[:, 0] * s_v[:, 1] - s_u[:, 1] * s_v[:, 0]
                det = np.where(np.abs(det) > 1e-300, det, 1e-300)
                u = np.clip(u + (r[:, 0] * s_v[:, 1] - r[:, 1] * s_v[:, 0]) / det, u_lo, u_hi)
                v = np.clip(v + (s_u[:, 0] * r[:, 1] - s_u[:, 1] * r[:, 0]) / det, v_lo, v_hi)
            s = surface_derivs(surf, u, v)[0]
            hit = np.hypot(*(qq - s[:, :2]).T) <= 1e-6
            cur = out[a:a + chunk]
            out[a:a + chunk] = np.where(hit & ~(cur >= s[:, 2]), s[:, 2], cur)
    return out.reshape(X.shape)
