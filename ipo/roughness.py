"""002's surface-roughness model for ball-end finishing and the feed limiter built on it.

r ball radius, f_p pick feed, f_i feed per tooth, alpha feed inclination against the
XY plane (tool axis Z), p = f_p/(2 pi) the phase shift between neighbouring passes.
All lengths in mm; functions accept numpy arrays for alpha (and f_i where noted).
"""
from __future__ import annotations

import numpy as np

from ipo.errors import ROUGHNESS_TARGET, IpoError


def phase_shift_mm(pick_mm: float) -> float:
    return pick_mm / (2.0 * np.pi)  # 002 §3.1


def cusp_height_mm(r_mm: float, pick_mm: float) -> float:
    """Cusp height across the feed left by the path interval: the isotropic target (002 §3.1)."""
    # r - sqrt(r^2 - p^2/4) without the cancellation (at p/r = 1e-6 it lost 0.1 %, and the
    # isotropic target came out below what the pick feed allows)
    quarter = 0.25 * pick_mm * pick_mm
    return quarter / (r_mm + np.sqrt(r_mm * r_mm - quarter))


def rmax_no_tip_mm(r_mm, fi_mm, pick_mm):
    """Tool tip not cutting, |alpha| > alpha_c (002 eq. 2)."""
    return (pick_mm**2 + (fi_mm - phase_shift_mm(pick_mm)) ** 2) / (8 * r_mm)


def rmax_tip_mm(r_mm, fi_mm, alpha_rad):
    """Tool tip cutting, |alpha| <= alpha_c (002 eq. 3)."""
    return r_mm * (1 - np.sqrt(1 - (fi_mm / r_mm) ** 2 + np.sin(alpha_rad) ** 2))


def critical_alpha_rad(r_mm, fi_mm, pick_mm):
    """Inclination at which the tool tip stops cutting (002 eq. 4)."""
    a = pick_mm**2 + (fi_mm - phase_shift_mm(pick_mm)) ** 2
    arg = np.sqrt(np.maximum((a / (8 * r_mm)) ** 2 - a / 4 + fi_mm**2, 0.0)) / r_mm
    return np.arcsin(np.minimum(arg, 1.0))


def rmax_mm(r_mm, fi_mm, pick_mm, alpha_rad):
    """Extended model: eq. 3 where |alpha| <= alpha_c(f_i), else eq. 2."""
    tip = np.abs(alpha_rad) <= critical_alpha_rad(r_mm, fi_mm, pick_mm)
    return np.where(tip, rmax_tip_mm(r_mm, fi_mm, alpha_rad), rmax_no_tip_mm(r_mm, fi_mm, pick_mm))


def feed_per_tooth_mm(r_mm: float, pick_mm: float, target_mm: float, alpha_rad) -> np.ndarray:
    """The largest f_i whose extended-model roughness is within target at each alpha.

    Each closed form (002 eq. 5 for |alpha| > alpha_c, eq. 6 for |alpha| <= alpha_c) is
    valid only where its own regime holds at its own f_i; the answer is the larger valid
    one (the model is continuous across alpha_c and grows with f_i beyond p, so no
    larger f_i stays within target). Raises if neither regime can reach the target.
    """
    alpha = np.abs(np.asarray(alpha_rad, dtype=float))
    sin_a = np.sin(alpha)
    under = 8 * r_mm * target_mm - pick_mm**2
    if under >= 0:
        f5 = phase_shift_mm(pick_mm) + np.sqrt(under)  # 002 eq. 5
        f5 = np.where(alpha > critical_alpha_rad(r_mm, f5, pick_mm), f5, 0.0) * np.ones_like(alpha)
    else:
        f5 = np.zeros_like(alpha)
    f6 = np.sqrt((r_mm * sin_a) ** 2 + 2 * r_mm * target_mm - target_mm**2)  # 002 eq. 6
    f6 = np.where(alpha <= critical_alpha_rad(r_mm, f6, pick_mm) + 1e-12, f6, 0.0)
    fi = np.maximum(f5, f6)
    if np.any(fi <= 0):
        raise IpoError(ROUGHNESS_TARGET, f"roughness target {target_mm * 1e3:.3f} um is below what pick feed "
                                         f"{pick_mm} mm allows with a {r_mm} mm ball")
    return fi


def roughness_feed_mm_s(r_mm: float, pick_mm: float, target_mm: float, flutes: int,
                        spindle_rpm: float, alpha_rad) -> np.ndarray:
    """F_rough = z * S * f_i, converted from mm/min to mm/s (002 §3)."""
    return flutes * spindle_rpm * feed_per_tooth_mm(r_mm, pick_mm, target_mm, alpha_rad) / 60.0


def inclination_rad(tangent: np.ndarray) -> np.ndarray:
    """Angle between unit path tangents (N, 3) and the XY plane."""
    return np.arcsin(np.clip(np.abs(tangent[..., 2]), 0.0, 1.0))
