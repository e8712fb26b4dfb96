"""A fit as the blocks that write it: Fanuc G06.2 (knots and weights written) or LinuxCNC G5.2
(uniform knots, XY plane), in the program's own units and frame, and the curve exactly as those
blocks put it (rounded control points, weights and knots), which is what the checks measure.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ipo.fit.rational import RationalFit

END_DIGITS = 9  # the last control point: as exact as the source's own number
WEIGHT_DIGITS = 7  # significant digits of a weight (weights span several decades)
KNOT_DIGITS = 6


@dataclass(frozen=True, slots=True)
class Frame:
    """How program numbers map to machine mm on a line: machine = value * unit + offset (G90)."""

    unit_mm: float
    absolute: bool
    offset_mm: tuple[float, float, float]
    plane: str = "XY"
    # program numbers map to machine mm by unit and offset alone, at a feed per minute: no cutter
    # compensation, no rotated system (G10 L2 R), no G93/G95 (ipr's detour); other lines are not fitted
    direct: bool = True
    arc_absolute: bool = False  # G90.1: I/J/K are the centre's coordinates; G91.1 (default): from the start


def fmt(value: float, digits: int) -> str:
    s = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0", "-") else s


def coordinate_digits(tol_mm: float, unit_mm: float) -> int:
    """Decimals for interior control points: a rounding step no larger than tol / 87, so that
    rounding all three axes (half a step each) moves the curve by at most ~tol / 100 (4 decimals at
    10 um in mm). The fit gives that much of the tolerance up (ipo.fit.convert): ~tol / 10 (3 decimals)
    cost g1_lhchips4 at 10 um 65 written blocks (4257 instead of 4192) for 2 % fewer bytes."""
    return max(3, math.ceil(-math.log10(tol_mm / (87.0 * unit_mm))))


def rounding_bound_mm(digits: int, unit_mm: float) -> float:
    return 0.5 * 10.0**-digits * unit_mm * math.sqrt(3.0)


def feed_text(feed_mm_s: float, frame: Frame) -> str:
    return fmt(feed_mm_s * 60.0 / frame.unit_mm, 6)


def _written(fit: RationalFit, frame: Frame, digits: int) -> tuple[list[list[str]], np.ndarray]:
    """The axis words of control points 1.. (absolute or, in G91, relative to the previous one; the
    last one as exact as the source's own number) and every control point as these words put it."""
    unit, off = frame.unit_mm, np.array(frame.offset_mm)
    start = fit.points[0]
    step = 10 ** (END_DIGITS - digits)
    if frame.absolute:
        nano = np.rint((fit.points - off) / unit * 10**END_DIGITS).astype(np.int64)
    else:
        nano = np.rint((fit.points - start) / unit * 10**END_DIGITS).astype(np.int64)
    nano[1:-1] = np.rint(nano[1:-1] / step).astype(np.int64) * step
    words = nano[1:] if frame.absolute else np.diff(nano, axis=0)
    written = [[fmt(v / 10**END_DIGITS, END_DIGITS) for v in row] for row in words]
    values = np.array([[float(v) for v in row] for row in written])
    pts = np.empty_like(fit.points)
    pts[0] = start
    pts[1:] = values * unit + off if frame.absolute else start + np.cumsum(values, axis=0) * unit
    return written, pts


def group_text(fit: RationalFit, feed_mm_s: float, frame: Frame, digits: int) -> tuple[list[str], RationalFit]:
    """Fanuc G06.2 blocks for `fit` (points in machine mm) and the curve exactly as written."""
    p = fit.degree
    written, pts = _written(fit, frame, digits)
    weights = np.array([round(w, weight_decimals(w)) for w in fit.weights])
    knots = np.round(fit.knots, KNOT_DIGITS)

    def r_word(i):
        return "" if weights[i] == 1.0 else f" R{fmt(weights[i], weight_decimals(weights[i]))}"

    out = [f"G06.2 P{p + 1} K{fmt(knots[0], KNOT_DIGITS)}{r_word(0)} F{feed_text(feed_mm_s, frame)}"]
    prev = None
    for i, vals in enumerate(written, 1):
        axes = "".join(f" {a}{v}" for a, v, pv in zip("XYZ", vals, prev or (None,) * 3)
                       if (v != pv if frame.absolute else v != "0"))
        out.append(f"K{fmt(knots[i], KNOT_DIGITS)}{axes}{r_word(i)}")
        prev = vals
    out += [f"K{fmt(k, KNOT_DIGITS)}" for k in knots[len(fit.points):]]
    return out, replace(fit, points=pts, weights=weights, knots=knots)


def weight_decimals(w: float) -> int:
    """Decimals that write a weight (0 < w <= 1) with WEIGHT_DIGITS significant digits."""
    return max(WEIGHT_DIGITS - 1 - math.floor(math.log10(w)), 0)


def g52_text(fit: RationalFit, feed_mm_s: float, frame: Frame, digits: int) -> tuple[list[str], RationalFit]:
    """LinuxCNC G5.2 blocks (XY plane, one Z) for a fit on uniform knots, and the curve as written.

    G5.2 takes the current position as control point 0 with weight 1 and makes its own uniform
    knots (ipr.nurbs_groups.g5_knots: 001's uniform_knots scaled), so the weights are scaled to
    w_0 = 1 (the curve is the same) and no knot is written: m control points cost m - 1 blocks
    and the closing G5.3."""
    written, pts = _written(fit, frame, digits)
    weights = np.round(fit.weights / fit.weights[0], 6)
    weights[0] = 1.0
    out = []
    for i, vals in enumerate(written, 1):
        head = f"G5.2 L{fit.degree + 1} F{feed_text(feed_mm_s, frame)} " if i == 1 else ""
        out.append(f"{head}X{vals[0]} Y{vals[1]} P{fmt(weights[i], 6)}")
    out.append("G5.3")
    pts[:, 2] = fit.points[0, 2]
    return out, replace(fit, points=pts, weights=weights)
