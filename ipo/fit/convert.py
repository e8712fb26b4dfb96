"""Program -> program: replace chains of G01/G02/G03 moves by G06.2 (or G5.2) groups within a tolerance.

Chains run through corners (ipo.fit.chains). G06.2 (the default) writes rational quadratic conic
spans with their own knots and weights (ipo.fit.conic_plan, ipo.fit.weights), and runs of G1 moves
as one G1 line or G2/G3 arc where that costs fewer blocks (ipo.fit.arcs); G5.2, or a degree
of 3 or more, 001's rational fits on uniform knots (ipo.fit.groups); a sharp corner is a knot of
multiplicity = degree. The program is interpreted once, line by line, so each entity keeps its
source line and the modes and offsets in force there; lines outside a fitted piece are copied
unchanged. The curve as written (rounded; an arc as the controller's arc geometry makes it) is
checked against the tolerance again, and a group by the
controller's own test where the caller hands it in (`walkable`: machine/ does, so that vcnc fit
never writes a group vcnc run refuses); the moves of a group that fails either check are planned again
in halves until each piece passes or is too short to halve (fewer than MIN_SPLIT moves); such a piece that still
fails stays G01.
"""
from __future__ import annotations

import math
import multiprocessing
import os
import re
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from ipo.errors import FIT_SETTINGS, IpoError
from ipo.fit.arcs import PLANE_CODE, move_text
from ipo.fit.chains import DEFAULT_CORNER_DEG, Chain, split_chains, sub_chain
from ipo.fit.distance import written_deviation_mm
from ipo.fit.groups import FitOptions, Span, plan_chain, sharp_of
from ipo.fit.modal_text import (motion_code, restore_cost, restore_motion, restore_plane, restored, with_feed,
                                with_plane)
from ipo.fit.quadratic import plan_chain_conic
from ipo.fit.written import Frame, coordinate_digits, feed_text, g52_text, group_text, rounding_bound_mm
from ipr import Setup, parse_line
from ipr.entities import Arc, Line, Nurbs
from ipr.interpreter import Interpreter

PURE_LETTERS = frozenset("NGXYZIJKRF")
PURE_G = frozenset({1.0, 2.0, 3.0})
DIALECTS = ("g06.2", "g5.2")
NO_SAVING = "no group saves blocks"  # why a piece is kept where no fit is wrong: G1 is cheaper there
REFUSED = "the controller cannot follow the group"  # why a group that fits is kept G1 (walkable said no)
MIN_SPLIT = 4  # a group that fails a check as written is planned again in halves while it has this many moves


@dataclass(slots=True)
class ConvertReport:
    chains: int = 0  # chains of two moves or more (G1/G2/G3 without a break)
    sharp_corners: int = 0  # vertices kept sharp inside groups (a knot of multiplicity = degree)
    double_knots: int = 0  # the other knots of multiplicity 2 (conic spans: the weights restart, the curve is tangent)
    sharp_vertices: int = 0  # the chains' vertices that must stay sharp (ipo.fit.chains.sharp_vertices)
    feeds_merged: int = 0  # feed changes inside groups and written G1/G2/G3 runs (all beyond the machine's reach)
    groups: int = 0
    arcs: int = 0  # G2/G3 blocks written for runs of G1 moves (ipo.fit.arcs)
    lines: int = 0  # G1 blocks written for runs of G1 moves within tol of one line
    moves_replaced: int = 0  # by groups, arcs and lines
    kept_g01: list[tuple[int, str]] = field(default_factory=list)  # (source line, why) pieces left G01
    max_deviation_mm: float = 0.0
    fit_time_s: float = 0.0
    blocks_before: int = 0
    blocks_after: int = 0
    bytes_before: int = 0
    bytes_after: int = 0


NOT_DIRECT = "cutter compensation, a rotated system (G10 L2 R) or G93/G95: written as it is"


def count_blocks(text: str) -> int:
    """Lines that carry a word (not blank, not comment-only, not '%')."""
    words = (re.sub(r"\([^)]*\)", "", raw.split(";", 1)[0]).strip() for raw in text.split("\n"))
    return sum(1 for s in words if s and s != "%")


