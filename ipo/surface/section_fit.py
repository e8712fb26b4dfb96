"""Compatible rational fits of all cross-sections (001 §2 applied to a family of sections).

Skinning (001 eq. 15) interpolates the sections' homogeneous control points across
the sections, weights included. Fitted independently, each section's weights follow
its own measurement noise; their interpolant then swings between sections (measured
on a noisy saddle: one section with weights 0.63..1 among weight-1 sections made the
surface bulge 0.5 mm between two sections, and made weights negative elsewhere). So
the sections here share one weight vector: 001's alternating iteration, with eq. 7
solved per section and the weight step of eq. 8–9 stacked over all sections'
coordinates. The shared weights are constant across the sections, so the skinned
weights are exactly those weights: positive, and no swing between sections.

The count is the smallest (from order up) for which every section's largest point
error |Q_j - C(u_j)| is within the tolerance: weights 1 first (a polynomial fit is
enough for most shapes), the shared-weight rational fit where it is not.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ipo.errors import FIT_DATA, FIT_SETTINGS, FIT_TOLERANCE, IpoError
from ipo.fit.rational import (RationalFit, SpanPolynomials, basis_matrix, chord_params, correct_params,
                              evaluate, uniform_knots)

MIN_WEIGHT = 1e-2  # relative to the largest: keeps the shared weights away from a pole


@dataclass(frozen=True, slots=True)
class SectionFits:
    """Compatible section curves (same degree, knots and weights) and how well each fits."""

    fits: list[RationalFit]
    n_ctrl: int
    degree: int
    rational: bool  # False: all weights 1
    max_error_mm: np.ndarray  # (n_sections,) largest |Q_j - C(u_j)|
    rms_mm: np.ndarray  # (n_sections,) f_l of 001 App. I step 5 per section
    rms_history: np.ndarray  # f_l over all sections after each iteration


def _wp(n_mat: np.ndarray, q: np.ndarray, w: np.ndarray) -> np.ndarray:
    return np.linalg.lstsq(n_mat, q * (n_mat @ w)[:, None], rcond=None)[0]  # 001 eq. 7


def _errors(n_mats, sections, wps, w):
    return [q - (n @ wp) / (n @ w)[:, None] for n, q, wp in zip(n_mats, sections, wps)]


def _positive(w: np.ndarray, new: np.ndarray) -> np.ndarray:
    """Move from w towards new as far as every weight stays >= MIN_WEIGHT * max; largest weight 1."""
    floor = MIN_WEIGHT * w.max()
    low = new < floor
    if low.any():
        t = np.min((w[low] - floor) / np.maximum(w[low] - new[low], 1e-300))
        new = w + max(t, 0.0) * (new - w)
    return new / new.max()


def _eq9(n_mats, sections, wps, w) -> np.ndarray:
    """001 eq. 9 stacked over every section and coordinate."""
    rows = [q[:, c, None] * n for n, q in zip(n_mats, sections) for c in range(q.shape[1])]
    rhs = [n @ wp[:, c] for n, q, wp in zip(n_mats, sections, wps) for c in range(q.shape[1])]
    a, b = np.vstack(rows), np.concatenate(rhs)
    normal = a.T @ a
    lam = 1e-9 * max(np.trace(normal) / len(w), 1e-300)  # the data may leave the weights undetermined
    return np.linalg.solve(normal + lam * np.eye(len(w)), a.T @ b + lam * w)


def _weight_step(n_mats, sections, wps, w):
    """New shared weights and each section's eq. 7 WP under them, if they lower the summed eq. 1
    error at the current parameters; else the old ones.

    Candidates: 001's eq. 9 (it minimises the homogeneous residual, not the distance, and alone
    barely moves the weights: on a 120-degree arc with 5 control points it left the error 16x above
    the best), and Levenberg–Marquardt steps on eq. 1 itself with WP eliminated through eq. 7,
    which is linear in w: WP_c = L_c w, so C(u_j) is a ratio of linear functions of w."""
    maps = [[np.linalg.pinv(n) @ (q[:, c, None] * n) for c in range(q.shape[1])]
            for n, q in zip(n_mats, sections)]  # L_c per section: WP_c = L_c w (001 eq. 7)
    nums = [[n @ lc for lc in ls] for n, ls in zip(n_mats, maps)]

    def residuals(wt):
        out = []
        for n, q, num in zip(n_mats, sections, nums):
            den = n @ wt
            out += [q[:, c] - (num[c] @ wt) / den for c in range(q.shape[1])]
        return np.concatenate(out)

    res = residuals(w)
    jac = []
    for n, q, num in zip(n_mats, sections, nums):
        den = n @ w
        jac += [(num[c] - ((num[c] @ w) / den)[:, None] * n) / den[:, None] for c in range(q.shape[1])]
    jac = np.vstack(jac)
    jtj, jte = jac.T @ jac, jac.T @ res
    diag = np.diag(np.diag(jtj) + 1e-12 * max(np.trace(jtj), 1e-300))
    trials = [_positive(w, _eq9(n_mats, sections, wps, w))]
    trials += [_positive(w, w + np.linalg.solve(jtj + mu * diag, jte)) for mu in (1e-3, 1e-2, 1e-1, 1.0)]
    best, best_e2 = None, float(res @ res)
    for wt in trials:
        r = residuals(wt)
        if r @ r < best_e2:
            best, best_e2 = wt, float(r @ r)
    if best is None:
        return wps, w
    return [np.stack([lc @ best for lc in ls], axis=1) for ls in maps], best


def fit_shared(sections: list[np.ndarray], n_ctrl: int, degree: int = 3, *, rational: bool = True,
               max_iter: int = 30, rel_delta: float = 1e-3, give_up_above: float | None = None) -> SectionFits:
    """001 Appendix I over all sections at once with one shared weight vector (weights 1 if not
    rational). Stops when f_{l-1} - f_l < rel_delta f_{l-1}, or (give_up_above) once the largest
    point error, falling at its current rate for the iterations left, cannot reach that value;
    returns the best iterate."""
    for h, q in enumerate(sections):
        if len(q) < n_ctrl:
            raise IpoError(FIT_DATA, f"section {h + 1} has {len(q)} points, fewer than {n_ctrl} control points")
    knots = uniform_knots(n_ctrl, degree)
    us = [chord_params(q, knots[-1]) for q in sections]
    w = np.ones(n_ctrl)
    n_pts = sum(len(q) for q in sections)
    spans = SpanPolynomials(knots, degree)
    # the weights-1 solve is a candidate too: with as many control points as points it interpolates,
    # and a weight step from there can only add rounding-noise weights (and poles) to it
    n_mats = [basis_matrix(knots, degree, u, n_ctrl) for u in us]
    wps = [_wp(n, q, w) for n, q in zip(n_mats, sections)]
    errs = _errors(n_mats, sections, wps, w)
    best = (float(np.sqrt(sum(np.sum(e**2) for e in errs) / max(n_pts - 1, 1))), wps, w.copy(), us, errs)
    history, worst_prev, converged = [], np.inf, False
    for it in range(max_iter):
        n_mats = [basis_matrix(knots, degree, u, n_ctrl) for u in us]
        wps = [_wp(n, q, w) for n, q in zip(n_mats, sections)]
        if rational:
            wps, w = _weight_step(n_mats, sections, wps, w)
        us = [correct_params(spans, wp, w, q, u) for wp, q, u in zip(wps, sections, us)]  # 001 eq. 10-11
        n_mats = [basis_matrix(knots, degree, u, n_ctrl) for u in us]
        errs = _errors(n_mats, sections, wps, w)
        f_l = float(np.sqrt(sum(np.sum(e**2) for e in errs) / max(n_pts - 1, 1)))  # 001 App. I step 5
        if f_l < best[0]:
            best = (f_l, [wp.copy() for wp in wps], w.copy(), [u.copy() for u in us], errs)
        converged = stop = bool(history) and history[-1] - f_l < rel_delta * history[-1]
        worst = max(float(np.max(np.sum(e**2, axis=1))) for e in errs) ** 0.5
        if give_up_above is not None and worst - (max_iter - it - 1) * max(worst_prev - worst, 0.0) > give_up_above:
            stop = True
        worst_prev = worst
        history.append(f_l)
        if stop:
            break
    _, wps, w, us, errs = best
    fits = [RationalFit(degree, knots, w, wp / w[:, None], u, np.array(history), converged)
            for wp, u in zip(wps, us)]
    max_err = np.array([np.max(np.linalg.norm(e, axis=1)) for e in errs])
    rms = np.array([np.sqrt(np.sum(e**2) / max(len(e) - 1, 1)) for e in errs])
    return SectionFits(fits, n_ctrl, degree, rational, max_err, rms, np.array(history))


def fit_sections(sections: list[np.ndarray], *, degree: int = 3, tol_mm: float | None = None,
                 n_ctrl: int | None = None, max_iter: int = 30) -> SectionFits:
    """All sections with one control-point count: `n_ctrl` if given (rational), else the smallest
    count whose fits are all within `tol_mm`, counting up from degree + 1 (the error is not
    monotone in the count, so a bisection could skip the smallest)."""
    if degree < 1:
        raise IpoError(FIT_SETTINGS, f"degree must be >= 1, got {degree}")
    if not sections:
        raise IpoError(FIT_DATA, "no sections to fit")
    fewest = min(len(q) for q in sections)
    if n_ctrl is not None:
        if not degree + 1 <= n_ctrl <= fewest:
            raise IpoError(FIT_SETTINGS, f"control-point count {n_ctrl} must be in {degree + 1}..{fewest} "
                                         f"(order {degree + 1}; the smallest section has {fewest} points)")
        return fit_shared(sections, n_ctrl, degree, max_iter=max_iter)
    if tol_mm is None or not tol_mm > 0:
        raise IpoError(FIT_SETTINGS, f"give a tolerance > 0 mm or a control-point count (tol_mm={tol_mm})")
    if fewest < degree + 1:
        raise IpoError(FIT_DATA, f"a section has {fewest} points; order {degree + 1} needs at least {degree + 1}")
    worst = np.inf
    for m in range(degree + 1, fewest + 1):
        for rational in (False, True):
            trial = fit_shared(sections, m, degree, rational=rational, max_iter=max_iter, give_up_above=tol_mm)
            if trial.max_error_mm.max() <= tol_mm:
                return trial
            worst = min(worst, float(trial.max_error_mm.max()))
    raise IpoError(FIT_TOLERANCE, f"no control-point count up to {fewest} fits every section within {tol_mm} mm "
                                  f"(best worst-section error {worst:.4g} mm)")


def section_error(fit: RationalFit, q: np.ndarray) -> float:
    """Largest |Q_j - C(u_j)| of one fitted section."""
    return float(np.max(np.linalg.norm(q - evaluate(fit, fit.params), axis=1)))
