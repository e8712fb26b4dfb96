"""Reference-word (sampled-data) output, 000 §2.3: per-period positions quantised to the
machine's basic length unit (BLU). The axis velocities of eq. 16 are not a separate output:
the period stream carries the path feed V and the increments, V dX / DS per period.

Quantising each absolute position (rather than each increment) carries the rounding
remainder from period to period: no error accumulates, every commanded position is within
0.5 BLU of the true one, and the increments sum exactly to the quantised end point.
"""
from __future__ import annotations

import numpy as np


def checked_points(pos_mm, name: str) -> np.ndarray:
    """pos_mm as a contiguous finite (N, 3) float64 array, or ValueError naming `name`."""
    pos = np.ascontiguousarray(pos_mm, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {pos.shape}")
    if not np.isfinite(pos).all():
        raise ValueError(f"{name} holds non-finite values")
    return pos


def quantise(pos_mm: np.ndarray, blu_mm: float, start_blu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-period increments (N, 3) int64 in BLU and the end position (3,) int64 in BLU.

    start_blu is where the machine stands (its last commanded position in BLU);
    start_blu + inc_blu[:j+1].sum(0) == round(pos_mm[j] / blu_mm) for every j.
    """
    pos = checked_points(pos_mm, "pos_mm")
    if not (np.isfinite(blu_mm) and blu_mm > 0):
        raise ValueError(f"blu_mm must be finite and > 0, got {blu_mm}")
    start = np.asarray(start_blu)
    if start.shape != (3,) or not np.issubdtype(start.dtype, np.integer):
        raise ValueError(f"start_blu must be three integers, got {start_blu!r}")
    q = np.rint(pos / blu_mm)
    if q.size and np.abs(q).max() >= 2.0**62:
        raise ValueError("positions out of range for int64 BLU counts")
    q = q.astype(np.int64)
    inc = np.diff(q, axis=0, prepend=start.astype(np.int64)[None, :])
    end = q[-1].copy() if len(q) else start.astype(np.int64).copy()
    return inc, end