def _interpret(lines: list[str], file: str, setup: Setup | None):
    """Entities in order, the frame of each line that made exactly one Line, and per-line entity counts."""
    interp = Interpreter(file, setup, all_errors=False)
    entities, frames, counts = [], {}, {}
    for n, text in enumerate(lines, 1):
        interp.feed(n, text)
        out = interp.out
        if out:
            counts[n] = len(out)
            if len(out) == 1 and isinstance(out[0], (Line, Arc)):
                st = interp.state
                frames[n] = Frame(float(st.unit), bool(st.absolute), tuple(float(c) for c in st.offset), st.plane,
                                  not st.detour, bool(st.arc_absolute))
            entities.extend(out)
            out.clear()
        if interp.done:
            break
    interp.finish(len(lines))
    return entities, frames, counts


def _pure(text: str) -> bool:
    """A plain motion block: only N, G1/G2/G3, X, Y, Z, I, J, K, R, F words, no comment, assignment
    or block delete (dropping it changes nothing but the path)."""
    if "(" in text or ";" in text:
        return False
    block = parse_line(text)
    if block.assigns or block.messages or block.delete or block.percent:
        return False
    for letter, value in block.words:
        if letter not in PURE_LETTERS or (letter == "G" and value not in PURE_G):
            return False
    return True


def convert_text(text: str, tol_mm: float, *, degree: int | None = None, corner_deg: float = DEFAULT_CORNER_DEG,
                 file: str = "<string>", setup: Setup | None = None, jobs: int | None = None,
                 accel_mm_s2: float = 1000.0, max_feed_mm_s: float = 100.0, reach_mm_s: float | None = None,
                 dialect: str = "g06.2", walkable: Callable[[Nurbs], str | None] | None = None,
                 arcs: bool = True) -> tuple[str, ConvertReport]:
    """The program with its chains fitted within tol_mm, and what was done (jobs: worker processes for the
    fits, default one per core; accel_mm_s2, max_feed_mm_s: the machine's, for the sharp-corner test of
    ipo.fit.chains; reach_mm_s: the fastest path speed its axes reach together (feeds at or above it are one
    feed, ipo.fit.chains.same_feed; default that of max_feed_mm_s on three axes; 0: never merge feeds);
    dialect: "g06.2" (Fanuc, 3-D, knots written, groups through corners) or "g5.2" (LinuxCNC, XY plane at
    one Z, uniform knots, a group per piece); degree: None for the dialect's own (G06.2: 2, conic spans; G5.2: 3);
    walkable: the controller's test of a group as written (None, or why it cannot follow it: machine/ hands in
    its check, ipo.feed.split.planning_problem); a group it refuses stays as the moves it replaces); arcs: runs of
    G1 moves may be written as one G1 line or G2/G3 arc where that costs fewer blocks (G06.2, ipo.fit.arcs)."""
    if dialect not in DIALECTS:
        raise IpoError(FIT_SETTINGS, f"dialect must be one of {', '.join(DIALECTS)}, got {dialect!r}")
    if not tol_mm > 0:
        raise IpoError(FIT_SETTINGS, f"tolerance must be > 0 mm, got {tol_mm}")
    if degree is None:
        degree = 2 if dialect == "g06.2" else 3
    if not 1 <= degree <= 5:
        raise IpoError(FIT_SETTINGS, f"degree must be 1..5 (G06.2 order P 2..6), got {degree}")
    lines = text.split("\n")  # as the IPR numbers lines: "\n" only
    entities, frames, counts = _interpret(lines, file, setup)
    pure = {n for n in frames if frames[n].direct and _pure(lines[n - 1])}
    reach = math.sqrt(3.0) * max_feed_mm_s if reach_mm_s is None else (reach_mm_s or None)

    def joinable(a, b) -> bool:
        return b.line == a.line + 1 and a.line in pure and b.line in pure and frames[a.line] == frames[b.line]

    report = ConvertReport(bytes_before=len(text.encode()), blocks_before=count_blocks(text))
    report.kept_g01 += [(n, NOT_DIRECT) for n in sorted(frames)
                        if not frames[n].direct and (n - 1 not in frames or frames[n - 1].direct)]
    replaced: dict[int, list[str]] = {}  # first source line of a chain -> its new text
    skip: set[int] = set()
    prefix: dict[int, str] = {}  # source line -> the motion code it needs after a group
    planes: dict[int, str] = {}  # source line -> the plane code it needs after an arc in another plane
    after: dict[int, list[str]] = {}  # source line -> blocks written after it
    t0 = time.perf_counter()
    chains = [c for c in split_chains(entities, tol_mm, joinable, reach) if c.moves[0].line in pure]
    if dialect == "g5.2":  # LinuxCNC's G5.2 lies in the XY plane and cannot move Z
        flat = [frames[c.moves[0].line].plane == "XY" and np.ptp(c.points[:, 2]) == 0.0 for c in chains]
        report.kept_g01 += [(c.moves[0].line, "not in the XY plane at one Z (G5.2)")
                            for c, ok in zip(chains, flat) if not ok]
        chains = [c for c, ok in zip(chains, flat) if ok]
    report.chains = len(chains)
    options = [replace(_options(tol_mm, degree, frames[c.moves[0].line], corner_deg, accel_mm_s2, max_feed_mm_s),
                       joins=dialect == "g06.2", restore_blocks=restore_cost(lines, c.moves[-1].line), arcs=arcs)
               for c in chains]
    report.sharp_vertices = sum(len(sharp_of(c, o)) for c, o in zip(chains, options))
    planner = plan_chain_conic if dialect == "g06.2" and degree == 2 else plan_chain
    plans = _map(planner, chains, options, jobs=jobs)
    writer = g52_text if dialect == "g5.2" else group_text
    chain_frames = [frames[c.moves[0].line] for c in chains]
    how = (tol_mm, writer, walkable, jobs)
    written = _written_all(chains, plans, chain_frames, how)
    while _split_failed(chains, options, chain_frames, plans, written, planner, how):
        pass
    for chain, spans, groups in zip(chains, plans, written):
        frame = frames[chain.moves[0].line]
        new, tail, tail_feed_mm_s, tail_plane = _convert_chain(chain, spans, groups, lines, frame, report)
        if new is None:
            continue
        replaced[chain.moves[0].line] = new
        skip.update(m.line for m in chain.moves)
        last = chain.moves[-1]
        feed = None if last.feed_mm_s == tail_feed_mm_s else feed_text(last.feed_mm_s, frame)
        if tail != motion_code(last) or feed is not None:  # a group, an arc, or moves at the lowest feed
            restore_motion(lines, last.line, motion_code(last), feed, after, prefix)
        if tail_plane != frame.plane:  # an arc in another plane ends the chain
            restore_plane(lines, last.line, PLANE_CODE[frame.plane], after, planes)
    report.fit_time_s = time.perf_counter() - t0
    out: list[str] = []
    for n, raw in enumerate(lines, 1):
        if n in replaced:
            new = replaced[n]
            # a chain that starts with a kept move right after a group ending the previous chain
            new = [restored(new[0], *prefix[n])] + new[1:] if n in prefix and new[0] == raw else new
            out += [_planed(new[0], planes.get(n))] + new[1:]
        elif n not in skip:
            out.append(_planed(restored(raw, *prefix[n]) if n in prefix else raw, planes.get(n)))
        out += after.get(n, [])
    result = "\n".join(out)
    report.bytes_after = len(result.encode())
    report.blocks_after = count_blocks(result)
    return result, report


