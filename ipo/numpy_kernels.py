"""numpy's linspace and interp as numba kernels, to the bit: for compiled code that must pick the
same parameters as a numpy path beside it (ipo.feed.table_verdict beside nurbs_table, the fit's
curve samples)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def linspace_into(a, b, num, out, at):
    """numpy.linspace(a, b, num) (num >= 2, a != b) into out[at:at + num]: i * step + a, the last exactly b."""
    step = (b - a) / (num - 1)
    for i in range(num - 1):
        out[at + i] = i * step + a
    out[at + num - 1] = b


@njit(cache=True)
def interp_at(x, xp, fp):
    """numpy.interp(x, xp, fp) at one finite x (xp non-decreasing: the interval is the last with xp[j] <= x)."""
    if x >= xp[-1]:
        return fp[-1]
    if x < xp[0]:
        return fp[0]
    j = np.searchsorted(xp, x, side="right") - 1
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]
