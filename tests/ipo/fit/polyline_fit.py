"""fit_polyline: a G01 polyline covered by 001 rational fits within a tolerance, or kept G01,
with the fewest NC blocks (ipo.fit.tolerance's fewest_ctrl over parts of it; a piece split in
two at its sharpest vertex where that needs fewer blocks).

The tests drive ipo.fit.tolerance through it over whole polylines; vcnc fit plans its groups
with ipo.fit.groups and ipo.fit.conic_plan instead.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ipo.errors import FIT_DATA, FIT_SETTINGS, IpoError
from ipo.fit.rational import RationalFit
from ipo.fit.tolerance import MAX_CTRL, FitSettings, densify, fewest_ctrl

MAX_POINTS_PER_FIT = 400  # longer polylines are cut into equal parts first


@dataclass(frozen=True, slots=True)
class Piece:
    """Vertices first..last (inclusive) of the polyline: a fitted curve, or G01 if fit is None."""

    first: int
    last: int
    fit: RationalFit | None
    deviation_mm: float  # checked max deviation of the fit (0 for G01)
    reason: str = ""  # why a piece stayed G01
    data: np.ndarray | None = None  # the points the fit was made on: the same polyline, densified


def nurbs_blocks(n_ctrl: int, degree: int) -> int:
    """NC blocks of one G06.2 group: a block per control point, `order` knot blocks, one to restore G1."""
    return n_ctrl + degree + 2


def _dedupe(q: np.ndarray) -> np.ndarray:
    """Indices of q without consecutive repeats (a zero-length G01 adds nothing to the path)."""
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    keep = np.concatenate([[True], step > 1e-12])
    keep[-1] = True
    return np.flatnonzero(keep)


def _turning(q: np.ndarray) -> np.ndarray:
    """Turning angle (rad) at each interior vertex."""
    d = np.diff(q, axis=0)
    n = np.linalg.norm(d, axis=1)
    n = np.where(n > 0, n, 1.0)
    c = np.einsum("ij,ij->i", d[:-1], d[1:]) / (n[:-1] * n[1:])
    return np.arccos(np.clip(c, -1.0, 1.0))


def _split_vertex(q: np.ndarray, first: int, last: int, min_moves: int) -> int:
    """Where to cut a piece in two: its sharpest vertex, unless the turning is nearly even
    (then the middle); both parts keep at least min_moves moves."""
    lo, hi = first + min_moves, last - min_moves
    mid = (first + last) // 2
    ang = _turning(q[first:last + 1])[lo - first - 1:hi - first]
    if len(ang) == 0:
        return mid
    k = int(np.argmax(ang))
    return lo + k if ang[k] > 2.0 * np.median(ang) + 1e-3 else mid


def _fit_range(q: np.ndarray, first: int, last: int, s: FitSettings,
               blocks: Callable[[int], int]) -> list[Piece]:
    """Fit vertices first..last as one piece or, where that needs fewer blocks, as two."""
    sub = q[first:last + 1]
    g01_blocks = last - first
    m_max = min(len(sub), MAX_CTRL)
    while m_max > 0 and blocks(m_max) >= g01_blocks:
        m_max -= 1
    data = densify(sub[_dedupe(sub)])
    fit, dev = fewest_ctrl(data, s, m_max) or (None, 0.0)
    if fit is None:
        whole = [Piece(first, last, None, 0.0, "no fit within tolerance saves blocks")]
        whole_blocks = g01_blocks
    else:
        whole = [Piece(first, last, fit, dev, data=data)]
        whole_blocks = blocks(len(fit.points))
    min_moves = s.degree + 2
    worth_splitting = fit is None or len(fit.points) > MAX_CTRL // 2
    if g01_blocks < 2 * min_moves or not worth_splitting:
        return whole
    cut = _split_vertex(q, first, last, min_moves)
    halves = _fit_range(q, first, cut, s, blocks) + _fit_range(q, cut, last, s, blocks)
    split_blocks = sum(blocks(len(p.fit.points)) if p.fit else p.last - p.first for p in halves)
    return halves if split_blocks < whole_blocks else whole


def fit_polyline(q: np.ndarray, s: FitSettings,
                 blocks: Callable[[int], int] | None = None) -> list[Piece]:
    """Cover the vertices 0..len(q)-1 with consecutive pieces (fitted curves or G01)."""
    q = np.asarray(q, dtype=float)
    if s.tol_mm <= 0:
        raise IpoError(FIT_SETTINGS, f"tolerance must be > 0 mm, got {s.tol_mm}")
    cost = blocks or (lambda m: nurbs_blocks(m, s.degree))
    n_seg = len(q) - 1
    if n_seg < 1:
        raise IpoError(FIT_DATA, "a polyline needs at least two vertices")
    parts = int(np.ceil(n_seg / MAX_POINTS_PER_FIT))
    bounds = np.linspace(0, n_seg, parts + 1).round().astype(int)
    pieces: list[Piece] = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        pieces += _fit_range(q, int(a), int(b), s, cost)
    return pieces