def _options(tol_mm: float, degree: int, frame: Frame, corner_deg: float, accel_mm_s2: float,
             max_feed_mm_s: float) -> FitOptions:
    """The fit's own tolerance: T less what rounding the written control points can add (a piece with
    arcs also gives up their chords' sag, ipo.fit.groups)."""
    fit_tol = tol_mm - rounding_bound_mm(coordinate_digits(tol_mm, frame.unit_mm), frame.unit_mm)
    return FitOptions(fit_tol, degree, accel_mm_s2, max_feed_mm_s, corner_deg, plane=frame.plane)


def _map(fn, *items: list, jobs: int | None) -> list:
    """fn over the items in order, in worker processes where there is more than one core to use and
    enough items to share (each call is independent of the others)."""
    jobs = (os.cpu_count() or 1) if jobs is None else jobs
    if jobs < 1:
        raise IpoError(FIT_SETTINGS, f"jobs must be >= 1, got {jobs}")
    if jobs == 1 or len(items[0]) < 2 * jobs:
        return [fn(*args) for args in zip(*items)]
    # a few chunks per worker: sizes vary (one chain can hold most of a program), and tiny tasks one by
    # one would cost more in hand-overs than they do to run
    chunk = max(1, len(items[0]) // (8 * jobs))
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(fn, *items, chunksize=chunk))


@dataclass(frozen=True, slots=True)
class _Written:
    """A fitted span as written: its blocks, the curve's deviation as written, and the verdicts on it."""

    text: list[str]
    deviation_mm: float
    off: bool  # beyond the tolerance once rounded
    refused: str | None  # why the controller cannot follow it (walkable), or None


