"""Rational B-spline approximation of point data (001 §2, Appendix I; spec §7).

The rational least-squares problem is non-linear, so 001 alternates three linear
(or one-dimensional) sub-problems on a uniform clamped knot vector: homogeneous
control points WP with the weights fixed (eq. 6–7), the weights with WP fixed
(eq. 8–9), and each data point's parameter by golden-section search (eq. 10–11).

Project choices beyond the paper: the first and last control points are pinned to
the first and last data points (a toolpath piece must start and end exactly where
the G01 run did), the weight solve is damped slightly towards the previous weights
(a straight or nearly straight run leaves the weights undetermined), a weight step
that would make a weight non-positive is shortened, and the scale is fixed by
normalising the largest weight to 1 (the curve is unchanged when WP and w scale
together). Everything is vectorised over all data points.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.errors import FIT_DATA, FIT_SETTINGS, IpoError
from ipo.fit.compiled import foot_params
from ipo.nurbs.kernel import basis, find_span

GOLDEN_STEPS = 20  # golden-section steps of the parameter correction: the bracket shrinks to 1e-4
MIN_WEIGHT = 1e-3  # relative to the largest weight; keeps the curve away from a pole


@dataclass(frozen=True, slots=True)
class RationalFit:
    """A fitted curve (clamped, uniform knots) and how the iteration went."""

    degree: int
    knots: np.ndarray  # (m + degree + 1,)
    weights: np.ndarray  # (m,) all > 0, largest 1
    points: np.ndarray  # (m, dim) Cartesian control points P_i = WP_i / w_i
    params: np.ndarray  # (r,) final parameter of each data point
    rms_history: np.ndarray  # f_l after each iteration (001 App. I step 5)
    converged: bool  # stopped by f_{l-1} - f_l < delta before the iteration budget ran out


def uniform_knots(n_ctrl: int, degree: int) -> np.ndarray:
    """Clamped uniform knots on [0, n - k + 2] (k = degree + 1 the order, n = n_ctrl - 1)."""
    if degree < 1 or n_ctrl < degree + 1:
        raise IpoError(FIT_SETTINGS, f"need at least degree + 1 = {degree + 1} control points, got {n_ctrl}")
    inner = np.arange(1, n_ctrl - degree, dtype=float)
    end = float(n_ctrl - degree)
    return np.concatenate([np.zeros(degree + 1), inner, np.full(degree + 1, end)])


def chord_params(q: np.ndarray, u_max: float) -> np.ndarray:
    """Chord-length parameters scaled to [0, u_max] (001 App. I step 1)."""
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    total = steps.sum()
    if total <= 0.0:
        raise IpoError(FIT_DATA, "data points are all identical: nothing to fit")
    return u_max * np.concatenate([[0.0], np.cumsum(steps)]) / total


def basis_matrix(knots: np.ndarray, degree: int, u: np.ndarray, n_ctrl: int) -> np.ndarray:
    """Dense [N]_{r x m} of 001 eq. 6: N[j, i] = N_{i,k}(u_j)."""
    span = find_span(knots, degree, u)
    vals = basis(knots, degree, u, span)
    out = np.zeros((len(u), n_ctrl))
    cols = span[:, None] - degree + np.arange(degree + 1)[None, :]
    np.put_along_axis(out, cols, vals, axis=1)
    return out


def eval_homogeneous(knots: np.ndarray, degree: int, wp: np.ndarray, w: np.ndarray,
                     u: np.ndarray) -> np.ndarray:
    """C(u) = sum N_i WP_i / sum N_i w_i (001 eq. 10), shape (len(u), dim)."""
    span = find_span(knots, degree, u)
    vals = basis(knots, degree, u, span)
    idx = span[:, None] - degree + np.arange(degree + 1)[None, :]
    num = np.einsum("ji,jid->jd", vals, wp[idx])
    den = np.einsum("ji,ji->j", vals, w[idx])
    return num / den[:, None]


class SpanPolynomials:
    """The basis functions as one polynomial per knot span, computed from ipo.nurbs.kernel.basis.

    The golden-section searches evaluate the curve thousands of times at moving
    parameters; per span polynomials make each evaluation a few array operations."""

    def __init__(self, knots: np.ndarray, degree: int):
        p = degree
        spans = np.arange(p, len(knots) - p - 1)
        spans = spans[knots[spans + 1] > knots[spans]]
        width = knots[spans + 1] - knots[spans]
        nodes = (np.arange(p + 1) + 0.5) / (p + 1)
        x = width[:, None] * nodes[None, :]  # (S, p+1) local abscissae
        vals = basis(knots, p, (knots[spans][:, None] + x).ravel(), np.repeat(spans, p + 1))
        vander = x[:, :, None] ** np.arange(p + 1)[None, None, :]
        self.coef = np.linalg.solve(vander, vals.reshape(len(spans), p + 1, p + 1))  # (S, power, function)
        self.starts = knots[spans]
        self.spans = spans
        self.degree = p

    def __call__(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Span index and the p+1 non-zero basis values at each u."""
        k = np.clip(np.searchsorted(self.starts, u, side="right") - 1, 0, len(self.starts) - 1)
        x = u - self.starts[k]
        c = self.coef[k]
        vals = c[:, self.degree]
        for power in range(self.degree - 1, -1, -1):
            vals = vals * x[:, None] + c[:, power]
        return self.spans[k], vals

    def homogeneous(self, wp: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The numerator and denominator of C(u) (001 eq. 10) as one polynomial per span,
        shape (S, power, dim+1)."""
        p = self.degree
        idx = self.spans[:, None] - p + np.arange(p + 1)[None, :]
        homog = np.concatenate([wp, w[:, None]], axis=1)[idx]  # (S, function, dim+1)
        return np.einsum("skf,sfd->skd", self.coef, homog)

    def curve(self, wp: np.ndarray, w: np.ndarray):
        """u -> C(u) for fixed homogeneous control points."""
        return self.curve_of(self.homogeneous(wp, w))

    def curve_of(self, poly: np.ndarray):
        """u -> C(u) for the span polynomials `homogeneous` gives."""
        p = self.degree

        def at(u: np.ndarray) -> np.ndarray:
            k = np.clip(np.searchsorted(self.starts, u, side="right") - 1, 0, len(self.starts) - 1)
            x = (u - self.starts[k])[:, None]
            c = poly[k]
            acc = c[:, p]
            for power in range(p - 1, -1, -1):
                acc = acc * x + c[:, power]
            return acc[:, :-1] / acc[:, -1:]

        return at


def _solve_wp(n_mat: np.ndarray, q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Homogeneous control points with the end points pinned to the data ends."""  # 001 eq. 6-7
    rhs = q * (n_mat @ w)[:, None]
    wp = np.empty((n_mat.shape[1], q.shape[1]))
    wp[0], wp[-1] = w[0] * q[0], w[-1] * q[-1]
    rhs -= n_mat[:, [0]] * wp[0] + n_mat[:, [-1]] * wp[-1]
    if n_mat.shape[1] > 2:
        wp[1:-1] = np.linalg.lstsq(n_mat[:, 1:-1], rhs, rcond=None)[0]
    return wp


def _solve_weights(n_mat: np.ndarray, q: np.ndarray, wp: np.ndarray, w_old: np.ndarray) -> np.ndarray:
    """Weights with WP fixed, stacked over the coordinates (001 eq. 8–9).

    The pinned ends keep WP_0 = w_0 Q_0 and WP_n = w_n Q_n, so their weights enter
    as N_{i,k}(u_j) (Q_j - Q_end). A Tikhonov term of relative size 1e-9 towards
    the previous weights makes the solve well posed where the data do not
    determine them (straight runs)."""
    r, m = n_mat.shape
    dim = q.shape[1]
    a = q[:, None, :] * n_mat[:, :, None]  # (r, m, dim): Q_j N_ij
    a[:, 0, :] = n_mat[:, [0]] * (q - q[0])
    a[:, -1, :] = n_mat[:, [-1]] * (q - q[-1])
    b = np.einsum("ji,id->jd", n_mat[:, 1:-1], wp[1:-1])
    a2 = a.transpose(0, 2, 1).reshape(r * dim, m)
    normal = a2.T @ a2
    lam = 1e-9 * max(np.trace(normal) / m, 1e-300)
    return np.linalg.solve(normal + lam * np.eye(m), a2.T @ b.reshape(-1) + lam * w_old)


def _positive_step(w_old: np.ndarray, w_new: np.ndarray) -> np.ndarray:
    """Move from w_old towards w_new as far as (at most all the way) every weight stays at or above
    MIN_WEIGHT * max(w_old); a weight already below that floor may only grow."""
    floor = np.minimum(MIN_WEIGHT * w_old.max(), w_old)
    falling = w_new < w_old
    t = 1.0
    if falling.any():
        t = min(1.0, float(np.min((w_old[falling] - floor[falling]) / (w_old[falling] - w_new[falling]))))
    return w_old + t * (w_new - w_old)


def fit_rational(q: np.ndarray, n_ctrl: int, degree: int = 3, *, max_iter: int = 30,
                 rel_delta: float = 1e-3, rational: bool = True,
                 params: np.ndarray | None = None, give_up_above: float | None = None,
                 good_below: float | None = None) -> RationalFit:
    """001 Appendix I on arrays: q (r, dim) data, n_ctrl control points (r >= n_ctrl).

    Stops when f_{l-1} - f_l < rel_delta * f_{l-1} (or f_l is ~0), or after max_iter
    iterations; returns the best iterate. rational=False skips the weight step
    (a non-rational least-squares fit with the same parameter correction).
    give_up_above: stop early once the largest data-point error, falling at its
    current rate for the iterations left, cannot get below this value (the
    caller's tolerance: the fit is then of no use to it); good_below: stop as soon as every
    data point is within this distance of its curve point (the caller needs no better fit)."""
    q = np.asarray(q, dtype=float)
    r = len(q)
    if r < n_ctrl:
        raise IpoError(FIT_DATA, f"{r} data points cannot determine {n_ctrl} control points")
    knots = uniform_knots(n_ctrl, degree)
    spans = SpanPolynomials(knots, degree)
    u_max = knots[-1]
    u = chord_params(q, u_max) if params is None else np.asarray(params, dtype=float).copy()
    w = np.ones(n_ctrl)
    scale = max(float(np.ptp(q, axis=0).max()), 1e-300)
    history: list[float] = []
    worst_prev = np.inf
    # the weights-1 solve is a candidate too: with as many control points as points it interpolates,
    # and the weight step and parameter correction can only move away from it
    wp = _solve_wp(basis_matrix(knots, degree, u, n_ctrl), q, w)
    err = q - eval_homogeneous(knots, degree, wp, w, u)
    best = (float(np.sqrt(np.sum(err**2) / max(r - 1, 1))), wp, w.copy(), u.copy())
    converged = False
    for _ in range(max_iter):
        n_mat = basis_matrix(knots, degree, u, n_ctrl)
        wp = _solve_wp(n_mat, q, w)
        if rational:
            wp, w = _weight_step(n_mat, q, wp, w)
        u = correct_params(spans, wp, w, q, u)
        err = q - eval_homogeneous(knots, degree, wp, w, u)
        f_l = float(np.sqrt(np.sum(err**2) / max(r - 1, 1)))  # 001 App. I step 5
        if f_l < best[0]:
            best = (f_l, wp.copy(), w.copy(), u.copy())
        if history and (history[-1] - f_l < rel_delta * history[-1] or f_l < 1e-12 * scale):
            history.append(f_l)
            converged = True
            break
        worst = float(np.sqrt(np.max(np.sum(err**2, axis=1))))
        if good_below is not None and worst <= good_below and f_l <= best[0]:
            history.append(f_l)
            converged = True
            break
        if give_up_above is not None:
            left = max_iter - len(history) - 1
            if worst - left * max(worst_prev - worst, 0.0) > give_up_above:
                history.append(f_l)
                break
        worst_prev = worst
        history.append(f_l)
    _, wp, w, u = best
    points = wp / w[:, None]
    points[0], points[-1] = q[0], q[-1]  # pinned: exact, not WP/w rounded
    return RationalFit(degree, knots, w, points, u, np.array(history), converged)


def _wp_map(n_mat: np.ndarray, q: np.ndarray) -> np.ndarray:
    """L with WP = L[c] @ w per coordinate c: eq. 7's least-squares WP is linear in the weights
    (its right-hand side Q_j sum_i N_i w_i is), with the end points pinned. Shape (dim, m, m)."""
    r, m = n_mat.shape
    dim = q.shape[1]
    inner = n_mat[:, 1:-1]
    # normal equations instead of a pseudo-inverse (an SVD per weight step was most of a fit's
    # time): the B-spline basis with data in every span is well conditioned
    gram = inner.T @ inner
    out = np.zeros((dim, m, m))
    for c in range(dim):
        rhs = q[:, c, None] * n_mat
        rhs[:, 0] -= n_mat[:, 0] * q[0, c]
        rhs[:, -1] -= n_mat[:, -1] * q[-1, c]
        out[c, 1:-1] = _solve_normal(gram, inner.T @ rhs, inner, rhs)
        out[c, 0, 0], out[c, -1, -1] = q[0, c], q[-1, c]
    return out


def _solve_normal(gram: np.ndarray, proj: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares solution of a x = b from its normal equations (gram = a^T a, proj = a^T b),
    or by SVD where they are singular."""
    try:
        return np.linalg.solve(gram, proj)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(a, b, rcond=None)[0]


def _weight_step(n_mat: np.ndarray, q: np.ndarray, wp: np.ndarray, w: np.ndarray):
    """New weights and the eq. 7 WP under them, only if they lower the data error (eq. 1)
    at the current parameters; returns (WP, w) with the largest weight 1.

    Two candidates: 001's eq. 9 (it minimises the homogeneous residual, which is not
    the distance, so its step alone can make the fit worse) and a Levenberg–Marquardt
    step on eq. 1 itself with WP eliminated through eq. 7 (C(u_j) is then a ratio of
    two linear functions of w, so the Jacobian is exact). The better one is taken."""
    lmap = _wp_map(n_mat, q)
    num = np.einsum("ji,cik->cjk", n_mat, lmap)  # (dim, r, m): numerator of C(u_j) per unit w

    def error(wt):
        den = n_mat @ wt
        c = np.einsum("cjk,k->jc", num, wt) / den[:, None]
        return q - c, c, den

    err, c, den = error(w)
    now = float(np.sum(err**2))
    trials = [_positive_step(w, _solve_weights(n_mat, q, wp, w))]  # 001 eq. 9
    jac = np.concatenate([(num[k] - c[:, k, None] * n_mat) / den[:, None] for k in range(q.shape[1])])
    jtj, jte = jac.T @ jac, jac.T @ np.concatenate([err[:, k] for k in range(q.shape[1])])
    diag = np.diag(np.diag(jtj) + 1e-12 * max(np.trace(jtj), 1e-300))
    for mu in (1e-3, 1e-2, 1e-1, 1.0):
        trials.append(_positive_step(w, w + np.linalg.solve(jtj + mu * diag, jte)))
    best, best_err = None, now
    for wt in trials:
        e2 = float(np.sum(error(wt)[0] ** 2))
        if e2 < best_err:
            best, best_err = wt, e2
    if best is None:
        return wp, w
    wp_new = np.stack([lmap[k] @ best for k in range(q.shape[1])], axis=1)
    s = best.max()
    return wp_new / s, best / s


def correct_params(spans: SpanPolynomials, wp, w, q, u) -> np.ndarray:
    """Each interior u_j by golden section in [u_{j-1}, u_{j+1}]; ends stay pinned."""  # 001 eq. 10-11
    if len(u) <= 2:
        return u
    new = u.copy()
    new[1:-1] = foot_params(spans.homogeneous(wp, w), spans.starts, np.ascontiguousarray(q[1:-1]),
                            u[:-2], u[2:], GOLDEN_STEPS)
    return np.maximum.accumulate(new)


def evaluate(fit: RationalFit, u: np.ndarray) -> np.ndarray:
    """Points of a fitted curve."""
    wp = fit.points * fit.weights[:, None]
    return eval_homogeneous(fit.knots, fit.degree, wp, fit.weights, np.asarray(u, dtype=float))
