"""The distance of a point from a straight segment: one compiled kernel for the rooms that measure
deviations from polylines (the feed stage's corner blends, the reference pulse's curve check, the
servo model's contour error)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def segment_distance(q, a, b):
    """Distance of the point q (3,) from the segment a-b."""
    ab0, ab1, ab2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    aq0, aq1, aq2 = q[0] - a[0], q[1] - a[1], q[2] - a[2]
    len2 = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    f = min(max((aq0 * ab0 + aq1 * ab1 + aq2 * ab2) / len2, 0.0), 1.0) if len2 > 0 else 0.0
    d0, d1, d2 = aq0 - f * ab0, aq1 - f * ab1, aq2 - f * ab2
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