def _written_all(chains: list[Chain], plans: list[list[Span]], frames: list[Frame],
                 how: tuple) -> list[list[_Written | None]]:
    """Every fitted span and one move written out (None where it is kept), in the worker pool (_written).
    how: (tol_mm, writer, walkable, jobs)."""
    tol_mm, writer, walkable, jobs = how
    at = [(i, j) for i, spans in enumerate(plans) for j, span in enumerate(spans) if not span.kept]
    moves = [chains[i].moves[plans[i][j].first:plans[i][j].last] for i, j in at]
    done = _map(_written, [plans[i][j] for i, j in at], moves, [frames[i] for i, _ in at],
                [chains[i].sag_mm for i, _ in at], [(tol_mm, writer, walkable)] * len(at), jobs=jobs)
    out: list[list[_Written | None]] = [[None] * len(spans) for spans in plans]
    for (i, j), w in zip(at, done):
        out[i][j] = w
    return out


def _written(span: Span, moves: tuple, frame: Frame, sag_mm: float, how: tuple) -> _Written:
    """A fitted span as written: STEP 1 write it and measure the curve as written; STEP 2 where it is within
    tol, the controller's check (it builds the arc-length tables of the run itself, most of a fit's time on
    dense real programs). how: (tol_mm, writer, walkable)."""
    tol_mm, writer, walkable = how
    feed = _lowest_feed(moves)
    digits = coordinate_digits(tol_mm, frame.unit_mm)
    if span.one_moves:  # G1 lines and G2/G3 arcs: the controller runs them as written
        at, blocks, dev = span.one_moves[0].start, [], 0.0
        for move in span.one_moves:  # each from where the one before it ends as written
            block, curve, end_gap_mm, at = move_text(move, frame, digits, moves[0].line, feed, at)
            blocks.append(block)
            dev = max(dev, written_deviation_mm(curve, move.path, tol_mm) + end_gap_mm)
        return _Written(blocks, dev, dev > tol_mm, None)
    text, written = writer(span.fit, feed, frame, digits)
    sag = sag_mm if any(isinstance(m, Arc) for m in moves) else 0.0
    dev = written_deviation_mm(written, span.data, tol_mm - sag) + sag
    refused = None
    if dev <= tol_mm and walkable is not None:
        refused = walkable(Nurbs(moves[0].line, written.degree, written.knots, written.weights, written.points, feed))
    return _Written(text, dev, dev > tol_mm, refused)


def _split_failed(chains: list[Chain], options: list[FitOptions], frames: list[Frame], plans: list[list[Span]],
                  written: list[list[_Written | None]], planner, how: tuple) -> bool:
    """Each group that is off as written or that the controller refuses, planned again as two chains of half
    its moves, written and checked, in its place in plans and written; whether there was one. A group's
    weights and knot intervals spread with its length (ipo.fit.weights) and the controller's arc-length
    table refuses the extremes: on g1_lhchips4 at 5 um two refused groups kept 700 moves as G1. The joined
    spans move a little from the spans as planned (3-D junctions, rounding): one group off by a fraction of a
    micrometre would otherwise keep hundreds of moves as G1."""
    todo = [(i, j) for i, groups in enumerate(written) for j, w in enumerate(groups)
            if w is not None and (w.off or w.refused is not None) and plans[i][j].last - plans[i][j].first >= MIN_SPLIT]
    halves = []  # (chain, options, frame, first move in the whole chain)
    for i, j in todo:
        span = plans[i][j]
        mid = (span.first + span.last) // 2
        for a, b in ((span.first, mid), (mid, span.last)):
            restore = options[i].restore_blocks if b == len(chains[i].moves) else 0
            halves.append((sub_chain(chains[i], a, b), replace(options[i], restore_blocks=restore), frames[i], a))
    new_plans = _map(planner, [h[0] for h in halves], [h[1] for h in halves], jobs=how[3])
    new_written = _written_all([h[0] for h in halves], new_plans, [h[2] for h in halves], how)
    for k, (i, j) in reversed(list(enumerate(todo))):  # the last first: the indices before it stay
        pair = (2 * k, 2 * k + 1)
        plans[i][j:j + 1] = [replace(s, first=s.first + halves[h][3], last=s.last + halves[h][3])
                             for h in pair for s in new_plans[h]]
        written[i][j:j + 1] = [w for h in pair for w in new_written[h]]
    return bool(todo)


