"""Program -> program: replace G01 runs by Fanuc G06.2 groups (001 rational fits).

Works on the text: the program is interpreted once (ipr.Interpreter, line by line,
so that each entity is tied to its source line together with the units, distance
mode and offsets in force there); every line outside a fitted piece is copied
unchanged. A G06.2 group starts at the current position (its first block carries
no axis word) and its last control point is the run's last vertex, written with
enough digits to reproduce it exactly. The curve as written (rounded coordinates
and weights) is checked against the tolerance again; a piece that fails stays G01.
"""
from __future__ import annotations

import math
import multiprocessing
import os
import re
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from ipo.fit.tolerance import FitSettings, Piece, fit_polyline, max_deviation, nurbs_blocks
from ipo.fit.g01_runs import DEFAULT_CORNER_DEG, run_vertices, split_runs
from ipo.fit.rational import RationalFit
from ipr import Setup, parse_line
from ipr.entities import Line
from ipr.interpreter import Interpreter

PURE_LETTERS = frozenset("NGXYZF")
AXIS_LETTERS = frozenset("XYZ")
# G codes that use axis words without needing a motion mode (they carry their own meaning)
OWN_AXIS_G = frozenset({0.0, 1.0, 2.0, 3.0, 5.2, 6.2, 10.0, 28.0, 30.0, 92.0})
END_DIGITS = 9  # the last control point: as exact as the source's own number
WEIGHT_DIGITS = 6
_N_WORD = re.compile(r"^\s*(N\s*\d+)\s*", re.IGNORECASE)


@dataclass(frozen=True, slots=True)
class Frame:
    """How program numbers map to machine mm on a line: machine = value * unit + offset (G90)."""

    unit_mm: float
    absolute: bool
    offset_mm: tuple[float, float, float]


@dataclass(slots=True)
class ConvertReport:
    runs: int = 0  # G01 runs of two moves or more
    short_runs: int = 0  # too short for a G06.2 group to save blocks
    groups: int = 0
    moves_replaced: int = 0
    # the fewest blocks any conversion of these runs could reach: every run as one group of
    # degree + 1 control-point blocks and degree + 1 knot blocks where that is shorter than the run
    blocks_bound: int = 0
    kept_g01: list[tuple[int, str]] = field(default_factory=list)  # (source line, why) pieces left G01
    max_deviation_mm: float = 0.0
    fit_time_s: float = 0.0
    blocks_before: int = 0
    blocks_after: int = 0
    bytes_before: int = 0
    bytes_after: int = 0


def count_blocks(text: str) -> int:
    """Lines that carry a word (not blank, not comment-only, not '%')."""
    n = 0
    for raw in text.split("\n"):
        s = re.sub(r"\([^)]*\)", "", raw.split(";", 1)[0]).strip()
        if s and s != "%":
            n += 1
    return n


def fmt(value: float, digits: int) -> str:
    s = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0", "-") else s


def coordinate_digits(tol_mm: float, unit_mm: float) -> int:
    """Decimals for interior control points: a rounding step no larger than tol / 8.7, so that
    rounding all three axes (half a step each) moves the curve by at most ~tol / 10."""
    return max(3, math.ceil(-math.log10(tol_mm / (8.7 * unit_mm))))


def rounding_bound_mm(digits: int, unit_mm: float) -> float:
    return 0.5 * 10.0**-digits * unit_mm * math.sqrt(3.0)


def _interpret(lines: list[str], file: str, setup: Setup | None):
    """Entities in order, the frame of each line that made exactly one Line, and per-line entity counts."""
    interp = Interpreter(file, setup, all_errors=False)
    entities, frames, counts = [], {}, {}
    for n, text in enumerate(lines, 1):
        interp.feed(n, text)
        out = interp.out
        if out:
            counts[n] = len(out)
            if len(out) == 1 and isinstance(out[0], Line):
                st = interp.state
                frames[n] = Frame(float(st.unit), bool(st.absolute), tuple(float(c) for c in st.offset))
            entities.extend(out)
            out.clear()
        if interp.done:
            break
    interp.finish(len(lines))
    return entities, frames, counts


def _pure(text: str) -> bool:
    """A plain G1 block: only N, G1, X, Y, Z, F words, no comment, assignment or block delete."""
    if "(" in text or ";" in text:
        return False
    block = parse_line(text)
    if block.assigns or block.messages or block.delete or block.percent:
        return False
    for letter, value in block.words:
        if letter not in PURE_LETTERS or (letter == "G" and value != 1.0):
            return False
    return True


def _needs_motion_mode(lines: list[str], start: int) -> bool:
    """Does the first line from index `start` on that uses axis words rely on the modal motion?"""
    for text in lines[start:]:
        block = parse_line(text)
        letters = {l for l, _ in block.words}
        gs = {v for l, v in block.words if l == "G" and isinstance(v, float)}
        if gs & OWN_AXIS_G:
            return False
        if letters & AXIS_LETTERS:
            return True
    return False


def _with_g1(text: str) -> str:
    """The same block with an explicit G1 (a G06.2 group leaves no motion mode active)."""
    if any(l == "G" for l, _ in parse_line(text).words):
        return text
    m = _N_WORD.match(text)
    return f"{m.group(1)} G1 {text[m.end():]}" if m else f"G1 {text.lstrip()}"


