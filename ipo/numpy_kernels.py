"""numpy's linspace and interp as numba kernels, to the bit, and the dot product of 3-vectors in one fixed
order: for compiled code that must pick the same parameters as a numpy path beside it (ipo.feed.table_verdict
beside nurbs_table, the fit's curve samples, the corner blends of ipo.feed.arc_corners beside curve_corner's)
or that tests thousands of conic spans (ipo.fit.conic)."""
from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import intrinsic


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


@intrinsic
def _fma(typingctx, a, b, c):
    """a * b + c rounded once (LLVM's fma)."""
    def codegen(context, builder, signature, args):
        return builder.fma(*args)
    return types.float64(types.float64, types.float64, types.float64), codegen


@njit(cache=True)
def dot3(a, b):
    """a . b of two 3-vectors as a chain of fused multiply-adds, the same bits on every CPU: `@` and np.dot
    call BLAS's ddot, whose order of operations depends on the CPU it runs on (an FMA chain on one host,
    products summed left to right on an AMD EPYC with AVX-512)."""
    return _fma(a[2], b[2], _fma(a[1], b[1], a[0] * b[0]))


@njit(cache=True)
def dot3_from(x, origin, b):
    """(x - origin) @ b, as dot3 forms it."""
    return _fma(x[2] - origin[2], b[2], _fma(x[1] - origin[1], b[1], (x[0] - origin[0]) * b[0]))