GROUP = "group"


def _convert_chain(chain: Chain, spans: list[Span], groups: list[_Written | None], lines: list[str], frame: Frame,
                   report: ConvertReport) -> tuple[list[str] | None, str | None, float | None, str | None]:
    """New text for one chain from its spans and their groups and moves as written (None if it stays as it
    is), the motion in force after it: GROUP (none) or a motion code, the feed (mm/s) and the plane in force
    after it. Groups and moves written for runs of G1 moves take the lowest feed of the moves they replace
    (feeds differ in a chain only beyond the machine's reach); a kept move after them gets its own back.
    An arc written in another plane than the program's carries its plane code, and the next arc the program's
    (groups and G1 moves do not depend on it)."""
    out: list[str] = []
    mode: str | None = None  # the motion in force after what was written (GROUP: none)
    changed = False
    feed_mm_s = None  # the feed in force where this text has set it (the chain's first block may carry it)
    plane = frame.plane  # the plane in force after what was written
    for span, written in zip(spans, groups):
        moves = chain.moves[span.first:span.last]
        group = _group_for(written, moves[0].line, report) if written is not None else None
        if group is None:
            src = [lines[m.line - 1] for m in moves]
            if changed and mode != motion_code(moves[0]):  # pure blocks: G1/G2/G3 or none; the program's feed
                feed = None if moves[0].feed_mm_s == feed_mm_s else feed_text(moves[0].feed_mm_s, frame)
                src[0] = restored(src[0], motion_code(moves[0]), feed)
            elif changed and moves[0].feed_mm_s != feed_mm_s:
                src[0] = with_feed(src[0], feed_text(moves[0].feed_mm_s, frame))
            arc = next((k for k, m in enumerate(moves) if isinstance(m, Arc)), None)  # the first to need a plane
            if plane != frame.plane and arc is not None:
                src[arc], plane = _planed(src[arc], PLANE_CODE[frame.plane]), frame.plane
            out += src
            if span.kept:
                report.kept_g01.append((moves[0].line, NO_SAVING))
            mode, feed_mm_s = motion_code(moves[-1]), moves[-1].feed_mm_s
        elif span.one_moves:
            feed = _lowest_feed(moves)
            blocks = [group[0] if feed == feed_mm_s else with_feed(group[0], feed_text(feed, frame))] + group[1:]
            for k, move in enumerate(span.one_moves):
                if move.centre_mm is not None and move.plane != plane:
                    blocks[k], plane = _planed(blocks[k], PLANE_CODE[move.plane]), move.plane
            out += blocks
            changed = True
            mode, feed_mm_s = span.one_moves[-1].code, feed
            report.feeds_merged += sum(a.feed_mm_s != b.feed_mm_s for a, b in zip(moves, moves[1:]))
            arcs = sum(m.centre_mm is not None for m in span.one_moves)
            report.arcs += arcs
            report.lines += len(span.one_moves) - arcs
            report.moves_replaced += len(moves)
        else:
            out += group
            mode, changed = GROUP, True
            feed_mm_s = _lowest_feed(moves)
            report.feeds_merged += sum(a.feed_mm_s != b.feed_mm_s for a, b in zip(moves, moves[1:]))
            report.groups += 1
            report.moves_replaced += len(moves)
            report.sharp_corners += span.corners()
            report.double_knots += span.double_knots
    if not changed:
        return None, None, None, None
    return out, mode, feed_mm_s, plane


def _planed(text: str, code: str | None) -> str:
    """A motion block (or the block restore_plane chose) with the plane code `code` (None: as it is)."""
    if code is None:
        return text
    out = with_plane(text, code)
    if out is None:
        raise ValueError(f"a block that cannot carry {code}: {text!r}")
    return out


def _lowest_feed(moves) -> float:
    """A group's F: the lowest its moves have (they differ only where all are beyond the machine's reach)."""
    return min(m.feed_mm_s for m in moves)


def _group_for(written: _Written, line: int, report: ConvertReport) -> list[str] | None:
    """The group's blocks, or None where the curve as written is off or the controller refuses it (and why)."""
    if written.off:
        report.kept_g01.append((line, f"rounded curve {written.deviation_mm * 1e3:.3f} um off"))
        return None
    if written.refused is not None:
        report.kept_g01.append((line, f"{REFUSED}: {written.refused}"))
        return None
    report.max_deviation_mm = max(report.max_deviation_mm, written.deviation_mm)
    return written.text
