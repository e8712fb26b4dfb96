"""ipo.numpy_kernels: numpy's linspace and interp to the bit, and dot3 as a chain of fused multiply-adds
(exact rational arithmetic as the reference)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from ipo.numpy_kernels import dot3, dot3_from, interp_at, linspace_into


def test_linspace_and_interp_are_numpys_to_the_bit():
    rng = np.random.default_rng(7)
    for _ in range(200):
        a, b = sorted(rng.normal(size=2) * 10.0 ** rng.integers(-3, 4))
        num = int(rng.integers(2, 300))
        out = np.empty(num + 3)
        linspace_into(a, b, num, out, 3)
        assert np.array_equal(out[3:], np.linspace(a, b, num))
        xp = np.cumsum(rng.exponential(size=50) * (rng.random(50) > 0.1))  # some repeated abscissae
        fp = rng.normal(size=50)
        x = np.concatenate([rng.uniform(xp[0] - 1.0, xp[-1] + 1.0, 40), xp[::7]])
        assert np.array_equal(np.array([interp_at(v, xp, fp) for v in x]), np.interp(x, xp, fp))


def _fma(x, y, z):
    return float(Fraction(x) * Fraction(y) + Fraction(z))  # exact, then one rounding


def _fma_chain(a, b):
    return _fma(a[2], b[2], _fma(a[1], b[1], a[0] * b[0]))


def test_dot3_is_a_chain_of_fused_multiply_adds():
    rng = np.random.default_rng(8)
    a = rng.normal(size=(2000, 3)) * rng.lognormal(size=(2000, 1))
    b = rng.normal(size=(2000, 3))
    origin = rng.normal(size=3)
    for x, y in zip(a, b):
        assert dot3(x, y) == _fma_chain(x, y)
        assert dot3_from(x, origin, y) == _fma_chain(x - origin, y)
        assert abs(dot3(x, y) - float(x @ y)) <= 4 * np.spacing(np.abs(x * y).sum())