def group_text(fit: RationalFit, feed_mm_s: float, frame: Frame, digits: int) -> tuple[list[str], RationalFit]:
    """Fanuc G06.2 blocks for `fit` (points in machine mm) and the curve exactly as written."""
    p = fit.degree
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
    weights = np.round(fit.weights, WEIGHT_DIGITS)
    knots = fit.knots

    def r_word(i):
        return "" if weights[i] == 1.0 else f" R{fmt(weights[i], WEIGHT_DIGITS)}"

    out = [f"G06.2 P{p + 1} K{fmt(knots[0], 6)}{r_word(0)} F{fmt(feed_mm_s * 60.0 / unit, 6)}"]
    prev = None
    for i, vals in enumerate(written, 1):
        axes = "".join(f" {a}{v}" for a, v, pv in zip("XYZ", vals, prev or (None,) * 3)
                       if (v != pv if frame.absolute else v != "0"))
        out.append(f"K{fmt(knots[i], 6)}{axes}{r_word(i)}")
        prev = vals
    out += [f"K{fmt(k, 6)}" for k in knots[len(fit.points):]]
    values = np.array([[float(v) for v in row] for row in written])
    pts = np.empty_like(fit.points)
    pts[0] = start
    pts[1:] = values * unit + off if frame.absolute else start + np.cumsum(values, axis=0) * unit
    return out, replace(fit, points=pts, weights=weights)


def convert_text(text: str, tol_mm: float, *, degree: int = 3, corner_deg: float = DEFAULT_CORNER_DEG,
                 file: str = "<string>", setup: Setup | None = None,
                 jobs: int | None = None) -> tuple[str, ConvertReport]:
    """The program with its G01 runs fitted within tol_mm, and what was done (jobs: worker
    processes for the fits, default one per core)."""
    if not tol_mm > 0:
        raise ValueError(f"tolerance must be > 0 mm, got {tol_mm}")
    if not 1 <= degree <= 5:
        raise ValueError(f"degree must be 1..5 (G06.2 order P 2..6), got {degree}")
    lines = text.split("\n")  # as the IPR numbers lines: "\n" only
    entities, frames, counts = _interpret(lines, file, setup)
    pure = {n for n in frames if _pure(lines[n - 1])}

    def joinable(a: Line, b: Line) -> bool:
        return b.line == a.line + 1 and a.line in pure and b.line in pure and frames[a.line] == frames[b.line]

    report = ConvertReport(bytes_before=len(text.encode()), blocks_before=count_blocks(text))
    replaced: dict[int, list[str]] = {}  # first source line of a run -> its new text
    skip: set[int] = set()
    t0 = time.perf_counter()
    todo = []
    for run in split_runs(entities, corner_deg=corner_deg, joinable=joinable):
        if len(run) < 2 or run[0].line not in pure:
            continue
        report.runs += 1
        report.blocks_bound += min(0, 2 * (degree + 1) - len(run))
        if len(run) <= nurbs_blocks(degree + 1, degree):
            report.short_runs += 1
            continue
        todo.append(run)
    settings = [_settings(tol_mm, degree, frames[run[0].line]) for run in todo]
    for run, pieces in zip(todo, _fit_all([run_vertices(r) for r in todo], settings, jobs)):
        new = _convert_run(run, pieces, lines, frames[run[0].line], tol_mm, report)
        if new is not None:
            replaced[run[0].line] = new
            skip.update(e.line for e in run)
    report.fit_time_s = time.perf_counter() - t0
    out: list[str] = []
    for n, raw in enumerate(lines, 1):
        if n in replaced:
            out += replaced[n]
        elif n not in skip:
            out.append(raw)
    result = "\n".join(out)
    report.blocks_bound += report.blocks_before
    report.bytes_after = len(result.encode())
    report.blocks_after = count_blocks(result)
    return result, report


def _settings(tol_mm: float, degree: int, frame: Frame) -> FitSettings:
    """The fit's own tolerance: T less what rounding the written control points can add."""
    return FitSettings(tol_mm - rounding_bound_mm(coordinate_digits(tol_mm, frame.unit_mm), frame.unit_mm), degree)


def _fit_all(polylines: list[np.ndarray], settings: list[FitSettings], jobs: int | None) -> list[list[Piece]]:
    """fit_polyline on every run, in worker processes where there is more than one core to use
    (each run's fit is independent of the others; results come back in order)."""
    jobs = (os.cpu_count() or 1) if jobs is None else jobs
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    if jobs == 1 or len(polylines) < 2 * jobs:
        return [fit_polyline(q, s) for q, s in zip(polylines, settings)]
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(fit_polyline, polylines, settings, chunksize=4))


def _convert_run(run: list[Line], pieces: list[Piece], lines: list[str], frame: Frame, tol_mm: float,
                 report: ConvertReport) -> list[str] | None:
    """New text for one run from its fitted pieces, or None if it stays as it is."""
    digits = coordinate_digits(tol_mm, frame.unit_mm)
    out: list[str] = []
    after_group = False
    any_group = False
    for piece in pieces:
        group = _group_for(piece, run, frame, digits, tol_mm, report) if piece.fit else None
        if group is None:
            if piece.fit is None:
                report.kept_g01.append((run[piece.first].line, piece.reason))
            src = [lines[e.line - 1] for e in run[piece.first:piece.last]]
            if after_group:
                src[0] = _with_g1(src[0])
            out += src
            after_group = False
        else:
            out += group
            after_group = any_group = True
            report.groups += 1
            report.moves_replaced += piece.last - piece.first
    if not any_group:
        return None
    if after_group and _needs_motion_mode(lines, run[-1].line):
        out.append("G1")
    return out


def _group_for(piece: Piece, run, frame, digits, tol_mm, report) -> list[str] | None:
    text, written = group_text(piece.fit, run[piece.first].feed_mm_s, frame, digits)
    dev = max_deviation(written, piece.data)
    if dev > tol_mm:
        report.kept_g01.append((run[piece.first].line, f"rounded curve {dev * 1e3:.3f} um off"))
        return None
    report.max_deviation_mm = max(report.max_deviation_mm, dev)
    return text
