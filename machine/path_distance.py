"""The distance from each point of one sampled path to another path's polyline (`vcnc compare`).

Exact, not windowed: matching the points by their proportional arc length drifts as soon as the two
paths differ in length (a program and its fit round corners differently; over Cereal.ngc's 206 s the
drift reached 1.5 mm where the paths are 0.1 mm apart), and scanning a wide window was the slowest
part of a comparison. Instead a k-d tree over the polyline's pieces (segments cut to at most the median
segment's length) names the nearest candidates, and a point's distance is final once every piece not yet
examined is provably farther: piece j lies within its half-length h_j of its midpoint, so its distance
is at least |q - m_j| - h_max, and the k nearest midpoints leave all the others at |q - m| >= d_k.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

FIRST_K = 8  # nearest pieces examined first; quadrupled for the points not yet settled
BALL_K = 512  # beyond this many, the remaining points take every piece within their bound (a ball query)
CHUNK_PAIRS = 1 << 21  # points x pieces examined at once (memory: ~50 bytes each)


def polyline_distances_mm(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance (mm) from each of `points` (n x 3) to the polyline through `path` (m x 3, m >= 1)."""
    p0, p1 = _pieces(path)
    if len(p0) == 0:
        return np.linalg.norm(points - path[0], axis=1)
    mid = (p0 + p1) / 2
    slack_mm = float(np.linalg.norm(p1 - p0, axis=1).max()) / 2
    tree = cKDTree(mid)
    best = np.empty(len(points))
    todo, k = np.arange(len(points)), FIRST_K
    while len(todo) and k <= BALL_K and k < len(mid):
        dk = np.empty(len(todo))
        step = max(1, CHUNK_PAIRS // k)
        for s in range(0, len(todo), step):
            part = todo[s:s + step]
            dist, idx = tree.query(points[part], k=k, workers=-1)
            best[part] = _to_pieces(points[part][:, None, :], p0[idx], p1[idx]).min(axis=1)
            dk[s:s + step] = dist[:, -1]
        todo = todo[best[todo] > dk - slack_mm]
        k *= 4
    if len(todo) and k >= len(mid):  # every piece is a candidate
        step = max(1, CHUNK_PAIRS // len(mid))
        for s in range(0, len(todo), step):
            part = todo[s:s + step]
            best[part] = _to_pieces(points[part][:, None, :], p0[None], p1[None]).min(axis=1)
    else:
        for i in todo:
            idx = np.asarray(tree.query_ball_point(points[i], best[i] + slack_mm), dtype=np.intp)
            best[i] = min(best[i], _to_pieces(points[i], p0[idx], p1[idx]).min(initial=np.inf))
    return best


def _pieces(path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The polyline's segments cut into pieces no longer than the median segment (at least one each;
    points standing still are dropped, their place is a vertex of the pieces either side)."""
    step = np.diff(path, axis=0)
    length = np.linalg.norm(step, axis=1)
    keep = length > 0
    start, step, length = path[:-1][keep], step[keep], length[keep]
    if len(length) == 0:
        return start, start
    n = np.maximum(np.ceil(length / np.median(length)).astype(np.intp), 1)
    seg = np.repeat(np.arange(len(n)), n)
    first = np.cumsum(n) - n
    k = np.arange(len(seg)) - first[seg]
    f0, f1 = k / n[seg], (k + 1) / n[seg]
    return start[seg] + f0[:, None] * step[seg], start[seg] + f1[:, None] * step[seg]


def _to_pieces(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|q - closest point of segment ab|, broadcast over the leading axes."""
    d = b - a
    t = np.clip(np.sum((q - a) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(q - a - t[..., None] * d, axis=-1)
