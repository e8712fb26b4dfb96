"""S-curve mode's anchors: where a jerk-limited segment of ipo.feed.jerk_plan starts and ends
with zero acceleration before the checks add any (step 1 of jerk_plan).

The first and last sample, every stop, both ends of every valley of x_acc (a run of equal x_acc
lower than the samples either side: a cap holds the speed down there) and of every plateau of
x_acc that is not a peak, and the samples where the path changes between straight and curved
(straights shorter than straight_min_mm between curved pieces count as curved).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def curved_intervals(s, t, kv, straight_min_mm):
    """Per sample interval: the path curves there (or its tangent turns), with straight runs
    shorter than straight_min_mm between curved ones counted as curved."""
    n = s.shape[0]
    curved = np.zeros(n - 1, np.bool_)
    for k in range(n - 1):
        for i in range(3):
            if kv[k, i] != 0.0 or kv[k + 1, i] != 0.0 or t[k, i] != t[k + 1, i]:
                curved[k] = True
    k = 0
    while k < n - 1:
        if curved[k]:
            k += 1
            continue
        e = k
        while e < n - 1 and not curved[e]:
            e += 1
        if k > 0 and e < n - 1 and s[e] - s[k] < straight_min_mm:
            curved[k:e] = True
        k = e
    return curved


@njit(cache=True)
def anchors(s, x, curved):
    """Which samples are anchors (ipo.feed.jerk_plan's step 1, without the first and last sample's
    special speeds)."""
    n = s.shape[0]
    anchor = np.zeros(n, np.bool_)
    anchor[0] = anchor[n - 1] = True
    for k in range(1, n - 1):
        if x[k] <= 0.0 or curved[k - 1] != curved[k]:
            anchor[k] = True
    k = 0
    while k < n:
        e = k
        while e + 1 < n and abs(x[e + 1] - x[k]) <= 1e-9 * max(x[k], 1e-12):
            e += 1
        lower_before = k == 0 or x[k - 1] > x[k]
        lower_after = e == n - 1 or x[e + 1] > x[k]
        peak = (k == 0 or x[k - 1] < x[k]) and (e == n - 1 or x[e + 1] < x[k])
        if (lower_before and lower_after) or (s[e] > s[k] and not peak):
            anchor[k] = anchor[e] = True  # a valley, or a plateau below its neighbours on one side
        k = e + 1
    return anchor
