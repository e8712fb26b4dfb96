"""ipo.nurbs.kernel.basis_derivs (The NURBS Book's A2.3, compiled, u by u) against the same algorithm
over arrays of u in numpy, bit for bit: the feed stage's arc-length tables and so the per-period
output were built on the array form's bits, and must not change with the compiled one. (Its values
against hand-computed basis functions and scipy: tests/ipo/nurbs/test_nurbs_kernel.py.)"""
from __future__ import annotations

import numpy as np

from ipo.nurbs.kernel import basis_derivs, find_span


def numpy_basis_derivs(knots, p, u, n_derivs, span):
    """A2.3 over arrays of u, every step one numpy expression."""
    m = len(u)
    ndu = np.zeros((p + 1, p + 1, m))
    ndu[0, 0] = 1.0
    left = np.zeros((p + 1, m))
    right = np.zeros((p + 1, m))
    for j in range(1, p + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = np.zeros(m)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    ders = np.zeros((n_derivs + 1, m, p + 1))
    ders[0] = ndu[:, p].T
    a = np.zeros((2, p + 1, m))
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, n_derivs + 1):
            d = np.zeros(m)
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d = d + a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d = d + a[s2, k] * ndu[r, pk]
            ders[k, :, r] = d
            s1, s2 = s2, s1
    factor = float(p)
    for k in range(1, n_derivs + 1):
        ders[k] *= factor
        factor *= p - k
    return ders


def test_compiled_a23_gives_the_array_forms_bits():
    rng = np.random.default_rng(23)
    for trial in range(600):
        p = int(rng.integers(1, 8))
        inner = np.sort(rng.uniform(-5, 5, rng.integers(0, 9)) * 10 ** rng.uniform(-3, 3))
        inner = np.repeat(inner, rng.integers(1, p + 1, len(inner)))  # interior knots of any multiplicity up to p
        lo, hi = (inner[0], inner[-1]) if len(inner) else (0.0, 1.0)
        lo, hi = lo - rng.uniform(0.01, 3), hi + rng.uniform(0.01, 3)
        knots = np.concatenate([[lo] * (p + 1), inner, [hi] * (p + 1)])
        # random u, the knots themselves (span starts) and both ends
        u = np.concatenate([rng.uniform(lo, hi, rng.integers(1, 60)), inner, [lo, hi]])
        n_derivs = int(rng.integers(0, p + 2))  # past p the derivatives are zero
        span = find_span(knots, p, u)
        got = basis_derivs(knots, p, u, n_derivs)
        want = numpy_basis_derivs(knots, p, u, n_derivs, span)
        assert got.shape == want.shape and got.tobytes() == want.tobytes(), (trial, p, n_derivs)
    # -0.0 stays as the array form has it
    knots = np.array([0, 0, 0, 1, 2, 2, 2], dtype=float)
    u = np.array([0.0, 1.0, 2.0, 0.5])
    assert basis_derivs(knots, 2, u, 3).tobytes() == numpy_basis_derivs(knots, 2, u, 3, find_span(knots, 2, u)).tobytes()


def test_basis_derivs_sum_to_one_and_their_derivatives_to_zero():
    knots = np.array([0, 0, 0, 0, 0.3, 0.3, 0.7, 1, 1, 1, 1])
    u = np.linspace(0, 1, 101)
    d = basis_derivs(knots, 3, u, 3)
    assert np.allclose(d[0].sum(axis=1), 1.0, atol=1e-14)
    assert np.allclose(d[1:].sum(axis=2), 0.0, atol=1e-9)
